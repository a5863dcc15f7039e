# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand landmarks from ordinary video frames with MediaPipe's hand models (palm detection, then 21 landmarks in
a rotated crop), run by the numpy runtime (:mod:`...detector`); the markerless counterpart of the glove
(thesis 6.3.2).

Palm detection (192 x 192, RGB in [0, 1], letterboxed): 2016 SSD anchors (strides 8, 16, 16, 16; two anchors
per cell on the first layer, six on the others) each give a box and seven palm keypoints as offsets from the
anchor centre in input pixels, and a score logit; boxes above 0.5 are merged by weighted non-maximum
suppression. The hand's crop is the palm box turned so that the wrist -> middle-finger-knuckle keypoints point
up, enlarged 2.6 times and moved half a box towards the fingers. Landmarks (224 x 224 crop): 21 points in crop
pixels (with a relative depth), a presence score and the same points in metres about the hand's centre
("world landmarks"). Landmarks of one frame give the next frame's crop, as MediaPipe tracks.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from ..detector import Interpreter

__all__ = ["HandDetector", "HandLandmarks", "ssd_anchors", "LANDMARK_NAMES", "model_paths"]

LANDMARK_NAMES = ("wrist", "thumb_cmc", "thumb_mcp", "thumb_ip", "thumb_tip", "index_mcp", "index_pip", "index_dip",
                  "index_tip", "middle_mcp", "middle_pip", "middle_dip", "middle_tip", "ring_mcp", "ring_pip",
                  "ring_dip", "ring_tip", "pinky_mcp", "pinky_pip", "pinky_dip", "pinky_tip")
PALM_SIZE, LANDMARK_SIZE = 192, 224
SCORE = 0.5


def model_paths() -> tuple[Path, Path]:
    folder = Path(__file__).resolve().parents[2] / "assets" / "mediapipe"
    return folder / "palm_detection_full.tflite", folder / "hand_landmark_full.tflite"


def ssd_anchors() -> np.ndarray:
    """(2016, 2) anchor centres in [0, 1] of the full palm detector (fixed anchor size)."""
    out = []
    for stride, per_cell in ((8, 2), (16, 6)):
        cells = PALM_SIZE // stride
        y, x = np.mgrid[0:cells, 0:cells]
        centres = np.column_stack([(x.ravel() + 0.5) / cells, (y.ravel() + 0.5) / cells])
        out.append(np.repeat(centres, per_cell, axis=0))
    return np.vstack(out)


@dataclass
class HandLandmarks:
    """One hand in one frame: ``image`` (21, 3) pixel x, y and relative depth (pixels), ``world`` (21, 3)
    metres about the hand's centre (x right, y down, z away from the camera, as the image), ``presence``,
    ``handedness`` the model's score, above 0.5 for a right hand in an ordinary (not mirrored) photo
    (measured: 0.97 on a render of the right reference hand, 0.02 on its mirror image; :meth:`side`)."""
    image: np.ndarray
    world: np.ndarray
    presence: float
    handedness: float = 0.5

    def side(self) -> str:
        """"left" or "right": the hand in an ordinary (not mirrored) photo."""
        return "right" if self.handedness > 0.5 else "left"


def _sample(image: np.ndarray, centre, size: float, angle: float, out: int) -> np.ndarray:
    """A rotated square crop (``out`` x ``out``) of side ``size`` pixels around ``centre``, bilinear."""
    t = (np.arange(out) + 0.5) / out - 0.5
    u, v = np.meshgrid(t * size, t * size)
    c, s = np.cos(angle), np.sin(angle)
    x = centre[0] + c * u - s * v
    y = centre[1] + s * u + c * v
    channels = [ndimage.map_coordinates(image[..., k], [y - 0.5, x - 0.5], order=1, mode="nearest") for k in range(3)]
    return np.stack(channels, axis=-1).astype(np.float32)


class HandDetector:
    """MediaPipe's palm detector and hand landmark model on numpy (module docstring)."""

    def __init__(self, palm_model: str | Path | None = None, landmark_model: str | Path | None = None):
        default_palm, default_landmark = model_paths()
        self.palm = Interpreter(palm_model or default_palm)
        self.landmark = Interpreter(landmark_model or default_landmark)
        self.anchors = ssd_anchors()

    def palms(self, image: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """(score, box centre and size (4,) pixels, 7 keypoints (7, 2) pixels) of each palm found."""
        h, w = image.shape[:2]
        side = max(h, w)
        scale = side / PALM_SIZE
        offset = np.array([(side - w) / 2.0, (side - h) / 2.0])
        crop = _sample(image, np.array([w / 2.0, h / 2.0]), side, 0.0, PALM_SIZE)
        raw, logits = self.palm.run(crop[None])
        scores = 1.0 / (1.0 + np.exp(-np.clip(logits[0, :, 0], -100, 100)))
        keep = np.flatnonzero(scores > SCORE)
        out = []
        for k in keep[np.argsort(-scores[keep])]:
            r = raw[0, k] / PALM_SIZE
            centre = (self.anchors[k] + r[:2]) * PALM_SIZE * scale - offset
            size = r[2:4] * PALM_SIZE * scale
            points = (self.anchors[k] + r[4:].reshape(7, 2)) * PALM_SIZE * scale - offset
            box = np.concatenate([centre, size])
            if all(np.linalg.norm(box[:2] - o[1][:2]) > 0.5 * max(o[1][2], o[1][3]) for o in out):
                out.append((float(scores[k]), box, points))
        return out

    @staticmethod
    def crop_from_palm(box: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, float, float]:
        """(centre, side, angle) of the landmark crop for a palm (module docstring)."""
        wrist, middle = points[0], points[2]
        angle = np.arctan2(middle[1] - wrist[1], middle[0] - wrist[0]) + np.pi / 2
        size = max(box[2], box[3])
        shift = np.array([np.sin(angle), -np.cos(angle)]) * 0.5 * size
        return box[:2] + shift, 2.6 * size, float(angle)

    @staticmethod
    def crop_from_landmarks(points: np.ndarray) -> tuple[np.ndarray, float, float]:
        """The next frame's crop from this frame's landmarks (wrist -> middle knuckle up, 2 x their extent)."""
        wrist, middle = points[0, :2], points[9, :2]
        angle = np.arctan2(middle[1] - wrist[1], middle[0] - wrist[0]) + np.pi / 2
        c, s = np.cos(-angle), np.sin(-angle)
        local = (points[:, :2] - wrist) @ np.array([[c, s], [-s, c]])
        low, high = local.min(axis=0), local.max(axis=0)
        centre_local = 0.5 * (low + high)
        centre = wrist + centre_local @ np.array([[c, -s], [s, c]])
        return centre, 2.0 * float(np.max(high - low)), float(angle)

    def landmarks(self, image: np.ndarray, crop: tuple[np.ndarray, float, float]) -> HandLandmarks:
        centre, size, angle = crop
        patch = _sample(image, centre, size, angle, LANDMARK_SIZE)
        points, presence, handedness, world = self.landmark.run(patch[None])
        local = points[0].reshape(21, 3) / LANDMARK_SIZE - np.array([0.5, 0.5, 0.0])
        c, s = np.cos(angle), np.sin(angle)
        x = centre[0] + size * (c * local[:, 0] - s * local[:, 1])
        y = centre[1] + size * (s * local[:, 0] + c * local[:, 1])
        return HandLandmarks(np.column_stack([x, y, local[:, 2] * size]), world[0].reshape(21, 3), float(presence[0, 0]),
                             float(handedness[0, 0]))

    def track(self, frames) -> list[HandLandmarks | None]:
        """Landmarks of the (first) hand in each frame, following it from frame to frame."""
        out, crop = [], None
        for image in frames:
            found = None
            if crop is not None:
                found = self.landmarks(image, crop)
                if found.presence < SCORE:
                    found = None
            if found is None:
                palms = self.palms(image)
                if palms:
                    found = self.landmarks(image, self.crop_from_palm(palms[0][1], palms[0][2]))
                    if found.presence < SCORE:
                        found = None
            out.append(found)
            crop = self.crop_from_landmarks(found.image) if found is not None else None
        return out
