# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands photo-head`` and ``photo-talk``: a textured, rigged head from a photograph (thesis 3.2.4), and
that head talking inside its photograph (3.2.5). Every input is checked and every output path refused before
any work, so a bad photo writes nothing."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters.export import save_or_export
from ..adapters.outputs import atomic_output, check_output_dir, check_output_path, written
from ..face.objects import EXPORT_ROLES
from .images import load_photo, write_picture

__all__ = ["COMMANDS"]


def _photos(args) -> list:
    photos = [load_photo(args.image, "--image", face=args.face)[0]]
    if getattr(args, "profile", None):
        photos.append(load_photo(args.profile, "--profile", face=1, role="profile")[0])
    return photos


def _refuse_inputs(outputs: list[Path], args) -> None:
    inputs = [Path(p) for p in (args.image, getattr(args, "profile", None)) if p]
    for out in outputs:
        for source in inputs:
            if source.exists() and out.exists() and out.resolve() == source.resolve():
                raise UserError(f"{out} would overwrite an input photo; choose another output name")
    if len({o.resolve() for o in outputs}) != len(outputs):
        raise UserError("every output needs its own file name")


class PhotoHead:
    NAME = "photo-head"
    HELP = "make a textured head with a fitted face rig from a photo (+ a profile photo); writes .blend/.glb/.fbx"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--image", required=True, help="the photo of the face (JPEG, PNG, WebP, TIFF, BMP)")
        parser.add_argument("--profile", help="a second photo of the same person (a side view), fitted jointly")
        parser.add_argument("--face", type=int, default=1,
                            help="which face when the photo shows several (1 = the largest; the others are listed)")
        parser.add_argument("--model", default="default", help="morphable model: 'default' or a model file")
        parser.add_argument("--set", dest="edits", action="append", default=[], metavar="ATTRIBUTE=VALUE",
                            help="edit the person with the morphable model (repeatable, in order): e.g. "
                                 "younger-older=0.6, slender-obese=-0.4, caricature=1.3; the rig is fitted to the "
                                 "edited head and --composite shows it in the photo")
        parser.add_argument("--composite", help="also write the head rendered back into the photo (.png)")
        parser.add_argument("--name", default="FH Photo Head", help="name of the head object")
        parser.add_argument("--out", required=True, help="output .blend, .glb or .fbx")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend", ".glb", ".fbx"))
        extra = [check_output_path(args.composite, (".png",))] if args.composite else []
        _refuse_inputs([out, *extra], args)
        from ...faces_hands_addon.photo.edit import parse_edit
        edits = [parse_edit(text) for text in args.edits]
        photos = _photos(args)
        bpy.ops.wm.read_homefile(use_empty=True)
        from .jobs import build_head
        head, result = build_head(bpy.context, photos, args.name, args.model, progress, edits)
        outputs = [out]
        if args.composite:
            from ...faces_hands_addon.photo.into_photo import still
            with atomic_output(extra[0]) as tmp:
                write_picture(Path(tmp), still(result, photos[0].pixels))
            outputs.append(extra[0])
        save_or_export(bpy.context, head, out, EXPORT_ROLES)
        print(written(outputs))
        return 0


class PhotoTalk:
    NAME = "photo-talk"
    HELP = "make the face in a photo speak a text: an MPEG-4 clip (.mp4) or a folder of PNG frames and a WAV"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--image", required=True, help="the photo of the face")
        parser.add_argument("--text", required=True, help="what to say (emoticons like :-) become emotions)")
        parser.add_argument("--voice", default="en-us", help="espeak-ng voice (default en-us)")
        parser.add_argument("--rate", type=float, default=165, help="words per minute (default 165)")
        parser.add_argument("--fps", type=float, default=25.0, help="frames per second (default 25)")
        parser.add_argument("--face", type=int, default=1, help="which face when the photo shows several")
        parser.add_argument("--style", help="non-verbal behaviour style (blinks, brows, gaze): neutral, nodder, "
                                            "brow_raiser, reserved, expressive")
        parser.add_argument("--emotion", help="an emotion for the whole take (joy, fear, ... or activation,evaluation)")
        parser.add_argument("--seed", type=int, default=0, help="seed of the behaviour's random choices")
        parser.add_argument("--out", required=True, help="an .mp4 file (a .wav goes beside it) or a folder for "
                                                         "frame_00000.png ... and speech.wav")

    @staticmethod
    def run(args, progress) -> int:
        from ...faces_hands_addon.anim.timing import check_fps
        from ...faces_hands_addon.speech.takes import check_text_length
        out = Path(args.out).expanduser()
        folder = out.suffix == ""
        out = check_output_dir(out) if folder else check_output_path(out, (".mp4",))
        if folder and out.exists() and any(out.iterdir()):
            raise UserError(f"output folder {out} is not empty; give a new or empty folder")
        _refuse_inputs([out] if folder else [out, out.with_suffix(".wav")], args)
        check_fps(args.fps)
        check_text_length(args.text, args.rate)
        photos = _photos(args)
        bpy.ops.wm.read_homefile(use_empty=True)
        from .talk import talking_photo
        print(written(talking_photo(photos[0], args, out, folder, progress)))
        return 0


COMMANDS = [PhotoHead, PhotoTalk]
