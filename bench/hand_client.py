# SPDX-License-Identifier: GPL-3.0-or-later
"""The baked hand in a real glTF client, measured against the simulation it was baked from.

The user's file is the GLB of Bake Hand + Export Baked Hand: bone rotations on the WebXR-named armature and a
fixed set of corrective shape keys whose weights are keyed per frame (hand/bake.py, 6.2.1 + issue 13 step 6).
This bench makes that file the way an artist does (the add-on's operators in the installed extension: Build
Hand Rig, Animate Hand with a motion preset, Bake Hand, Export Baked Hand), then measures the skin three
ways, at every baked frame:

* **simulation** (the ground truth): the engine's own skin nodes, frame by frame, simulated again from the
  very contraction table the bake sampled (``BakeHandJob.contractions``; the simulation is deterministic, so
  this is the state the bake read its bone angles and weights from);
* **Blender**: the baked hand object evaluated by Blender's depsgraph at each frame (armature modifier +
  shape keys), i.e. what the artist sees after baking;
* **browser**: three.js (``GLTFLoader``, ``AnimationMixer`` stepped as a render loop does) in Debian's headless
  chromium reads every skin vertex's world position (``SkinnedMesh.getVertexPosition``: morph targets, then
  linear blend skinning, then ``matrixWorld``).

GLB vertices (split at UV seams) are matched to skin nodes by their rest positions. Reported: browser vs
Blender (what the export loses), Blender vs simulation and browser vs simulation (what skinning + corrective
keys lose), median / p95 / max over all vertices and frames, in mm, plus the fingertips' worst error and the
Khronos validator's counts. The run fails when the validator reports an error or the browser cannot play it.

``.venv/bin/python bench/hand_client.py [--motion showcase] [--fps 30]``; needs ``make install`` and
``make bench-client``. The last line is ``RESULT key=value ...``.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402  (the installed extension)
import bpy  # noqa: E402
import gltf_client as client  # noqa: E402
import numpy as np  # noqa: E402

OUT = _harness.ROOT / "out" / "bench" / "hand_client"


def make_glb(motion: str, fps: int, path: Path) -> tuple[object, object, dict]:
    """Build, animate, bake and export through the operators; returns (hand object, bake job, wall times)."""
    wall = {}
    started = time.perf_counter()
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = fps
    assert bpy.ops.faces_hands.build_hand_rig() == {"FINISHED"}
    obj = bpy.context.active_object
    wall["build_s"] = time.perf_counter() - started
    assert bpy.ops.faces_hands.animate_hand(motion=motion) == {"FINISHED"}
    job = _harness.addon_module("operators.hand.jobs").BakeHandJob(bpy.context, obj)     # the table the operator will sample
    started = time.perf_counter()
    assert bpy.ops.faces_hands.bake_hand() == {"FINISHED"}
    wall["bake_s"] = time.perf_counter() - started
    started = time.perf_counter()
    assert bpy.ops.faces_hands.export_hand(filepath=str(path)) == {"FINISHED"}
    wall["export_s"] = time.perf_counter() - started
    return obj, job, wall


def simulated(job) -> np.ndarray:
    """The engine's skin nodes (F, N, 3), mesh coordinates, simulated from the bake's contraction table."""
    from faces_hands_addon.hand.bake import simulate_frames
    return np.array([job.rig.positions for _ in simulate_frames(job.rig, job.contractions, job.dt)])


def blender_frames(obj, frames: list[int]) -> np.ndarray:
    """The baked object's evaluated vertices (F, V, 3) in world coordinates, frame by frame."""
    out = []
    world = np.array(obj.matrix_world)
    for frame in frames:
        bpy.context.scene.frame_set(frame)
        graph = bpy.context.evaluated_depsgraph_get()
        evaluated = obj.evaluated_get(graph)
        mesh = evaluated.to_mesh()
        co = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        evaluated.to_mesh_clear()
        out.append(co.reshape(-1, 3) @ world[:3, :3].T + world[:3, 3])
    return np.array(out)


def to_blender(points: np.ndarray) -> np.ndarray:
    """glTF's Y-up metres to Blender's Z-up metres (the exporter's +Y up conversion undone)."""
    return np.stack([points[..., 0], -points[..., 2], points[..., 1]], axis=-1)


def nearest(reference: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, float]:
    """For each point its nearest reference index, and the largest such distance (m)."""
    from scipy.spatial import cKDTree
    distance, index = cKDTree(reference).query(points)
    return index, float(distance.max())


def stats(errors_m: np.ndarray) -> dict:
    mm = errors_m.ravel() * 1000.0
    return {"median": float(np.median(mm)), "p95": float(np.percentile(mm, 95)), "max": float(mm.max())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--motion", default="showcase", help="motion preset to bake (default showcase)")
    parser.add_argument("--fps", type=int, default=30, help="scene frame rate (default 30)")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / f"{args.motion}.glb"
    obj, job, wall = make_glb(args.motion, args.fps, path)
    truth = simulated(job)                                             # (F, N, 3) mesh coordinates
    world = np.array(obj.matrix_world)
    truth = truth @ world[:3, :3].T + world[:3, 3]
    blender = blender_frames(obj, job.frames)
    validation = client.validate([path])[0]
    glb = client.Glb(path)
    mesh, _ = client.skin_mesh(glb)
    base = client.Skin(glb)
    vertex_count = len(base.base)
    times = (np.array(job.frames) - job.frames[0]) / float(args.fps)
    played = client.play(path, base, None, times, np.arange(vertex_count), [], influences=False)
    browser = to_blender(np.array(played["samples"]["positions"]))          # (F, V, 3)
    rest = to_blender(base.rest(np.arange(vertex_count)))                    # the GLB's own rest vertices
    rest_nodes = job.rig.rest_positions @ world[:3, :3].T + world[:3, 3]
    rest_blender = np.array([world[:3, :3] @ v.co + world[:3, 3] for v in obj.data.vertices])
    to_node, match_m = nearest(rest_nodes, rest)
    to_blender_vertex, match_b = nearest(rest_blender, rest)
    export = np.linalg.norm(browser - blender[:, to_blender_vertex], axis=-1)
    bake_blender = np.linalg.norm(blender[:, to_blender_vertex] - truth[:, to_node], axis=-1)
    bake_browser = np.linalg.norm(browser - truth[:, to_node], axis=-1)
    print(f"{args.motion}: {len(job.frames)} frames at {args.fps} fps, {len(truth[0])} skin nodes, {vertex_count} GLB "
          f"vertices (matched at rest within {match_m * 1000:.2f} mm to the simulation, {match_b * 1000:.2f} mm to "
          f"Blender); build {wall['build_s']:.1f} s, bake {wall['bake_s']:.1f} s, export {wall['export_s']:.2f} s")
    print(f"  validator: {validation['numErrors']} errors, {validation['numWarnings']} warnings, {validation['numInfos']} infos;"
          f" three.js r{played['info']['revision']} played clip '{played['info']['clip']}' "
          f"{played['info']['duration']:.3f} s, {played['info']['boundTracks']}/{len(played['info']['tracks'])} tracks bound")
    rows = {"browser vs Blender (export)": stats(export), "Blender vs simulation (bake)": stats(bake_blender),
            "browser vs simulation (what ships)": stats(bake_browser)}
    for label, s in rows.items():
        print(f"  {label:36s} median {s['median']:.3f} mm, p95 {s['p95']:.3f} mm, max {s['max']:.3f} mm")
    worst_export = int(np.argmax(export.max(axis=1)))
    print(f"  export's worst frame {job.frames[worst_export]}: max {export[worst_export].max() * 1000:.3f} mm, "
          f"{int((export[worst_export] > 1e-4).sum())} vertices over 0.1 mm")
    worst_frame = int(np.argmax(bake_browser.max(axis=1)))
    print(f"  worst frame {job.frames[worst_frame]} (t = {times[worst_frame]:.2f} s): max {bake_browser[worst_frame].max() * 1000:.2f} mm")
    ok = validation["numErrors"] == 0 and played["info"]["boundTracks"] == len(played["info"]["tracks"])
    print(f"RESULT motion={args.motion} frames={len(job.frames)} validator_errors={validation['numErrors']} "
          f"validator_warnings={validation['numWarnings']} client_ok={int(ok)} "
          f"export_max_mm={rows['browser vs Blender (export)']['max']:.4f} "
          f"ships_vs_sim_median_mm={rows['browser vs simulation (what ships)']['median']:.3f} "
          f"ships_vs_sim_p95_mm={rows['browser vs simulation (what ships)']['p95']:.3f} "
          f"ships_vs_sim_max_mm={rows['browser vs simulation (what ships)']['max']:.3f} "
          f"bake_s={wall['bake_s']:.1f} export_s={wall['export_s']:.2f}")
    return 0 if ok else 1


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
