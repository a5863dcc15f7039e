# SPDX-License-Identifier: GPL-3.0-or-later
"""The 26 feature points of thesis 6.2.3 (Table 6.5) found automatically on a hand photo: MediaPipe's palm
detector and 21 hand landmarks (:class:`.mediapipe_hands.HandDetector`, the extension's own numpy TFLite
runtime) give 19 of them directly, the other 7 are derived from those with the reference hand's own
proportions; the result is the photo input of :mod:`..hand.photo` (the RBF warp of 6.2.3). It lives beside the
markerless tracker that shares its detector (tracking uses the hand package, not the other way round).

* **Direct (19)**: finger tips I-V, DIP II-V, IP I, PIP II-V and MCP I-V are MediaPipe's ``*_tip``,
  ``*_dip``, ``thumb_ip``, ``*_pip`` and ``*_mcp`` (MediaPipe's ``thumb_mcp`` is the thumb's MCP joint, MCP I;
  its ``thumb_cmc`` has no feature point).
* **Derived (7)**: MediaPipe marks no skin outline. Each derived point is placed in a frame spanned by two
  direct points, at the coordinates it has in the same frame on the reference hand (the source feature
  points projected onto their fitting plane, as the warp does): the four interdigital webs from the two
  knuckles (MCPs) they lie between; radial and ulnar wrist and the head of the ulna from the wrist -> middle
  knuckle segment, with MediaPipe's ``wrist`` standing for the middle of the reference's two wrist points.
  The frame's second axis turns towards the thumb in both, so palm-side and back-side photos map alike.
* **Scale**: the thesis calibrates with two clicks on a ruler. Without clicks the hand's length (wrist ->
  middle finger tip) is given in millimetres and stands for the ruler, drawn from the wrist landmark to the
  middle finger's tip.

Refused with a clear message (nothing is built): no hand, more than one hand, a hand of the other side than
asked (a left hand, or a mirror image of a right one), a hand cut off at the photo's edge (a landmark at the
edge, or the landmark model less than :data:`WHOLE` sure of the hand: it draws cut-off fingers shortened).
"""
from __future__ import annotations

import numpy as np

from ..core.errors import UserError
from ..hand.features import FEATURE_NAMES

__all__ = ["DIRECT", "DERIVED", "derived_coordinates", "feature_pixels", "detect_photo_points", "SIDES_WORDS"]

DIRECT = {**{f"{f}_tip": f"{f}_tip" for f in ("thumb", "index", "middle", "ring", "pinky")},
          **{f"{f}_{p}": f"{f}_{p}" for f in ("index", "middle", "ring", "pinky") for p in ("dip", "pip")},
          "thumb_ip": "thumb_ip", **{f"{f}_mcp": f"{f}_mcp" for f in ("thumb", "index", "middle", "ring", "pinky")}}
WRIST = "wrist_centre"                 # MediaPipe's wrist; on the reference, the middle of its two wrist points
DERIVED = {"web_thumb_index": ("thumb_mcp", "index_mcp"), "web_index_middle": ("index_mcp", "middle_mcp"),
           "web_middle_ring": ("middle_mcp", "ring_mcp"), "web_ring_pinky": ("ring_mcp", "pinky_mcp"),
           "wrist_radial": (WRIST, "middle_mcp"), "wrist_ulnar": (WRIST, "middle_mcp"),
           "ulna_head": (WRIST, "middle_mcp")}
SIDES_WORDS = {"right": "a right hand", "left": "a left hand"}
EDGE = 0.01                            # a landmark nearer than this fraction of the photo's size to its edge
WHOLE = 0.9                            # the landmark model's presence below which part of the hand is missing
                                       # (measured on the rendered reference hand: 0.97 whole, 0.69-0.76 with
                                       # the finger tips cut off, where it puts shortened fingers inside the photo)


def _thumbward(points: dict[str, np.ndarray]) -> float:
    """+1 when the thumb lies counter-clockwise of the wrist -> middle knuckle direction, else -1 (2D)."""
    along = points["middle_mcp"] - points[WRIST]
    across = points["index_mcp"] - points["pinky_mcp"]
    return 1.0 if along[0] * across[1] - along[1] * across[0] > 0 else -1.0


def _frame(points: dict[str, np.ndarray], a: str, b: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u = points[b] - points[a]
    v = _thumbward(points) * np.array([-u[1], u[0]])
    return points[a], u, v


def _plane(source_points: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The source feature points in 2D coordinates of their fitting plane (6.2.3), plus the wrist centre."""
    names = list(FEATURE_NAMES)
    x = np.array([source_points[n] for n in names], np.float64)
    centre = x.mean(axis=0)
    _, vectors = np.linalg.eigh((x - centre).T @ (x - centre) / len(names))
    flat = (x - centre) @ vectors[:, [2, 1]]
    out = dict(zip(names, flat))
    out[WRIST] = 0.5 * (out["wrist_radial"] + out["wrist_ulnar"])
    return out


def derived_coordinates(source_points: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Derived point -> its (s, t) in the frame of its two anchors on the reference hand (module docstring)."""
    plane = _plane(source_points)
    out = {}
    for name, (a, b) in DERIVED.items():
        origin, u, v = _frame(plane, a, b)
        out[name] = np.linalg.solve(np.column_stack([u, v]), plane[name] - origin)
    return out


def feature_pixels(landmarks: dict[str, np.ndarray], source_points: dict[str, np.ndarray]) -> dict[str, list]:
    """The 26 feature points (pixels) from MediaPipe's named landmarks (``wrist`` and the 19 direct ones)."""
    points = {name: np.asarray(landmarks[mp], np.float64)[:2] for name, mp in DIRECT.items()}
    points[WRIST] = np.asarray(landmarks["wrist"], np.float64)[:2]
    for name, (s, t) in derived_coordinates(source_points).items():
        origin, u, v = _frame(points, *DERIVED[name])
        points[name] = origin + s * u + t * v
    return {name: [float(points[name][0]), float(points[name][1])] for name in FEATURE_NAMES}


def _found(detector, image: np.ndarray, source: str) -> list:
    """The landmarks of every distinct hand in ``image`` (a hand found twice by the palm detector counts once)."""
    from .mediapipe_hands import SCORE
    hands = []
    for _, box, keypoints in detector.palms(image):
        found = detector.landmarks(image, detector.crop_from_palm(box, keypoints))
        if found.presence < SCORE:
            continue
        size = float(np.linalg.norm(found.image[12, :2] - found.image[0, :2]))
        if all(np.linalg.norm(found.image[0, :2] - other.image[0, :2]) > 0.5 * size for other, _ in hands):
            hands.append((found, size))
    if not hands:
        raise UserError(f"{source}: no hand found; photograph one flat hand, fingers apart, on a plain background")
    if len(hands) > 1:
        raise UserError(f"{source}: {len(hands)} hands found; photograph one hand at a time")
    return hands


def detect_photo_points(image: np.ndarray, source_points: dict[str, np.ndarray], side: str, hand_length_mm: float,
                        source: str = "photo", detector=None) -> dict:
    """The photo input (:func:`.photo.check_photo`) of the one hand of ``side`` in ``image`` ((H, W, 3) RGB in
    [0, 1]): its 26 feature points and, standing for the ruler, the wrist -> middle tip segment of
    ``hand_length_mm``. ``detector``: a :class:`HandDetector` (default: MediaPipe's bundled models)."""
    from .mediapipe_hands import LANDMARK_NAMES, HandDetector
    if not (isinstance(hand_length_mm, (int, float)) and np.isfinite(hand_length_mm) and 80 <= hand_length_mm <= 300):
        raise UserError(f"the hand's length (wrist to middle finger tip) must be 80-300 mm, not {hand_length_mm!r}")
    image = np.asarray(image, np.float32)
    if image.ndim != 3 or image.shape[2] < 3 or min(image.shape[:2]) < 64:
        raise UserError(f"{source}: not a colour photo of at least 64 x 64 pixels")
    detector = detector or HandDetector()
    (found, size), = _found(detector, image[..., :3], source)
    h, w = image.shape[:2]
    margin = EDGE * max(h, w)
    xy = found.image[:, :2]
    outside = [LANDMARK_NAMES[k] for k in np.flatnonzero((xy[:, 0] < margin) | (xy[:, 0] > w - margin)
                                                         | (xy[:, 1] < margin) | (xy[:, 1] > h - margin))]
    if outside:
        raise UserError(f"{source}: part of the hand is outside the photo ({', '.join(outside)}); photograph the "
                        "whole hand with the wrist")
    if found.presence < WHOLE:
        raise UserError(f"{source}: part of the hand seems outside the photo or hidden (the detector is "
                        f"{100 * found.presence:.0f}% sure of a hand, {100 * WHOLE:.0f}% needed); photograph the "
                        "whole hand with the wrist, fingers apart")
    seen = found.side()
    if seen != side:
        raise UserError(f"{source}: the photo shows {SIDES_WORDS[seen]} (or a mirror image of {SIDES_WORDS[side]}); "
                        f"build the {seen} hand (--side {seen}) or photograph the {side} hand")
    landmarks = dict(zip(LANDMARK_NAMES, xy))
    points = feature_pixels(landmarks, source_points)
    ruler = [[float(v) for v in xy[0]], [float(v) for v in xy[12]]]
    return {"points": points, "ruler": ruler, "ruler_mm": float(hand_length_mm), "image": source}
