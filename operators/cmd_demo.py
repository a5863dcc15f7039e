# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands demo``: the main job on the embedded default data, written under one folder.

1. the default MEDUSA head: built, expressions baked (ARKit + visemes + emotions), a labelled contact
   sheet of neutral / every muscle / jaw / ARKit / visemes, the baked head as GLB, the rig as .blend;
2. the thesis' example sentence "Can you show me the way to the conference hall?" spoken with espeak-ng
   on that head: GLB + WAV (same start) and a contact sheet of frames at phoneme centres.
"""
from __future__ import annotations

import bpy

from . import bl_export, bl_face, bl_sheet
from .cmd_face import build_default, save_blend
from .cmd_speech import run_line
from .jobs import run_job
from .outputs import atomic_output, check_output_dir, written

NAME = "demo"
HELP = "run the main job on the embedded default data and list what it wrote"
SENTENCE = "Can you show me the way to the conference hall?"


def add_arguments(parser) -> None:
    parser.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    parser.add_argument("--quick", action="store_true", help="smaller contact sheet (muscles only)")


def _scaled(progress, start: float, end: float):
    return lambda fraction, message="": progress(start + (end - start) * fraction, message)


def run(args, progress) -> int:
    from .ops_face import BakeJob
    out_dir = check_output_dir(args.out)
    outputs = []
    _, rig_obj = build_default(_scaled(progress, 0.0, 0.05))
    rig = bl_face.get_rig(rig_obj)
    include = ("neutral", "muscles", "direct") + (() if args.quick else ("arkit", "visemes"))
    sheet = out_dir / "face_contact_sheet.png"
    with atomic_output(sheet) as tmp:
        bl_sheet.render_sheet(bpy.context, rig_obj, bl_sheet.expression_cells(rig, include), tmp, columns=10,
                              progress=_scaled(progress, 0.05, 0.5))
    outputs.append(sheet)
    print(run_job(BakeJob(bpy.context, rig_obj, "EXPRESSIONS", "all"), bpy.context,
                  _scaled(progress, 0.5, 0.7)))
    glb = out_dir / "face_expressions.glb"
    outputs.append(bl_export.export_rig(bpy.context, rig_obj, str(glb)))
    blend = out_dir / "face_rig.blend"
    save_blend(blend)
    outputs.append(blend)
    spec = {"text": SENTENCE, "out": str(out_dir / "speech.glb"), "sheet": str(out_dir / "speech_contact_sheet.png"),
            "extra_sheets": [(out_dir / "speech_contact_sheet_three_quarter.png", "three-quarter")]}
    outputs += run_line(spec, None, 30.0, _scaled(progress, 0.7, 1.0))
    progress(1.0, "demo finished")
    print(written(outputs))
    return 0
