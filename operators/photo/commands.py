# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands photo-head`` and ``photo-talk``: a textured, rigged head from a photograph (thesis 3.2.4), and
that head talking inside its photograph (3.2.5). Every input is checked and every output path refused before
any work, so a bad photo writes nothing."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters.export import save_or_export
from ..adapters.outputs import atomic_output, check_output_path, written
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
        parser.add_argument("--composite", help="also write the head rendered back into the photo (.png)")
        parser.add_argument("--name", default="FH Photo Head", help="name of the head object")
        parser.add_argument("--out", required=True, help="output .blend, .glb or .fbx")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend", ".glb", ".fbx"))
        extra = [check_output_path(args.composite, (".png",))] if args.composite else []
        _refuse_inputs([out, *extra], args)
        photos = _photos(args)
        bpy.ops.wm.read_homefile(use_empty=True)
        from .services import build_head
        head, result = build_head(bpy.context, photos, args.name, args.model, progress)
        outputs = [out]
        if args.composite:
            from ...faces_hands_addon.photo.into_photo import still
            with atomic_output(extra[0]) as tmp:
                write_picture(Path(tmp), still(result, photos[0].pixels))
            outputs.append(extra[0])
        save_or_export(bpy.context, head, out, EXPORT_ROLES)
        print(written(outputs))
        return 0


COMMANDS = [PhotoHead]
