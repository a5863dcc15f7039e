# SPDX-License-Identifier: GPL-3.0-or-later
"""The default character (issue 35), measured as it ships (the installed extension, like ``make bench``):

* ``build_s``: nothing -> the rigged character in an empty file (MPFB2 body, armature, weights, materials,
  the face rig fitted to its head, both hand rigs), the service the Add menu and ``build-character`` run;
* ``live_tick_ms`` (and ``live_tick_cpu_ms``, its CPU time): one live-preview tick of the whole character (``common.live.live_step``: the layers read,
  face + head + hands stepped, the pose written into the simulation key and the pose bones) plus the
  depsgraph update that shows it, median over ticks of keyed motion (jaw, smile, head turn, both hands'
  finger flexors moving); ``live_tick_face_ms`` the same with the hands relaxed (a speech take);
* ``bake_s``: the 74 expressions (ARKit 52 + 15 visemes + 7 emotions) baked into shape keys of the body,
  after one settle has compiled the simulation kernels (``bake_cold_s`` includes that);
* a 30-s spoken clip (``./fh speak`` with a behaviour style, so the head turns): ``glb_mb``, morph
  ``targets``, the Khronos validator's errors, and three.js in headless chromium (``bench/client``) playing
  it: ``bone_move_mm``, how far a vertex at the back of the head moves (only bones move it), and
  ``weights_moving``, how many morph weights change over the clip;
* ``shapes_ok`` of ``bench/shapes.py`` on the character's face rig (goal >= 62 of 67).

Run: ``python bench/character.py`` (needs ``make install``; the clip part ``make bench-client``). Timing
figures are wall time on a shared machine: noisy. The last line is ``RESULT key=value ...``.
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench" / "character"
TICKS = 90
HAND_MUSCLES = ("flexor_digitorum_superficialis_index", "flexor_digitorum_profundus_middle")


def build(bpy) -> tuple[float, object]:
    services = _harness.addon_module("operators.character.services")
    started = time.perf_counter()
    body = services.build_character_object()
    return time.perf_counter() - started, body


def _key_motion(bpy, body, hands: bool) -> None:
    """Keyed controls over ``TICKS`` frames: jaw, smile, head yaw; with ``hands`` two finger flexors per hand."""
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, TICKS
    controls = {"jaw_open": 0.8, "zygomaticus_major_L": 1.0, "head_yaw": 0.3}
    if hands:
        controls.update({f"{m}_{s}": 0.9 for m in HAND_MUSCLES for s in "LR"})
    for name, peak in controls.items():
        path = f'["fh.ctrl.{name}"]'
        for frame, value in ((1, 0.0), (TICKS // 2, peak), (TICKS, 0.0)):
            body[f"fh.ctrl.{name}"] = value
            body.keyframe_insert(path, frame=frame)


def live_ticks(bpy, body, hands: bool) -> tuple[list[float], list[float]]:
    """Wall and CPU milliseconds of each tick (the CPU time is what a busy neighbour does not inflate)."""
    live = _harness.addon_module("operators.bases.live")
    _key_motion(bpy, body, hands)
    rig = _harness.addon_module("operators.adapters.rig_store").get_rig(body)
    rig.reset()
    wall, cpu = [], []
    for frame in range(1, TICKS + 1):
        bpy.context.scene.frame_set(frame)
        started, started_cpu = time.perf_counter(), time.process_time()
        live.live_step(bpy.context, body)
        bpy.context.view_layer.update()
        wall.append((time.perf_counter() - started) * 1000.0)
        cpu.append((time.process_time() - started_cpu) * 1000.0)
    return wall, cpu


def bake(bpy, body) -> tuple[float, float, int]:
    face = _harness.addon_module("operators.face.services")
    rig = _harness.addon_module("operators.adapters.rig_store").get_rig(body)
    started = time.perf_counter()
    rig.settled({"ctrl": {"jaw_open": 1.0, "eyelid_close_L": 1.0}})          # compiles the kernels
    compile_s = time.perf_counter() - started
    started = time.perf_counter()
    report = face.bake(bpy.context, body, "expressions", "all")
    bake_s = time.perf_counter() - started
    count = int(re.search(r"Baked (\d+)", report).group(1))
    return bake_s, bake_s + compile_s, count


def shapes(rig, folder: Path) -> dict:
    """bench/shapes.py on the character's face rig (saved by the engine)."""
    path = folder / "character_face.npz"
    rig.face.save(path)
    done = subprocess.run([sys.executable, str(ROOT / "bench" / "shapes.py"), "--rig", str(path)],
                          capture_output=True, text=True)
    (OUT / "shapes.txt").write_text(done.stdout + done.stderr)
    line = next((l for l in done.stdout.splitlines() if l.startswith("RESULT")), "")
    return dict(re.findall(r"(\w+)=([^\s]+)", line))


class _Primitive:
    """What ``gltf_client.play`` needs of a mesh: its index and rest positions (primitive 0: the skin)."""

    def __init__(self, glb, mesh: int, node: int):
        self.mesh = mesh
        world = glb.world_matrices()[node]
        self.base = glb.accessor(glb.gltf["meshes"][mesh]["primitives"][0]["attributes"]["POSITION"])
        self.linear, self.offset = world[:3, :3], world[:3, 3]

    def rest(self, vertices):
        return self.base[vertices] @ self.linear.T + self.offset


def speak(seconds: float = 30.0) -> tuple[Path, float]:
    """``./fh speak`` a ~``seconds`` line with a behaviour style (the head moves) into a GLB."""
    from gltf_client import text_for
    glb_path = OUT / "speech30.glb"
    started = time.perf_counter()
    done = subprocess.run([str(ROOT / "fh"), "speak", "--text", text_for(seconds), "--style", "nodder", "--out",
                           str(glb_path)], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"./fh speak failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return glb_path, time.perf_counter() - started


def spoken_clip(glb_path: Path) -> dict:
    """The clip's size, targets, the validator's report and three.js playing it (module docstring)."""
    from gltf_client import Glb, play, validate
    glb = Glb(glb_path)
    node = next(i for i, n in enumerate(glb.gltf["nodes"]) if "mesh" in n and "skin" in n)
    mesh = glb.gltf["nodes"][node]["mesh"]
    targets = len(glb.gltf["meshes"][mesh]["primitives"][0].get("targets", ()))
    report = validate([glb_path])[0]
    skin = _Primitive(glb, mesh, node)
    rest = skin.rest(np.arange(len(skin.base)))
    head = np.flatnonzero(rest[:, 1] > rest[:, 1].max() - 0.25)
    back = head[np.argmin(rest[head, 2])]                       # glTF: the face looks along +Z
    clip = glb.gltf["animations"][0]
    duration = max(float(glb.accessor(s["input"]).max()) for s in clip["samplers"])
    times = np.linspace(0.0, duration, 121)
    played = play(glb_path, skin, clip.get("name"), times, np.array([back]), [])
    positions = np.array(played["samples"]["positions"])[:, 0, :]
    influences = np.array(played["samples"]["influences"])
    return {"glb_mb": glb_path.stat().st_size / 1e6, "targets": targets, "validator_errors": report["numErrors"],
            "validator_warnings": report["numWarnings"], "clip_s": duration,
            "bone_move_mm": float(np.linalg.norm(positions - positions[0], axis=1).max() * 1000),
            "weights_moving": int(np.sum(np.ptp(influences, axis=0) > 1e-3)),
            "bound_tracks": played["info"]["boundTracks"], "tracks": len(played["info"]["tracks"])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-clip", action="store_true", help="leave out the 30-s clip (no node/chromium)")
    parser.add_argument("--skip-shapes", action="store_true", help="leave out bench/shapes.py")
    parser.add_argument("--ticks-only", action="store_true", help="the build and the live ticks only")
    parser.add_argument("--glb", type=Path, help="check this spoken clip only (no build, ticks, bake, shapes)")
    args = parser.parse_args(argv)
    if args.glb:
        clip = spoken_clip(args.glb.resolve())
        print(f"RESULT {' '.join(f'{k}={v}' for k, v in clip.items())}")
        return 0
    import bpy
    OUT.mkdir(parents=True, exist_ok=True)
    figures: dict = {}
    build_s, body = build(bpy)
    figures["build_s"] = build_s
    print(f"build: {build_s:.1f} s, {len(body.data.vertices)} vertices, {len(body.parent.data.bones)} bones")
    rig = _harness.addon_module("operators.adapters.rig_store").get_rig(body)
    for hands, key in ((False, "live_tick_face_ms"), (True, "live_tick_ms")):
        ticks, cpu = live_ticks(bpy, body, hands)
        figures[key] = float(np.median(ticks[5:]))
        figures[key.replace("_ms", "_cpu_ms")] = float(np.median(cpu[5:]))
        print(f"{key}: median {figures[key]:.2f} ms, p90 {np.percentile(ticks[5:], 90):.2f} ms "
              f"({1000 / figures[key]:.0f} fps); CPU median {np.median(cpu[5:]):.2f} ms")
    if args.ticks_only:
        print(f"RESULT {' '.join(f'{k}={v:.2f}' for k, v in figures.items())}")
        return 0
    figures["bake_s"], figures["bake_cold_s"], figures["expressions"] = bake(bpy, body)
    print(f"bake: {figures['expressions']} expressions in {figures['bake_s']:.1f} s "
          f"({figures['bake_cold_s']:.1f} s with the first compile)")
    with tempfile.TemporaryDirectory(prefix="fh-character-bench-") as tmp:
        if not args.skip_shapes:
            result = shapes(rig, Path(tmp))
            figures["shapes_ok"] = result.get("shapes_ok", "nan")
            figures["shapes_total"] = result.get("shapes_total", "nan")
            figures["blink_gap_mm"] = result.get("blink_gap_mm", "nan")
            print(f"shapes: {figures['shapes_ok']} of {figures['shapes_total']} (out/bench/character/shapes.txt)")
    if not args.skip_clip:
        path, figures["speak_s"] = speak()
        clip = spoken_clip(path)
        print(json.dumps(clip))
        figures.update({k: clip[k] for k in ("glb_mb", "targets", "validator_errors", "bone_move_mm",
                                             "weights_moving", "clip_s")})
    text = " ".join(f"{k}={v:.2f}" if isinstance(v, float) else f"{k}={v}" for k, v in figures.items())
    print(f"RESULT {text}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
