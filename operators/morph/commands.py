# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands morph``: a morphed face in batch, e.g.
``morph --model default --set "masculine-feminine=-0.6" --constrain masculine-feminine
--set "mouth:narrow-wide=-0.4" --seed 3 --out face.glb``. The edits run in the order given."""
from __future__ import annotations

import argparse
from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ..adapters.export import ExportOptions, save_or_export
from ..adapters.outputs import atomic_output, check_output_path, written
from . import services, sheet


class _Ordered(argparse.Action):
    """Collect --set / --constrain / --caricature in the order they were given."""

    def __call__(self, parser, namespace, values, option_string=None):
        steps = list(getattr(namespace, "steps", None) or [])
        steps.append((self.dest, values))
        namespace.steps = steps


def parse_setting(text: str) -> tuple[list[str], str, float, str]:
    """``[segment[+segment]:]attribute[@shape|@colour]=value`` -> (segments, attribute, value, part)."""
    if "=" not in text:
        raise UserError(f"--set {text!r}: write attribute=value, e.g. masculine-feminine=0.6")
    name, _, value = text.rpartition("=")
    segments = []
    if ":" in name:
        where, _, name = name.partition(":")
        segments = [s.strip() for s in where.split("+") if s.strip()]
    part = "both"
    if "@" in name:
        name, _, part = name.partition("@")
    try:
        number = float(value)
    except ValueError:
        raise UserError(f"--set {text!r}: {value!r} is not a number") from None
    return segments, name.strip(), number, part.strip()


class Morph:
    INPUTS = ("model",)
    INPUT_WORDS = {"model": ("mask",)}
    NAME = "morph"
    HELP = "create a face from a morphable model (attributes, constraints, caricature) and save .glb/.fbx/.blend"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--model", default="default",
                            help="model file (.npz, .mat, .h5, .bin), 'default' (whole heads on the character's "
                                 "topology) or 'mask' (the synthetic 468-vertex face mask)")
        parser.add_argument("--face", choices=("average", "random", "example"), default=None,
                            help="start face (default: average; random when --seed is given)")
        parser.add_argument("--seed", type=int, default=None, help="seed of the random start face")
        parser.add_argument("--example", type=int, default=0, help="database example for --face example")
        parser.add_argument("--set", dest="set", action=_Ordered, metavar="[SEGMENT:]NAME=VALUE",
                            help="give the face an attribute value (absolute: the face ends with NAME=VALUE; "
                                 "repeatable, in order): e.g. mouth:narrow-wide=-0.4; NAME@shape or NAME@colour "
                                 "for one part")
        parser.add_argument("--constrain", dest="constrain", action=_Ordered, metavar="NAME",
                            help="keep this attribute's current value through the following edits")
        parser.add_argument("--caricature", dest="caricature", action=_Ordered, metavar="LEVEL",
                            help="caricature level (1 = unchanged)")
        parser.add_argument("--sheet", help="also render a contact sheet (.png) of the demo cells")
        parser.add_argument("--sheet-cells", choices=tuple(sheet.SHEETS), default="demo",
                            help="what the contact sheet shows: the demo cells, 12 random people, or every "
                                 "attribute at -2 / 0 / +2")
        parser.add_argument("--sheet-view", choices=tuple(sheet.VIEWS), default="front", help="view of the sheet")
        parser.add_argument("--sheet-columns", type=int, default=6, help="cells per row of the sheet")
        parser.add_argument("--character", action="store_true",
                            help="write the default character's body with this head (the model's head written "
                                 "into the character's mesh; models of the character's topology only)")
        parser.add_argument("--save-face", help="also save the face as JSON")
        parser.add_argument("--out", required=True, help="output .glb, .fbx or .blend")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".glb", ".fbx", ".blend"))
        extra = [check_output_path(p, (s,)) for p, s in ((args.sheet, ".png"), (args.save_face, ".json")) if p]
        if len({p.resolve() for p in [out, *extra]}) != 1 + len(extra):
            raise UserError("every output needs its own file name")
        if args.model not in ("", "default") and any(p.resolve() == Path(args.model).resolve()
                                                     for p in [out, *extra]):
            raise UserError("an output must not overwrite the model file")
        kind = args.face or ("random" if args.seed is not None else "average")
        progress(0.05, "loading the model")
        bpy.ops.wm.read_homefile(use_empty=True)
        obj = services.create_face_object(bpy.context, args.model, kind, args.seed or 0, args.example)
        for flag, value in getattr(args, "steps", None) or []:
            services.apply(obj, lambda face, flag=flag, value=value: _step(face, flag, value))
        face = services.face_of(obj)
        for line in face.history_lines():
            print(f"  {line}")
        for c in face.constraints:
            print(f"  constraint {c.attribute}: shape {c.shape}, now {face.value(c.attribute):.12f}")
        outputs = [out]
        if args.sheet:
            progress(0.3, "rendering the contact sheet")
            with atomic_output(extra[0]) as tmp:
                sheet.render_sheet(bpy.context, obj, sheet.SHEETS[args.sheet_cells](face.model), tmp,
                                   columns=max(1, args.sheet_columns), progress=progress, view=args.sheet_view)
            outputs.append(extra[0])
        if args.save_face:
            outputs.append(services.save_face(obj, args.save_face))
        if args.character:
            obj = _character_with(obj)
        _write(obj, out)
        print(written(outputs))
        return 0


def _step(face, flag: str, value: str) -> None:
    if flag == "set":
        segments, name, number, part = parse_setting(value)
        face.set_attribute_value(name, number, part, segments)
    elif flag == "constrain":
        face.constrain(value.strip(), "both")
    else:
        try:
            face.caricature(float(value))
        except ValueError:
            raise UserError(f"--caricature {value!r} is not a number") from None


def _character_with(obj):
    """The default character's body (a plain mesh) with the face's head written into it; the head object
    goes (the output is the character)."""
    from ...faces_hands_addon.character.body import character_mesh
    from ..character.objects import body_mesh
    body = bpy.data.objects.new("FH Character", body_mesh("FH Character", character_mesh()))
    bpy.context.scene.collection.objects.link(body)
    services.link_character(obj, body)
    coords = np.empty(len(body.data.vertices) * 3, np.float32)
    body.data.shape_keys.key_blocks[services.HEAD_KEY].data.foreach_get("co", coords)
    body.shape_key_clear()
    body.data.attributes["position"].data.foreach_set("vector", coords)
    body.data.update()
    bpy.data.objects.remove(obj)
    print(f"  the head written into the character's body ({len(body.data.vertices)} vertices)")
    return body


def _write(obj, out) -> None:
    save_or_export(bpy.context, obj, out, (), ExportOptions())


COMMANDS = [Morph]
