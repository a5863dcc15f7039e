"""The pitch replay in Blender (thesis 6.3.4): the ball spinning along the reference trajectory with its axes,
trajectories as curves, calibrated cameras with their photos, a Workbench render that shows the ball; the
command line refusing bad input with nothing written."""
from __future__ import annotations

import importlib
import json

import numpy as np

from conftest import addon_module, run_fh


def _result():
    from faces_hands_addon.tracking.camera import Camera, look_at
    from faces_hands_addon.tracking.flight import RPM, fly
    from faces_hands_addon.tracking.pipeline import PitchResult
    from faces_hands_addon.tracking.reference import Reference
    from faces_hands_addon.tracking.setup import Calibration
    flight = fly([0.4, 0.0, 1.75], [0.0, 28.0, -0.5], [1600 * RPM, 0.0, 0.0], 0.6)
    times, curve = flight.samples(1e-3)
    result = PitchResult(front=flight.at(np.arange(8) / 80.0), back=flight.at(0.45 + np.arange(5) / 50.0))
    result.reference = Reference(curve[0], flight.velocity(0.0)[0], flight.spin, 0.6, curve, times, 0)
    result.orientations = np.eye(3)[None]
    eye = np.array([-3.0, 1.6, 1.8])
    R = look_at(eye, [0.4, 1.6, 1.6])
    camera = Camera("front_top", (160, 120), 150.0, 150.0, 80.0, 60.0, [0, 0, 0, 0], R, -R @ eye)
    return result, Calibration({"front_top": camera}, {}, {"front": 80.0}, np.array([0.0, 1.0, 0.0])), camera


def test_replay_objects_and_a_render_that_shows_the_ball(bpy_clean, tmp_path):
    bpy = bpy_clean
    package = addon_module("operators.tracking").__name__
    replay = importlib.import_module(f"{package}.replay")             # loaded on first use
    scene_mod = importlib.import_module(f"{package}.scene")
    from faces_hands_addon.tracking.ball_model import ball_model
    result, calibration, camera = _result()
    photo = tmp_path / "front_top.png"
    bpy.ops.image.new(name="photo", width=16, height=12)
    image = bpy.data.images["photo"]
    image.filepath_raw, image.file_format = str(photo), "PNG"
    image.save()
    objects = replay.build_replay(bpy.context, result, calibration, {"front_top": photo}, None, ball_model())
    ball = objects["ball"]
    assert {"ball", "reference", "measured", "cameras"} <= set(objects)
    assert len(ball.children) == 3                                      # the ball's local axes
    scene = bpy.context.scene
    first, last = scene.frame_start, scene.frame_end
    fps = scene.render.fps / scene.render.fps_base
    assert abs((last - first) - 0.6 * replay.SLOWDOWN * fps) <= 1      # 0.6 s in slow motion
    scene.frame_set(first)
    start = np.array(ball.matrix_world.translation)
    scene.frame_set((first + last) // 2)
    middle = np.array(ball.matrix_world.translation)
    assert np.linalg.norm(start - result.reference.curve[0]) < 1e-3 and middle[1] > start[1] + 5.0
    q0 = np.array(ball.rotation_quaternion)
    scene.frame_set(first + 2)                                          # 1600 rpm for 2 slowed-down frames
    turned = np.degrees(2 * np.arccos(min(1.0, abs(float(np.dot(q0, ball.rotation_quaternion))))))
    assert abs(turned - 1600 / 60 * 360 * 2 / (replay.SLOWDOWN * fps)) < 1.5
    assert objects["cameras"][0].data.background_images[0].image.filepath_raw == str(photo)
    scene.frame_set(first + 4)
    scene_mod.setup_render(scene, camera.size, "5")
    scene.display.shading.color_type = "VERTEX"
    picture = scene_mod.render_array(scene, objects["cameras"][0], camera.size)
    pixel = camera.project(np.array(ball.matrix_world.translation)[None])[0].astype(int)
    assert picture[pixel[1], pixel[0]].max() > 0.5 and picture[5, 5].max() < 0.1


def test_track_pitch_refuses_bad_input_and_writes_nothing(installed, tmp_path):
    photos = tmp_path / "photos"
    photos.mkdir()
    out = tmp_path / "replay.blend"
    result = run_fh(installed, "track-pitch", "--photos", photos, "--calib", tmp_path / "none.json", "--out", out)
    assert result.returncode != 0 and "calibration file" in result.stderr and not out.exists()
    calib = tmp_path / "calib.json"
    calib.write_text(json.dumps({"format": "faces_hands.pitch_calibration", "version": 1, "cameras": [],
                                 "pairs": {}, "strobes": {}}))
    result = run_fh(installed, "track-pitch", "--photos", photos, "--calib", calib, "--out", out)
    assert result.returncode != 0 and "no photo" in result.stderr and not out.exists()
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("x")
    result = run_fh(installed, "synth-pitch", "--pitch", "slider", "--out", full)
    assert result.returncode != 0 and "not empty" in result.stderr
    assert [p.name for p in full.iterdir()] == ["keep.txt"]
