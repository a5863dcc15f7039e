# SPDX-License-Identifier: GPL-3.0-or-later
"""The pitch replay from an ordinary high-speed video (no glove, no painted ball): the markerless counterpart
of thesis 6.3 for today's users.

* Hand: MediaPipe's 21 landmarks per frame (:mod:`.mediapipe_hands`); their metric "world landmarks" are placed
  in the calibrated camera by the pose that maps them onto the frame's landmark pixels
  (:func:`landmarks_in_world`), then carried into the world; the rig's joints stand in for the glove
  markers (:func:`landmark_layout`: the wrist and the index and little finger knuckles fix the root, as the
  three back-of-hand markers do) and the same joint-by-joint fit along each finger (:func:`.hand_pose.solve_hand`)
  gives root and joint angles.
* Ball: its silhouette in each frame (:mod:`.ball`), the distance from its image radius (``d = f R / r``),
  then the reference trajectory of Eq. 6.12 fitted to those positions; an unmarked ball shows no spin, so the
  spin is what the curvature of the flight asks for (the fit starts from none).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from .ball import find_silhouettes, refine_centre
from .camera import Camera, rotation_from_vector
from .glove import GloveLayout, glove_layout
from .hand_pose import solve_hand
from .images import foreground_threshold, hsv, undistort_image
from .mediapipe_hands import LANDMARK_NAMES, HandDetector
from .reference import Measured, fit_reference

__all__ = ["landmark_layout", "LANDMARK_MARKERS", "VideoResult", "track_video", "landmarks_in_world",
           "as_pitch_result"]

#: glove marker name -> (MediaPipe landmark, rig bone carrying it, place along the bone)
LANDMARK_MARKERS = {
    "back_index": ("index_mcp", "index-finger-metacarpal", 1.0), "back_centre": ("wrist", "wrist", 0.0),
    "back_ulnar": ("pinky_mcp", "pinky-finger-metacarpal", 1.0),
    "thumb_mcp": ("thumb_mcp", "thumb-metacarpal", 1.0), "thumb_ip": ("thumb_ip", "thumb-phalanx-proximal", 1.0),
    "thumb_nail": ("thumb_tip", "thumb-phalanx-distal", 1.0),
    **{f"{f}_{j}": (f"{f}_{m}", f"{f}-finger-phalanx-{b}", 1.0) for f in ("index", "middle", "ring", "pinky")
       for j, m, b in (("pip", "pip", "proximal"), ("dip", "dip", "intermediate"), ("nail", "tip", "distal"))},
}
REACH = 0.03          # m: landmarks are labelled already; they only need to be near the model
BACK_TOLERANCE = 0.03


def landmark_layout(skeleton) -> GloveLayout:
    """The rig's joints where MediaPipe puts its landmarks, as a glove whose every marker has its own colour
    (so the labels are the landmarks' names)."""
    markers = [{"name": name, "bone": bone, "along": along, "lateral": 0.0}
               for name, (_, bone, along) in LANDMARK_MARKERS.items()]
    doc = {"colours": list(LANDMARK_MARKERS), "markers": markers, "back": ["back_index", "back_centre", "back_ulnar"],
           "assignment": {name: name for name in LANDMARK_MARKERS}, "surface": False}
    return glove_layout(skeleton, np.zeros((1, 3)), doc)


def landmarks_in_world(camera: Camera, landmarks) -> np.ndarray:
    """(21, 3) world positions: the world landmarks (metres, axes like the camera's) turned and moved so that
    they project onto the image landmarks (Levenberg-Marquardt from the distance their spread implies), then
    carried from the camera into the world."""
    flat = camera.undistorted().with_pose(np.eye(3), np.zeros(3))
    model = landmarks.world - landmarks.world.mean(axis=0)
    pixels = landmarks.image[:, :2]
    spread_m = np.sqrt(np.mean(np.sum(model[:, :2] ** 2, axis=1)))
    spread_px = np.sqrt(np.mean(np.sum((pixels - pixels.mean(axis=0)) ** 2, axis=1)))
    depth = 0.5 * (flat.fx + flat.fy) * spread_m / max(spread_px, 1e-6)
    centre = flat.rays(pixels.mean(axis=0)[None], distorted=False)[0]
    start = np.concatenate([np.zeros(3), centre / centre[2] * depth])

    def residual(x):
        placed = flat.with_pose(rotation_from_vector(x[:3]), x[3:])
        return (placed.project(model, distorted=False) - pixels).ravel()

    x = least_squares(residual, start, method="lm").x
    in_camera = model @ rotation_from_vector(x[:3]).T + x[3:]
    return (in_camera - camera.t) @ camera.R


@dataclass
class VideoResult:
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    hands: list = field(default_factory=list)            # (time, HandPose, world landmarks)
    ball_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ball: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    reference: object = None
    warnings: list = field(default_factory=list)


def _ball_position(camera: Camera, image: np.ndarray, radius: float) -> np.ndarray | None:
    """The white ball's centre from one frame (its whiteness picked out first: the hand and the room are not
    white), distance from the image radius."""
    flat = camera.undistorted()
    _, saturation, value = hsv(image)
    grey = saturation < 0.2
    level = foreground_threshold(value[grey])
    white = np.where(grey & (value > level), value, 0.0)
    found = find_silhouettes(np.repeat(white[..., None], 3, axis=2), 12).silhouettes
    if not found:
        return None
    s = max(found, key=lambda item: item.area)
    f = 0.5 * (flat.fx + flat.fy)
    approximate = flat.centre + flat.rays(s.centre[None], distorted=False)[0] * f * radius / max(s.axes[0], 1e-6)
    pixel = refine_centre(flat, white, s, approximate, radius, 0.5 * level)
    distance = f * radius / max(0.5 * (s.axes[0] + s.axes[1]), 1e-6)
    return flat.centre + flat.rays(pixel[None], distorted=False)[0] * distance


def track_video(frames: list[np.ndarray], fps: float, camera: Camera, skeleton, ball_radius: float,
                detector: HandDetector | None = None, progress=None) -> VideoResult:
    """Hand poses and ball flight from the frames of one calibrated camera (module docstring)."""
    progress = progress or (lambda fraction, message="": None)
    detector = detector or HandDetector()
    layout = landmark_layout(skeleton)
    out = VideoResult(times=np.arange(len(frames)) / fps)
    flat = [undistort_image(f, camera) for f in frames]
    order = [LANDMARK_NAMES.index(LANDMARK_MARKERS[name][0]) for name in layout.names]
    progress(0.1, "hand landmarks")
    prior = None
    for k, found in enumerate(detector.track(flat)):
        if found is None:
            continue
        world = landmarks_in_world(camera.undistorted(), found)
        pose = solve_hand(skeleton, layout, world[order], layout.colours, prior, REACH, BACK_TOLERANCE)
        if pose is not None:
            out.hands.append((out.times[k], pose, world))
            prior = pose.angles
    if not out.hands:
        out.warnings.append("no hand was found in the video")
    progress(0.7, "ball")
    positions, times = [], []
    for k, image in enumerate(flat):
        p = _ball_position(camera, image, ball_radius)
        if p is not None:
            positions.append(p)
            times.append(out.times[k])
    out.ball, out.ball_times = np.array(positions).reshape(-1, 3), np.array(times)
    if len(positions) >= 4:
        t0 = out.ball_times[0]
        velocity = (positions[1] - positions[0]) / (times[1] - times[0])
        out.reference = fit_reference(out.ball, out.ball_times - t0, np.zeros((0, 3)),
                                      Measured(out.ball[0], velocity, np.zeros(3)), 200.0)
    else:
        out.warnings.append("the ball was found in fewer than 4 frames; no flight")
    return out


def as_pitch_result(video: VideoResult):
    """The video's measurements in the shape the replay takes (:class:`.pipeline.PitchResult`)."""
    from .pipeline import PitchResult
    result = PitchResult(front=video.ball, front_times=video.ball_times, warnings=list(video.warnings))
    result.reference = video.reference
    result.orientations = np.eye(3)[None]
    if video.hands:
        first = video.hands[0][0]
        result.hands = [(t - first, pose, world, None) for t, pose, world in video.hands]
        result.hand_times = np.array([t - first for t, *_ in video.hands])
    return result
