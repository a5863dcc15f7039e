"""The character's face rig refitted after a morph edit (thesis 3.2 -> 3.1.2), measured in the engine
(``character.refit``, what *Refit Face Rig* computes before it writes into Blender):

* **refit_s** (wall) and **refit_cpu_s** (this process's CPU, all threads) of one refit: the model's average
  head with masculine-feminine slid to +2 placed on the body, the face rig fitted to it, the eyes placed
  under the refitted lids, the brows painted; the machine may be shared, so both are given;
* **blink_gap_mm** (the larger lid gap of eyeBlinkLeft / eyeBlinkRight, ``face.audit``; goal <= 0.5) and
  **pp_lip_gap_mm** (viseme_PP's lip gap; its audit limit is 0.3) on that refitted rig, whose rest is the
  morphed head;
* **targets_s**: baking the ARKit 52 + 15 visemes again on the refitted rig (wall), **targets** their count
  (``--no-targets`` skips it);
* **click_s** (wall) and **click_cpu_s**: the whole *Refit Face Rig* operator in Blender on the character
  built with its hand rigs, its 67 targets baked, after the same edit (fit, targets baked again, written
  into the body); ``--no-click`` skips it;
* on **held-out heads**: the first ``--heldout N`` (default 5) of the model's held-out heads
  (``out/head_model_heldout.npz``, split by ``scripts/build_head_model.py``'s fixed seed: never in the PCA
  nor the attributes, never looked at while building the refit), each placed on the body as it is and
  refitted: the largest blink gap, the largest viseme_PP lip gap, how many pass both, the slowest refit.

Last line: ``RESULT refit_s=... refit_cpu_s=... blink_gap_mm=... pp_lip_gap_mm=... targets=... targets_s=...
click_s=... click_cpu_s=... heldout=... heldout_pass=... heldout_blink_max_mm=... heldout_pp_max_mm=... heldout_refit_s_max=...``."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402

from faces_hands_addon.anim.bakes import ShapesBake  # noqa: E402
from faces_hands_addon.character.fitting import build_character_rig  # noqa: E402
from faces_hands_addon.character.refit import refit_character_rig  # noqa: E402
from faces_hands_addon.face.audit_targets import audit_shapes  # noqa: E402
from faces_hands_addon.face.expressions import load_expressions  # noqa: E402
from faces_hands_addon.morph.editing import EditFace  # noqa: E402
from faces_hands_addon.morph.heads import head_model  # noqa: E402

HELD = _harness.ROOT / "out" / "head_model_heldout.npz"
CHECKED = ("eyeBlinkLeft", "eyeBlinkRight", "viseme_PP")


def refit(rig, model, head):
    wall, cpu = time.perf_counter(), time.process_time()
    new = refit_character_rig(rig, model, head)
    return new, time.perf_counter() - wall, time.process_time() - cpu


def closure(new, expressions) -> tuple[float, float]:
    """(larger blink lid gap, viseme_PP lip gap), mm."""
    rows = audit_shapes(new.face, expressions, CHECKED)["rows"]
    blink = max(rows["eyeBlinkLeft"][0]["gap_L"], rows["eyeBlinkRight"][0]["gap_R"])
    return float(blink), float(rows["viseme_PP"][0]["lip_gap"])


def click(expressions) -> tuple[float, float]:
    """(wall, CPU) seconds of the Refit Face Rig operator (module docstring)."""
    import bpy
    bake = _harness.addon_module("operators.bases.bake")
    jobs = _harness.addon_module("operators.bases.jobs")
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert bpy.ops.faces_hands.add_character(skeleton="game_engine", hands=True) == {"FINISHED"}
    body = bpy.data.objects["FH Character"]
    jobs.run_job(bake.BakeJob(bake.bake_inputs(bpy.context, body, animated=False), "EXPRESSIONS", expressions),
                 bpy.context)
    bpy.context.scene.faces_hands_morph.model_path = ""
    assert bpy.ops.faces_hands.morph_new_face(kind="average") == {"FINISHED"}
    body.select_set(True)
    assert bpy.ops.faces_hands.morph_link_character() == {"FINISHED"}
    assert bpy.ops.faces_hands.morph_set_attribute(name="masculine-feminine", part="shape", value=2.0) == {"FINISHED"}
    wall, cpu = time.perf_counter(), time.process_time()
    assert bpy.ops.faces_hands.morph_refit_character() == {"FINISHED"}
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--heldout", type=int, default=5, help="how many held-out heads to refit to (0: none)")
    parser.add_argument("--no-targets", action="store_true", help="do not time baking the targets again")
    parser.add_argument("--no-click", action="store_true", help="do not time the operator in Blender")
    args = parser.parse_args()
    expressions = {**load_expressions("arkit"), **load_expressions("visemes")}
    model = head_model()
    rig = build_character_rig("game_engine", hands=False)
    face = EditFace(model)
    face.create("average")
    face.set_attribute("masculine-feminine", 2.0)
    new, wall, cpu = refit(rig, model, face.shape)
    blink, pp = closure(new, expressions)
    print(f"strong edit (masculine-feminine +2): refit {wall:.2f} s wall, {cpu:.2f} s CPU; blink gap {blink:.2f} mm, "
          f"viseme_PP lip gap {pp:.2f} mm", flush=True)
    targets_s = float("nan")
    if not args.no_targets:
        start = time.perf_counter()
        bake = ShapesBake(new, expressions)
        while bake.step() < 1.0:
            pass
        targets_s = time.perf_counter() - start
        print(f"{len(bake.shapes)} targets baked again in {targets_s:.1f} s", flush=True)
    click_s = click_cpu = float("nan")
    if not args.no_click:
        click_s, click_cpu = click(expressions)
        print(f"Refit Face Rig in Blender (character with hands, {len(expressions)} targets): {click_s:.1f} s wall, "
              f"{click_cpu:.1f} s CPU", flush=True)
    held_blink, held_pp, held_s, passed = [], [], [], 0
    if args.heldout:
        with np.load(HELD) as data:
            held = np.asarray(data["vertices"], np.float64)[:args.heldout]
        for index, head in enumerate(held):
            one, seconds, _ = refit(rig, model, head)
            b, p = closure(one, expressions)
            held_blink.append(b)
            held_pp.append(p)
            held_s.append(seconds)
            passed += int(b <= 0.5 and p <= 0.3)
            print(f"held-out head {index}: refit {seconds:.2f} s, blink gap {b:.2f} mm, viseme_PP lip gap {p:.2f} mm",
                  flush=True)
    worst = (lambda values: f"{max(values):.2f}" if values else "nan")
    print(f"RESULT refit_s={wall:.2f} refit_cpu_s={cpu:.2f} blink_gap_mm={blink:.2f} pp_lip_gap_mm={pp:.2f} "
          f"targets={len(expressions)} targets_s={targets_s:.1f} click_s={click_s:.1f} click_cpu_s={click_cpu:.1f} heldout={len(held_s)} heldout_pass={passed} "
          f"heldout_blink_max_mm={worst(held_blink)} heldout_pp_max_mm={worst(held_pp)} "
          f"heldout_refit_s_max={worst(held_s)}")


if __name__ == "__main__":
    main()
