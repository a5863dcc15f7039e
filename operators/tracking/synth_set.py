# SPDX-License-Identifier: GPL-3.0-or-later
"""``synth-pitch``: a synthetic multi-exposure recording of one pitch with its ground truth.

Writes into the output folder:

* ``photos/<camera>.png``: one multi-exposure photo per camera (front and back ball pairs, four hand cameras);
* ``calibration/<camera>_board_<k>.png`` and ``calibration/<camera>_object.png`` with
  ``calibration/setup.json`` (the board, the object's sphere centres and colours per camera, the stereo
  pairs, the strobes, the pitcher's hand photo points), unless calibration is skipped;
* ``truth.json``: the pitch (initial position, velocity, spin), every flash's ball position and orientation,
  every hand exposure's root, joint angles and glove marker positions, and the true cameras.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...faces_hands_addon.tracking import meshes as tm
from ...faces_hands_addon.tracking.ball_model import ball_model
from ...faces_hands_addon.tracking.glove import glove_layout
from ...faces_hands_addon.tracking.hand_pose import couple_rotations
from ...faces_hands_addon.tracking.setup import setup_preset
from ...faces_hands_addon.tracking.synth import hand_motion, object_points, pitcher_hand, synthetic_pitch, synthetic_rig
from ..adapters.render import write_png
from .synth_render import Piece, ball_piece, render_calibration, render_photos, render_video

__all__ = ["write_synthetic_set", "BALL_IN_HAND"]

BALL_IN_HAND = np.array([0.05, -0.012, -0.118])    # the ball's centre in the rest hand's frame while gripped


def _png(image: np.ndarray, path: Path) -> None:
    rgba = np.concatenate([image[::-1], np.ones(image.shape[:2] + (1,), np.float32)], axis=2)
    write_png(rgba, path)


def _hand_pieces(truth: dict, rig, layout, setup: dict, rng) -> tuple[list[Piece], dict]:
    model = ball_model()
    mesh = tm.ball_mesh(model)
    strobe = setup["strobes"]["hand"]
    light = np.asarray(strobe["position"], float)
    skeleton = rig.skeleton
    roots, angles = hand_motion(truth["spec"], truth["rng"], skeleton, skeleton.dof_names(), truth["hand_times"],
                                truth["release"], truth["velocity"], BALL_IN_HAND)
    angles = np.array([couple_rotations(skeleton, a) for a in angles])
    release_root = hand_motion(truth["spec"], np.random.default_rng(0), skeleton, skeleton.dof_names(),
                               np.zeros(1), truth["release"], truth["velocity"], BALL_IN_HAND)[0][0]
    held = release_root[:3, :3].T @ truth["orientation_at"](0.0)
    pieces, markers = [], []
    rest, faces, weights = rig.rest_positions.astype(np.float64), rig.faces, rig.skin_weights()
    for t, root, a in zip(truth["hand_times"], roots, angles):
        skin = tm.skinned(rest, weights, skeleton.bone_transforms(a), root)
        parts = [(skin, faces, np.full((len(skin), 3), 0.012))]
        points = layout.positions(skeleton, root, a)
        markers.append(points)
        for p, colour in zip(points, layout.colours):
            sphere = tm.icosphere(layout.radius, layout.rgb[colour], 2)
            parts.append((sphere.vertices + p, sphere.faces, sphere.colours))
        if t < 0:
            position, orientation = root[:3, :3] @ BALL_IN_HAND + root[:3, 3], root[:3, :3] @ held
        else:
            position, orientation = truth["flight"].at(t)[0], truth["orientation_at"](t)
        ball = ball_piece(mesh, orientation, position, light, strobe["ambient"], model.radius)
        parts += ball.parts
        pieces.append(Piece(parts, root[:3, 3] + root[:3, :3] @ np.array([0.0, 0.0, -0.08]), 0.16))
    hand = {"times": truth["hand_times"].tolist(), "roots": roots.tolist(), "angles": angles.tolist(),
            "dof_names": skeleton.dof_names(), "markers": np.array(markers).tolist(), "marker_names": layout.names,
            "marker_colours": layout.colours}
    return pieces, hand


SKIN_RGB = (0.8, 0.6, 0.5)


def _video(scene, out: Path, truth: dict, rig, setup: dict, cameras: dict, rng) -> tuple[list[Path], dict]:
    """The high-speed video (``video/frame_<k>.png`` and ``video/video.json``): the bare hand in skin colour,
    a plain white ball, from the video camera of the set-up."""
    spec = setup["video"]
    times = np.arange(spec["start"], spec["end"], 1.0 / spec["fps"])
    skeleton = rig.skeleton
    roots, angles = hand_motion(truth["spec"], np.random.default_rng([truth["seed"], 6]), skeleton,
                                skeleton.dof_names(), times, truth["release"], truth["velocity"], BALL_IN_HAND)
    angles = np.array([couple_rotations(skeleton, a) for a in angles])
    sphere = tm.icosphere(ball_model().radius, (0.92, 0.92, 0.92), 4)
    rest, faces, weights = rig.rest_positions.astype(np.float64), rig.faces, rig.skin_weights()
    frames = []
    for t, root, a in zip(times, roots, angles):
        skin = tm.skinned(rest, weights, skeleton.bone_transforms(a), root)
        ball = root[:3, :3] @ BALL_IN_HAND + root[:3, 3] if t < 0 else truth["flight"].at(t)[0]
        frames.append([Piece([(skin, faces, np.tile(SKIN_RGB, (len(skin), 1))),
                              (sphere.vertices + ball, sphere.faces, sphere.colours)], root[:3, 3], 0.2)])
    images = render_video(scene, cameras[spec["camera"]], frames, spec["background"], rng, setup["noise_sigma"])
    folder = out / "video"
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for k, image in enumerate(images):
        written.append(folder / f"frame_{k:04d}.png")
        _png(image, written[-1])
    written.append(folder / "video.json")
    written[-1].write_text(json.dumps({"format": "faces_hands.pitch_video", "version": 1, "camera": spec["camera"],
                                       "fps": spec["fps"]}, indent=1))
    ball = [truth["flight"].at(t)[0].tolist() if t >= 0 else None for t in times]
    return written, {"times": times.tolist(), "roots": roots.tolist(), "angles": angles.tolist(), "ball": ball}


def _truth_document(truth: dict, cameras: dict, hand: dict, photo: dict) -> dict:
    return {"format": "faces_hands.pitch_truth", "version": 1, "pitch": truth["pitch"], "seed": truth["seed"],
            "release": truth["release"].tolist(), "velocity": truth["velocity"].tolist(),
            "spin": truth["spin"].tolist(), "speed_mph": truth["speed_mph"], "spin_rpm": truth["spin_rpm"],
            "front": {"times": truth["front_times"].tolist(), "positions": truth["front_positions"].tolist(),
                      "orientations": truth["front_orientations"].tolist()},
            "back": {"times": truth["back_times"].tolist(), "positions": truth["back_positions"].tolist(),
                     "orientations": truth["back_orientations"].tolist()},
            "hand": hand, "hand_photo": photo, "cameras": [c.to_dict() for c in cameras.values()]}


def _calibration_setup(setup: dict, photo: dict) -> dict:
    spec = setup["calibration"]
    objects = {}
    for name, placement in spec["objects"].items():
        objects[name] = {"cameras": placement["cameras"], "colours": spec["colours"] * 2,
                         "points": object_points(placement["centre"], placement["size"]).tolist()}
    return {"format": "faces_hands.pitch_calibration_photos", "version": 1, "board": spec["board"],
            "sphere_radius": spec["sphere_radius"],
            "objects": objects, "pairs": setup["pairs"],
            "strobes": {k: {"hz": v["hz"]} for k, v in setup["strobes"].items()},
            "plate_direction": setup["plate_direction"], "hand": {"photo": photo},
            "single": [setup["video"]["camera"]] if "video" in setup else []}


def write_synthetic_set(scene, out: Path, pitch: str, seed: int, calibration: bool = True, progress=None,
                        video: bool = True) -> list[Path]:
    """Render one synthetic pitch set into ``out`` (module docstring); returns the written files."""
    progress = progress or (lambda fraction, message="": None)
    setup = setup_preset()
    cameras = synthetic_rig(seed, setup)
    truth = synthetic_pitch(pitch, seed, setup)
    progress(0.02, "building the pitcher's hand")
    rig, photo = pitcher_hand(seed)
    layout = glove_layout(rig.skeleton, rig.rest_positions.astype(np.float64))
    rng = np.random.default_rng([seed, 5])
    written = []
    (out / "photos").mkdir(parents=True, exist_ok=True)
    if calibration:
        progress(0.1, "rendering calibration photos")
        (out / "calibration").mkdir(parents=True, exist_ok=True)
        shots = render_calibration(scene, cameras, setup, rng)
        for name, shot in shots.items():
            for k, image in enumerate(shot["boards"]):
                written.append(out / "calibration" / f"{name}_board_{k}.png")
                _png(image, written[-1])
            written.append(out / "calibration" / f"{name}_object.png")
            _png(shot["object"], written[-1])
        written.append(out / "calibration" / "setup.json")
        written[-1].write_text(json.dumps(_calibration_setup(setup, photo), indent=1, sort_keys=True))
    progress(0.6, "rendering the multi-exposure photos")
    pieces, hand = _hand_pieces(truth, rig, layout, setup, rng)
    for name, image in render_photos(scene, cameras, setup, truth, pieces, rng).items():
        written.append(out / "photos" / f"{name}.png")
        _png(image, written[-1])
    document = _truth_document(truth, cameras, hand, photo)
    if video and "video" in setup:
        progress(0.85, "rendering the high-speed video")
        files, document["video"] = _video(scene, out, truth, rig, setup, cameras, rng)
        written += files
    written.append(out / "truth.json")
    written[-1].write_text(json.dumps(document, indent=1, sort_keys=True))
    return written
