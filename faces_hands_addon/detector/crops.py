# SPDX-License-Identifier: GPL-3.0-or-later
"""What MediaPipe's detectors do around a model run, shared by every detector of the extension: SSD anchors,
rotated square crops in and out of the model's input (a crop is its centre in pixels, its side in pixels and
its angle: the crop's x axis is ``(cos a, sin a)`` in the image, y down), and weighted non-maximum
suppression of boxes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

__all__ = ["Crop", "ssd_anchors", "sample_crop", "from_crop", "weighted_nms", "box_iou"]


@dataclass(frozen=True)
class Crop:
    """A rotated square of the image: ``centre`` (x, y) pixels, ``size`` its side in pixels, ``angle`` radians."""
    centre: tuple[float, float]
    size: float
    angle: float = 0.0

    def axes(self) -> np.ndarray:
        """(2, 2): the crop's x and y axes in the image (rows)."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([[c, s], [-s, c]])


def ssd_anchors(input_size: int, strides: tuple[int, ...], per_cell: tuple[int, ...]) -> np.ndarray:
    """(A, 2) anchor centres in [0, 1] of an SSD detector with fixed anchor size (MediaPipe's
    ``SsdAnchorsCalculator``: ``per_cell`` anchors at every cell of each stride's grid, layers of equal stride
    merged)."""
    out = []
    for stride, count in zip(strides, per_cell):
        cells = input_size // stride
        y, x = np.mgrid[0:cells, 0:cells]
        centres = np.column_stack([(x.ravel() + 0.5) / cells, (y.ravel() + 0.5) / cells])
        out.append(np.repeat(centres, count, axis=0))
    return np.vstack(out)


def sample_crop(image: np.ndarray, crop: Crop, out: int, border: str = "nearest", flip: bool = False) -> np.ndarray:
    """The ``out`` x ``out`` model input of ``crop`` (bilinear; ``border`` "nearest" repeats the edge, "zero"
    pads black); ``flip`` mirrors it left to right (MediaPipe's iris model sees right eyes mirrored)."""
    t = ((np.arange(out) + 0.5) / out - 0.5) * crop.size
    u, v = np.meshgrid(t[::-1] if flip else t, t)
    (xx, xy), (yx, yy) = crop.axes()
    x = crop.centre[0] + xx * u + yx * v
    y = crop.centre[1] + xy * u + yy * v
    mode = "nearest" if border == "nearest" else "constant"
    channels = [ndimage.map_coordinates(image[..., k], [y - 0.5, x - 0.5], order=1, mode=mode, cval=0.0)
                for k in range(image.shape[2])]
    return np.stack(channels, axis=-1).astype(np.float32)


def from_crop(points: np.ndarray, crop: Crop, out: int, flip: bool = False) -> np.ndarray:
    """Model output points (N, 2 or 3) in the crop's input pixels -> image pixels; a third coordinate (relative
    depth in input pixels) is scaled like x."""
    points = np.asarray(points, np.float64)
    local = points[:, :2] / out - 0.5
    if flip:
        local[:, 0] = -local[:, 0]
    xy = np.asarray(crop.centre) + crop.size * (local @ crop.axes())
    if points.shape[1] == 2:
        return xy
    return np.column_stack([xy, points[:, 2] / out * crop.size])


def box_iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Intersection over union of ``box`` (x0, y0, x1, y1) with each row of ``boxes``."""
    x0 = np.maximum(box[0], boxes[:, 0])
    y0 = np.maximum(box[1], boxes[:, 1])
    x1 = np.minimum(box[2], boxes[:, 2])
    y1 = np.minimum(box[3], boxes[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    area = (box[2] - box[0]) * (box[3] - box[1])
    areas = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    return inter / np.maximum(area + areas - inter, 1e-12)


def weighted_nms(boxes: np.ndarray, scores: np.ndarray, extras: np.ndarray,
                 threshold: float = 0.3) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """MediaPipe's weighted non-maximum suppression: from the best remaining box, every box overlapping it by
    more than ``threshold`` (IoU) is merged into one, coordinates (box and ``extras``, e.g. keypoints)
    averaged with the scores as weights; the merged detection keeps the best score."""
    order = list(np.argsort(-scores, kind="stable"))
    out = []
    while order:
        best = order[0]
        overlap = box_iou(boxes[best], boxes[order]) > threshold
        group = [order[i] for i in np.flatnonzero(overlap)]
        weights = scores[group] / scores[group].sum()
        out.append((float(scores[best]), weights @ boxes[group], np.tensordot(weights, extras[group], axes=1)))
        order = [index for index, o in zip(order, overlap) if not o]
    return out
