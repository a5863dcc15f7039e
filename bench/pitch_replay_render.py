"""Render a pitch replay (.blend from ``track-pitch``) to look at it: the whole flight from the side with both
trajectories, the hand in slow motion (three frames), and the view of a calibrated camera over its photo.
Usage: ``python bench/pitch_replay_render.py REPLAY.blend OUT_DIR``; prints the written PNGs and a RESULT line."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

import _harness

import bpy  # noqa: E402

render = _harness.addon_module("operators.common.render")


def camera(name, location, target, lens=35.0):
    data = bpy.data.cameras.new(name)
    data.lens = lens
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    direction = np.asarray(target) - np.asarray(location)
    obj.rotation_euler = __import__("mathutils").Vector(direction).to_track_quat("-Z", "Y").to_euler()
    return obj


def shot(scene, cam, path: Path, size=(1280, 720), frame=None) -> Path:
    if frame is not None:
        scene.frame_set(frame)
    render.setup_workbench(scene, size)
    scene.display.shading.color_type = "VERTEX"
    scene.display.shading.light = "STUDIO"
    scene.camera = cam
    scene.render.filepath = str(path)
    with render.quiet_stdout():
        bpy.ops.render.render(write_still=True)
    return path


def main() -> None:
    blend, out = Path(sys.argv[1]), Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    ball = bpy.data.objects["FH Pitch Ball"]
    hand = bpy.data.objects.get("FH Pitcher Hand")
    written = []
    side = camera("FH Look Side", (9.0, 7.0, 2.2), (0.2, 7.0, 1.3), 24.0)
    middle = (scene.frame_start + scene.frame_end) // 2
    written.append(shot(scene, side, out / "replay_side.png", frame=middle))
    if hand is not None:
        hand_frames = sorted({int(k.co[0]) for c in hand.animation_data.action.fcurves for k in c.keyframe_points}) \
            if hasattr(hand.animation_data.action, "fcurves") else [scene.frame_start]
        for k, frame in enumerate(np.linspace(scene.frame_start, scene.frame_start + 30, 3).astype(int)):
            scene.frame_set(int(frame))
            root = np.array(hand.matrix_world.translation)
            close = camera(f"FH Look Hand {k}", tuple(root + np.array([0.35, -0.45, 0.2])), tuple(root), 50.0)
            written.append(shot(scene, close, out / f"replay_hand_{k}.png", (960, 720)))
    near = camera("FH Look Release", (1.6, -0.6, 2.0), (0.4, 0.8, 1.7), 28.0)
    written.append(shot(scene, near, out / "replay_release.png", frame=scene.frame_start + 90))
    front = bpy.data.objects.get("FH Camera front_top")
    if front is not None:
        written.append(shot(scene, front, out / "replay_front_top.png", (800, 600), frame=middle))
    for path in written:
        print(f"wrote {path}")
    print(f"RESULT renders={len(written)} frames={scene.frame_end - scene.frame_start + 1} "
          f"hand={'yes' if hand is not None else 'no'} ball_keys={len(ball.animation_data.action.slots) if ball.animation_data else 0}")


if __name__ == "__main__":
    main()
