# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands demo``: the main job on the embedded default data, written under one folder.

1. the default MEDUSA head: built, expressions baked (ARKit + visemes + emotions), a labelled contact
   sheet of neutral / every muscle / jaw / ARKit / visemes, the baked head as GLB, the rig as .blend;
2. morphable faces (thesis 3.2, 5.1): a contact sheet of the average face of the default model, +-2 on a
   few attributes, a caricature, and the Fig. 3.8 experiment (masculine, then higher eyebrows, without and
   with the masculinity constrained);
3. the thesis' example sentence "Can you show me the way to the conference hall?" spoken with espeak-ng
   on that head, both ways a studio ships it: engine-ready weights of the fixed target set (speech.glb) and
   the exact per-frame cache for offline renders (speech_cache.glb), their sizes printed; the WAV (same
   start) and contact sheets of frames at phoneme centres; and the thesis' "Hi! ;-) Can you show me the way
   to the conference hall? :-)" with non-verbal behaviour and the emoticons' wink and smile
   (speech_performance.glb and its sheet);
4. the anatomical reference hand (6.2): contact sheets of the preset poses (palm and thumb side) and of its
   geometric muscles bulging, the showcase motion baked and exported as GLB, the rig as .blend.
"""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.meshio import glb_document
from ..adapters.blendfile import save_blend
from ..adapters.outputs import atomic_output, check_output_dir, written
from ..adapters.rig_store import get_rig
from ..face import services as face, sheet
from ..hand import services as hand
from ..morph import services as morph, sheet as morph_sheet
from ..speech.batch import checked_spec
from ..speech.services import run_line

FPS = 30.0

SENTENCE = "Can you show me the way to the conference hall?"
#: the thesis' example of emotion tags in text (4.3.5): a wink and a smile, with non-verbal behaviour
PERFORMANCE = "Hi! ;-) Can you show me the way to the conference hall? :-)"


def _scaled(progress, start: float, end: float):
    return lambda fraction, message="": progress(start + (end - start) * fraction, message)


class Demo:
    NAME = "demo"
    HELP = "run the main job on the embedded default data and list what it wrote"

    @staticmethod
    def add_arguments(parser) -> None:
        parser.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
        parser.add_argument("--quick", action="store_true", help="smaller contact sheet (muscles only)")

    @staticmethod
    def run(args, progress) -> int:
        out_dir = check_output_dir(args.out)
        outputs = []
        rig_obj = face.build_default_rig_object(_scaled(progress, 0.0, 0.05))
        include = ("neutral", "muscles", "direct") + (() if args.quick else ("arkit", "visemes"))
        sheet_path = out_dir / "face_contact_sheet.png"
        with atomic_output(sheet_path) as tmp:
            sheet.render_sheet(bpy.context, rig_obj, sheet.expression_cells(get_rig(rig_obj), include), tmp,
                               columns=10, progress=_scaled(progress, 0.05, 0.5))
        outputs.append(sheet_path)
        print(face.bake(bpy.context, rig_obj, "expressions", "all", _scaled(progress, 0.5, 0.7)))
        outputs.append(face.export(bpy.context, rig_obj, str(out_dir / "face_expressions.glb")))
        blend = out_dir / "face_rig.blend"
        save_blend(blend)
        outputs.append(blend)
        outputs.append(_morph_sheet(out_dir, _scaled(progress, 0.7, 0.73)))
        weights = checked_spec({"text": SENTENCE, "out": str(out_dir / "speech.glb"),
                                "sheet": str(out_dir / "speech_contact_sheet.png")}, FPS)
        weights["extra_sheets"] = [(out_dir / "speech_contact_sheet_three_quarter.png", "three-quarter")]
        outputs += run_line(weights, None, FPS, _scaled(progress, 0.73, 0.8))
        cache = checked_spec({"text": SENTENCE, "out": str(out_dir / "speech_cache.glb"), "animation": "frames"}, FPS)
        cache["wav"] = False                                   # the same audio as speech.wav
        outputs += run_line(cache, None, FPS, _scaled(progress, 0.8, 0.84))
        performance = checked_spec({"text": PERFORMANCE, "out": str(out_dir / "speech_performance.glb"),
                                    "sheet": str(out_dir / "speech_performance_sheet.png"), "style": "neutral",
                                    "seed": "0"}, FPS)
        outputs += run_line(performance, None, FPS, _scaled(progress, 0.84, 0.87))
        outputs += hand.run_demo(out_dir, _scaled(progress, 0.87, 1.0))
        progress(1.0, "demo finished")
        print(written(outputs))
        print(_compare(out_dir / "speech.glb", out_dir / "speech_cache.glb"))
        return 0


def _morph_sheet(out_dir: Path, progress) -> Path:
    """The morphable-face contact sheet of the default model (average, attributes, caricature, Fig. 3.8)."""
    path = out_dir / "morph_contact_sheet.png"
    with atomic_output(path) as tmp:
        morph_face = morph.create_face_object(bpy.context)
        morph_sheet.render_sheet(bpy.context, morph_face, morph_sheet.demo_cells(morph.face_of(morph_face).model),
                                 tmp, progress=progress)
        bpy.data.objects.remove(morph_face)
    return path


def _compare(weights: Path, cache: Path) -> str:
    """Both ways of shipping the demo line: size and morph targets of each GLB."""
    lines = []
    for path, label in ((weights, "engine-ready weights"), (cache, "exact per-frame cache")):
        targets = max(len(m.get("extras", {}).get("targetNames", [])) for m in glb_document(path)["meshes"])
        lines.append(f"{path.name} ({label}): {path.stat().st_size / 1e6:.2f} MB, {targets} morph targets")
    return "\n".join(lines)
