# SPDX-License-Identifier: GPL-3.0-or-later
"""The default head's painted skin: eyebrows and lip vermilion as per-node colours over the skin tone.

A bare head hides the brow signals of 4.2.1 and 4.3.5 (raises at pitch maxima, the question raise, the
thinking frown): there is nothing dark to move. Painting the brows onto the skin nodes makes each brow
movement the skin's own movement, in Blender's renders and in an exported file (glTF ``COLOR_0``)
alike, with no extra geometry or texture.

The brow is a band under the template's upper brow contour (``eyebrow_*_upper``, the canonical face
mesh's brow line), thick at the head near the nose (``BROW_HEAD_HEIGHT``) and tapering to the tail
(``BROW_TAIL_HEIGHT``), the usual adult proportions. The vermilion is the visible surface inside the
outer lip contours (seen from the front), fading over ``LIP_SOFT_EDGE`` outside them.
"""
from __future__ import annotations

import numpy as np

#: linear RGB: the rig's skin material, dark brown brow hair, lip vermilion
SKIN_RGB = (0.80, 0.58, 0.47)
BROW_RGB = (0.030, 0.020, 0.014)
LIP_RGB = (0.62, 0.25, 0.24)
BROW_HEAD_HEIGHT = 0.0070   # m: brow height at its medial end
BROW_TAIL_HEIGHT = 0.0035   # m: at its lateral end
BROW_SOFT_EDGE = 0.0015     # m: the band fades over this distance at its top and ends
BROW_LOWER_FADE = 0.0035    # m: and over this at its lower edge (the hair thins out towards the lid)
LIP_STRENGTH = 0.8          # how much of the vermilion colour the lip nodes take
LIP_SOFT_EDGE = 0.001       # m


def _closest_on_polyline(points: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every point: its closest point on ``line`` and the arc-length fraction (0 at line[0]) there."""
    a, b = line[:-1], line[1:]
    ab = b - a
    lengths = np.linalg.norm(ab, axis=1)
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
    t = np.einsum("nsk,sk->ns", points[:, None, :] - a[None], ab) / np.maximum(lengths ** 2, 1e-18)
    t = np.clip(t, 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    distance = np.linalg.norm(points[:, None, :] - closest, axis=2)
    segment = np.argmin(distance, axis=1)
    rows = np.arange(len(points))
    fraction = (cumulative[segment] + t[rows, segment] * lengths[segment]) / max(cumulative[-1], 1e-18)
    return closest[rows, segment], fraction


def _band(x: np.ndarray, low: np.ndarray, high: np.ndarray, soft_low: float, soft_high: float) -> np.ndarray:
    """1 inside [low, high], fading linearly to 0 over ``soft_low`` below it and ``soft_high`` above."""
    below = np.clip((x - (low - soft_low)) / soft_low, 0.0, 1.0)
    above = np.clip(((high + soft_high) - x) / soft_high, 0.0, 1.0)
    return np.minimum(below, above)


def brow_weights(vertices: np.ndarray, contour: np.ndarray, surface: np.ndarray) -> np.ndarray:
    """Per node in [0, 1]: how much brow hair covers it, for one brow contour (node indices from the
    medial or the lateral end; the medial end is the one nearer the midline)."""
    line = vertices[contour]
    if abs(line[0, 0]) > abs(line[-1, 0]):
        line = line[::-1]          # medial end first
    closest, fraction = _closest_on_polyline(vertices, line)
    height = BROW_HEAD_HEIGHT + (BROW_TAIL_HEIGHT - BROW_HEAD_HEIGHT) * fraction
    offset = vertices - closest
    rise = offset[:, 2]
    sideways = np.linalg.norm(offset[:, :2], axis=1)   # off the band's ends, or behind the surface
    weight = _band(rise, -height + BROW_LOWER_FADE / 2, np.zeros_like(height), BROW_LOWER_FADE, BROW_SOFT_EDGE)
    weight *= np.clip(1.0 - (sideways - 0.003) / BROW_SOFT_EDGE, 0.0, 1.0)
    return weight * surface


def _inside_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Even-odd rule for 2D ``points`` against a closed ``polygon``."""
    x, y = points[:, 0:1], points[:, 1:2]
    x0, y0 = polygon[:, 0], polygon[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    crosses = (y0 > y) != (y1 > y)
    at = x0 + (y - y0) * (x1 - x0) / np.where(y1 == y0, 1e-18, y1 - y0)
    return (np.count_nonzero(crosses & (x < at), axis=1) % 2) == 1


def lip_weights(vertices: np.ndarray, outer_upper: np.ndarray, outer_lower: np.ndarray,
                surface: np.ndarray) -> np.ndarray:
    """Per node in [0, 1]: the lip vermilion, inside the outer lip contours seen from the front (x, z)."""
    ring = np.concatenate([vertices[outer_upper], vertices[outer_lower][::-1]])
    front = vertices[:, [0, 2]]
    flat = np.column_stack([front[:, 0], np.zeros(len(front)), front[:, 1]])
    ring_flat = np.column_stack([ring[:, 0], np.zeros(len(ring)), ring[:, 2]])
    closest, _ = _closest_on_polyline(flat, np.concatenate([ring_flat, ring_flat[:1]]))
    outside = np.linalg.norm(flat - closest, axis=1)
    inside = _inside_polygon(front, ring[:, [0, 2]])
    weight = np.where(inside, 1.0, np.clip(1.0 - outside / LIP_SOFT_EDGE, 0.0, 1.0))
    return weight * surface


def skin_colours(skin) -> np.ndarray:
    """Linear RGB per skin node (``SkinMesh``): skin tone, eyebrows, lips."""
    vertices = np.asarray(skin.vertices, np.float64)
    surface = skin.group("surface").astype(np.float64)
    colours = np.tile(np.asarray(SKIN_RGB, np.float64), (len(vertices), 1))
    lips = LIP_STRENGTH * lip_weights(vertices, np.asarray(skin.contours["lips_outer_upper"]),
                                      np.asarray(skin.contours["lips_outer_lower"]), surface)
    colours += lips[:, None] * (np.asarray(LIP_RGB) - colours)
    brows = np.zeros(len(vertices))
    for side in "LR":
        name = f"eyebrow_{side}_upper"
        if name in skin.contours:
            brows = np.maximum(brows, brow_weights(vertices, np.asarray(skin.contours[name]), surface))
    colours += brows[:, None] * (np.asarray(BROW_RGB) - colours)
    return colours
