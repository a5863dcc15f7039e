# SPDX-License-Identifier: GPL-3.0-or-later
"""The live hand preview's whole tick inside Blender (thesis 6.2.4's real-time claim, measured as the artist
waits for it): ``hand_live_tick_ms`` = the add-on's ``live_step`` with the hand's hook (contractions read from
the rig object, mix, pseudo muscles (Eqs. 6.1-6.9), finger contact, geometric muscles, skin substeps, armature
posed, rest-space skin written into the simulation shape key) + Blender's depsgraph evaluation of the skinned
result and its normals. The contractions follow the 'showcase' motion, a new value every tick.

Two paths in the same run: the compiled kernel (numba, loaded as in an interactive session, where the live
preview runs) and the numpy reference path. Medians of wall and CPU time per tick (CPU: every thread of the
process), then a second pass with step / write / depsgraph timed one by one.

Run: ``make install`` then ``.venv/bin/python bench/hand_live_tick.py``. Ends with one ``RESULT`` line.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402

import bpy  # noqa: E402
from live_tick import measure  # noqa: E402

from faces_hands_addon.hand import motion  # noqa: E402
from faces_hands_addon.physics import kernel  # noqa: E402

FRAME_DT = 1.0 / 30.0


def measure_hand(obj, table, names, compiled: bool) -> dict:
    """:func:`live_tick.measure` of the hand: the 'showcase' contractions, the hand's hook, the compiled
    (``compiled``) or the numpy path."""
    rig = _harness.EXTENSION.operators.adapters.rig_store.get_rig(obj)
    rig.hand.integrator.backend = rig.contact.backend = rig.pseudo.backend = "auto" if compiled else "numpy"
    rig.reset()

    def set_row(target, frame):
        for name, value in zip(names, table[frame]):
            target[f"fh.ctrl.{name}"] = float(value)

    return measure(obj, len(table), set_row, _harness.EXTENSION.operators.hand.objects.push_hand_pose, FRAME_DT)


def main() -> None:
    compiled = kernel.substep_kernel() is not None
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert bpy.ops.faces_hands.build_hand_rig() == {"FINISHED"}
    obj = bpy.context.active_object
    rig = _harness.EXTENSION.operators.adapters.rig_store.get_rig(obj)
    names = list(rig.muscle_names)
    times, table = motion.motion_table("showcase", names, 1.0 / FRAME_DT)
    print(f"settings: Blender {bpy.app.version_string}, hand '{obj.name}' {len(obj.data.vertices)} vertices, "
          f"{rig.hand.network.node_count} nodes, {rig.hand.network.springs.count} springs, {len(table)} ticks "
          f"of 1/30 s ('showcase' motion), one thread, load average {os.getloadavg()[0]:.1f}")
    result = []
    for label, use in (("compiled", True), ("numpy", False)):
        if use and not compiled:
            continue
        f = measure_hand(obj, table, names, use)
        print(f"{label:>8}: live tick {f['ms']:.2f} ms wall ({1e3 / f['ms']:.0f} fps), {f['cpu_ms']:.2f} ms CPU; "
              f"split: rig lookup {f['rig']:.3f} + step {f['step']:.2f} + write {f['write']:.2f} + depsgraph {f['depsgraph']:.2f} ms")
        suffix = "" if use else "_numpy"
        result.append(f"hand_live_tick_ms{suffix}={f['ms']:.2f} hand_live_fps{suffix}={1e3 / f['ms']:.0f} "
                      f"step_ms{suffix}={f['step']:.2f} write_ms{suffix}={f['write']:.2f} "
                      f"depsgraph_ms{suffix}={f['depsgraph']:.2f}")
    print(f"RESULT compiled={int(compiled)} " + " ".join(result))


if __name__ == "__main__":
    main()
