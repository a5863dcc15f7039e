# SPDX-License-Identifier: GPL-3.0-or-later
"""Faces and their 478 landmarks in a photograph, with MediaPipe's face models on the numpy runtime
(:mod:`..detector`): the automatic first step of fitting the morphable model to an image (thesis 3.2.4, where
the user clicked "about seven feature points"; 3.2.5).

* **Faces** (``face_detection_short_range``, 128 x 128, RGB in [-1, 1], letterboxed): 896 SSD anchors
  (strides 8, 16, 16, 16; 2 then 6 per cell) each give a box and six keypoints (eyes, nose tip, mouth, ears)
  as offsets in input pixels and a score logit; boxes over 0.5 are merged by weighted non-maximum
  suppression. The whole picture is searched first; when it holds no face, overlapping tiles of half, a
  quarter, ... of its size (down to :data:`MIN_TILE` pixels), so that small faces in large photos are found.
* **Landmarks** (``face_landmark``, 192 x 192, RGB in [0, 1]): the face's box made square (its long side),
  enlarged 1.5 times and turned so that the eyes lie on the crop's x axis; 468 points (x, y in crop pixels,
  a relative depth scaled like x) and a presence logit.
* **Eyes and irises** (``iris_landmark``, 64 x 64, RGB in [0, 1]): per eye a crop on its two corners (33-133
  and 362-263), 2.3 times their distance, the second eye mirrored; 71 eye-contour points replace the face
  model's points around that eye, and 5 iris points (centre first) become landmarks 468-472 (eye 33-133) and
  473-477 (eye 362-263), as in MediaPipe's 478-point face mesh.

Coordinates are image pixels of the oriented photo (x right, y down, pixel centres at +0.5); the third column
is MediaPipe's relative depth (pixels; smaller is nearer the camera).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..detector import Interpreter
from ..detector.crops import Crop, from_crop, sample_crop, ssd_anchors, weighted_nms

__all__ = ["FaceBox", "FaceLandmarks", "FaceFinder", "model_paths", "LANDMARKS", "IRIS_CENTRES",
           "EYE_CONTOUR_INDICES", "MIN_TILE"]

DETECT_SIZE, MESH_SIZE, IRIS_SIZE = 128, 192, 64
LANDMARKS = 478
IRIS_CENTRES = (468, 473)         # iris centres of the eyes around 33-133 (the subject's right) and 362-263
SCORE = 0.5
MIN_TILE = 480                    # px: smaller tiles would look for faces far under the size a fit needs
#: the face landmarks the iris model's 71 eye-contour points replace (eye 33-133; the other eye mirrored)
EYE_CONTOUR_INDICES = (
    (33, 7, 163, 144, 145, 153, 154, 155, 133, 246, 161, 160, 159, 158, 157, 173, 130, 25, 110, 24, 23, 22, 26,
     112, 243, 247, 30, 29, 27, 28, 56, 190, 226, 31, 228, 229, 230, 231, 232, 233, 244, 113, 225, 224, 223, 222,
     221, 189, 35, 124, 46, 53, 52, 65, 143, 111, 117, 118, 119, 120, 121, 128, 245, 156, 70, 63, 105, 66, 107,
     55, 193),
    (263, 249, 390, 373, 374, 380, 381, 382, 362, 466, 388, 387, 386, 385, 384, 398, 359, 255, 339, 254, 253, 252,
     256, 341, 463, 467, 260, 259, 257, 258, 286, 414, 446, 261, 448, 449, 450, 451, 452, 453, 464, 342, 445, 444,
     443, 442, 441, 413, 265, 353, 276, 283, 282, 295, 372, 340, 346, 347, 348, 349, 350, 357, 465, 383, 300, 293,
     334, 296, 336, 285, 417))
EYE_CORNERS = ((33, 133), (362, 263))
EYE_CONTOUR_FLIP = (False, True)


def model_paths() -> tuple[Path, Path, Path]:
    folder = Path(__file__).resolve().parents[2] / "assets" / "mediapipe"
    return (folder / "face_detection_short_range.tflite", folder / "face_landmark.tflite",
            folder / "iris_landmark.tflite")


def _sigmoid(x) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.clip(np.asarray(x, np.float64), -100.0, 100.0)))


@dataclass
class FaceBox:
    """A detected face: ``score``, ``box`` (x0, y0, x1, y1) pixels, ``keypoints`` (6, 2) pixels: the eye on
    the image's left, the other eye, nose tip, mouth centre, the ear on the image's left, the other ear."""
    score: float
    box: np.ndarray
    keypoints: np.ndarray

    @property
    def size(self) -> float:
        return float(max(self.box[2] - self.box[0], self.box[3] - self.box[1]))

    def crop(self) -> Crop:
        """The landmark model's crop (module docstring)."""
        centre = 0.5 * (self.box[:2] + self.box[2:])
        d = self.keypoints[1] - self.keypoints[0]
        return Crop((float(centre[0]), float(centre[1])), 1.5 * self.size, float(np.arctan2(d[1], d[0])))


@dataclass
class FaceLandmarks:
    """``points`` (478, 3): x, y pixels and relative depth; ``presence`` the face model's confidence;
    ``crop`` the crop they were found in."""
    points: np.ndarray
    presence: float
    crop: Crop

    @property
    def inter_ocular(self) -> float:
        """Pixels between the iris centres."""
        return float(np.linalg.norm(self.points[IRIS_CENTRES[0], :2] - self.points[IRIS_CENTRES[1], :2]))


class FaceFinder:
    """MediaPipe's face detector, face landmark and iris models on numpy (module docstring)."""

    def __init__(self, paths: tuple[Path, Path, Path] | None = None):
        detect, mesh, iris = paths or model_paths()
        self.detector, self.mesh, self.iris = Interpreter(detect), Interpreter(mesh), Interpreter(iris)
        self.anchors = ssd_anchors(DETECT_SIZE, (8, 16), (2, 6))

    def _detect_in(self, image: np.ndarray, crop: Crop) -> tuple[list, list, list]:
        tensor = sample_crop(image, crop, DETECT_SIZE, border="zero") * 2.0 - 1.0
        raw, logits = self.detector.run(tensor[None])
        scores = _sigmoid(logits[0, :, 0])
        keep = np.flatnonzero(scores > SCORE)
        boxes, points = [], []
        for k in keep:
            r = raw[0, k] / DETECT_SIZE
            centre, half = self.anchors[k] + r[:2], 0.5 * r[2:4]
            corners = from_crop(np.array([centre - half, centre + half]) * DETECT_SIZE, crop, DETECT_SIZE)
            boxes.append(corners.ravel())
            points.append(from_crop((self.anchors[k] + r[4:16].reshape(6, 2)) * DETECT_SIZE, crop, DETECT_SIZE))
        return boxes, points, list(scores[keep])

    def detect(self, image: np.ndarray) -> list[FaceBox]:
        """Every face found, largest first (module docstring: the whole picture, then finer tiles)."""
        h, w = image.shape[:2]
        side = float(max(h, w))
        tile = side
        while True:
            boxes, points, scores = [], [], []
            for crop in _tiles(w, h, tile):
                b, p, s = self._detect_in(image, crop)
                boxes += b
                points += p
                scores += s
            if scores:
                merged = weighted_nms(np.array(boxes), np.array(scores), np.array(points))
                faces = [FaceBox(score, box, keypoints) for score, box, keypoints in merged]
                return sorted(faces, key=lambda f: -f.size)
            tile /= 2.0
            if tile < MIN_TILE:
                return []

    def landmarks(self, image: np.ndarray, face: FaceBox) -> FaceLandmarks:
        """The 478 landmarks of ``face`` (module docstring), found in two passes: the second crop is taken
        from the first pass's landmarks (their eye line and extent), as MediaPipe tracks from frame to frame."""
        crop = face.crop()
        points, presence = self._mesh(image, crop)
        crop = _crop_from_points(points)
        points, presence = self._mesh(image, crop)
        points = self._refine_eyes(image, points)
        return FaceLandmarks(points, presence, crop)

    def _mesh(self, image: np.ndarray, crop: Crop) -> tuple[np.ndarray, float]:
        raw, flag = self.mesh.run(sample_crop(image, crop, MESH_SIZE)[None])
        return from_crop(raw.reshape(468, 3), crop, MESH_SIZE), float(_sigmoid(flag.ravel()[0]))

    def _refine_eyes(self, image: np.ndarray, points: np.ndarray) -> np.ndarray:
        out = np.zeros((LANDMARKS, 3))
        out[:468] = points
        for (a, b), indices, flip, iris_at in zip(EYE_CORNERS, EYE_CONTOUR_INDICES, EYE_CONTOUR_FLIP, IRIS_CENTRES):
            p, q = points[a, :2], points[b, :2]
            d = q - p
            size = 2.3 * float(max(abs(d[0]), abs(d[1])))
            crop = Crop(tuple(0.5 * (p + q)), size, float(np.arctan2(d[1], d[0])))
            contour, iris = self.iris.run(sample_crop(image, crop, IRIS_SIZE, flip=flip)[None])
            contour = from_crop(contour.reshape(71, 3), crop, IRIS_SIZE, flip=flip)
            iris = from_crop(iris.reshape(5, 3), crop, IRIS_SIZE, flip=flip)
            if flip:                      # the mirrored eye's iris ring runs the other way round
                iris = iris[[0, 3, 2, 1, 4]]
            index = np.asarray(indices)
            out[index, :2] = contour[:, :2]
            out[iris_at:iris_at + 5, :2] = iris[:, :2]
            out[iris_at:iris_at + 5, 2] = points[index[:16], 2].mean()
        return out


def _tiles(width: int, height: int, tile: float) -> list[Crop]:
    """Square crops of side ``tile`` covering the picture with half a tile of overlap (one for the whole)."""
    if tile >= max(width, height):
        return [Crop((width / 2.0, height / 2.0), float(max(width, height)))]
    out = []
    for cy in _stations(height, tile):
        for cx in _stations(width, tile):
            out.append(Crop((cx, cy), tile))
    return out


def _stations(length: int, tile: float) -> list[float]:
    if tile >= length:
        return [length / 2.0]
    count = int(np.ceil((length - tile) / (tile / 2.0))) + 1
    return list(np.linspace(tile / 2.0, length - tile / 2.0, count))


def _crop_from_points(points: np.ndarray) -> Crop:
    """The landmark crop from landmarks (as MediaPipe's face_landmark_landmarks_to_roi: the eye corners 33 and
    263 give the angle; the points' extent, here measured along that eye line, the square's side, enlarged
    1.5 times)."""
    d = points[263, :2] - points[33, :2]
    angle = float(np.arctan2(d[1], d[0]))
    c, s = np.cos(angle), np.sin(angle)
    axes = np.array([[c, s], [-s, c]])
    local = points[:, :2] @ axes.T
    low, high = local.min(axis=0), local.max(axis=0)
    centre = 0.5 * (low + high) @ axes
    size = 1.5 * float(np.max(high - low))
    if not np.isfinite(size) or size <= 0:
        raise UserError("the face landmarks collapsed to a point; correct them by hand")
    return Crop((float(centre[0]), float(centre[1])), size, angle)
