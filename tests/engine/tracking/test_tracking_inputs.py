"""Bad input to the pitch tracker (issue 39): missing calibration or cameras, photos of different sizes, no
ball found, clear messages, partial results, inputs never modified; and the numpy detector runtime against
numbers the official TFLite runtime gave for the same input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.detector import Interpreter
from faces_hands_addon.tracking.camera import Camera, look_at
from faces_hands_addon.tracking.mediapipe_hands import model_paths
from faces_hands_addon.tracking.pipeline import PitchTracker, check_photos
from faces_hands_addon.tracking.setup import Calibration, calibration_document, read_calibration


def _calibration(size=(64, 48)) -> Calibration:
    cameras = {}
    for name, z in (("front_top", 2.1), ("front_bottom", 1.3)):
        eye = np.array([-3.5, 1.5, z])
        R = look_at(eye, [0.0, 1.5, 1.6])
        cameras[name] = Camera(name, size, 60.0, 60.0, size[0] / 2, size[1] / 2, [0, 0, 0, 0], R, -R @ eye)
    return Calibration(cameras, {"front": ["front_top", "front_bottom"]}, {"front": 80.0}, np.array([0, 1.0, 0]))


def test_calibration_file_problems(tmp_path):
    with pytest.raises(UserError, match="does not exist"):
        read_calibration(tmp_path / "missing.json")
    broken = tmp_path / "broken.json"
    broken.write_text("{ not json")
    with pytest.raises(UserError, match="JSON"):
        read_calibration(broken)
    doc = calibration_document(_calibration())
    doc["pairs"]["back"] = ["back_left", "back_right"]
    bad_pair = tmp_path / "pair.json"
    bad_pair.write_text(json.dumps(doc))
    with pytest.raises(UserError, match="back_left"):
        read_calibration(bad_pair)
    good = tmp_path / "good.json"
    good.write_text(json.dumps(calibration_document(_calibration())))
    assert sorted(read_calibration(good).cameras) == ["front_bottom", "front_top"]


def test_photo_sizes_and_missing_cameras():
    calibration = _calibration()
    black = np.zeros((48, 64, 3), np.float32)
    with pytest.raises(UserError, match="32x48 pixels but camera front_top was calibrated at 64x48"):
        check_photos(calibration, {"front_top": np.zeros((48, 32, 3)), "front_bottom": black})
    with pytest.raises(UserError, match="no stereo pair has both photos"):
        check_photos(calibration, {"front_top": black})


def test_no_ball_found_gives_a_partial_result_and_leaves_the_photos_alone():
    calibration = _calibration()
    rng = np.random.default_rng(0)
    photos = {n: rng.uniform(0, 0.02, (48, 64, 3)).astype(np.float32) for n in calibration.cameras}
    before = {n: p.copy() for n, p in photos.items()}
    tracker = PitchTracker(calibration, photos)
    for _ in tracker.steps():
        pass
    result = tracker.result
    assert len(result.front) == 0 and result.reference is None and not result.table
    assert any("no ball found in the front pair" in w for w in result.warnings)
    assert any("no back pair photos" in w for w in result.warnings)
    assert all(np.array_equal(before[n], photos[n]) for n in photos)


def test_numpy_runtime_matches_the_tflite_runtime():
    """Reference numbers: tflite-runtime 2.14 on the same input (x ramp, y ramp, 0.5)."""
    palm_path, landmark_path = model_paths()
    model = Interpreter(landmark_path)
    h, w = model.input_shape[1:3]
    y, x = np.mgrid[0:h, 0:w]
    image = np.stack([x / w, y / h, 0.5 + 0 * x], axis=-1)[None].astype(np.float32)
    landmarks, presence, handedness, world = model.run(image)
    assert np.allclose(landmarks.ravel()[:5], [108.64917, 173.33264, 9.0e-05, 110.62801, 149.44441], atol=2e-3)
    assert landmarks.sum() == pytest.approx(4524.2588, abs=0.05)
    assert presence.item() == pytest.approx(0.02253, abs=1e-4)
    assert handedness.item() == pytest.approx(0.4382, abs=1e-4)
    assert world.sum() == pytest.approx(-0.1028, abs=1e-3)
    with pytest.raises(UserError, match="detector input"):
        model.run(np.zeros((1, 10, 10, 3)))
