# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip contact (lip collision that keeps the lower lip clean): the lips rest closed, so a
muscle that lifts one lip (the mentalis pushing the lower lip up, AU17; the orbicularis oris of one lip)
would push it through the other. Per control state, where the attachment targets of the two lip margins
cross (the lower margin above the upper one at the same x) while the lips are stacked (not one tucked
behind the other, as the lower lip goes behind the upper incisors for /f v/), both margins give way by
half the overlap and the lip tissue around them follows, fading over a few millimetres (3.1.2 "Mass Spring
Network": the attachment pairs carry the skin to the targets, so contact is resolved on the targets).
The commissures, where the lips meet in small triangles, move as one piece (:meth:`LipContact.commissures`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["LipContact"]

TOLERANCE = 0.0002        # m of overlap the lips may press into each other before they give way
SPREAD = 0.009            # m over the skin from the margin over which the lip tissue follows the margin
STACKED = (0.0015, 0.0035)  # m: lips this far apart front to back still touch fully / no longer touch
CORNER = 0.007           # m around each mouth corner (commissure) that moves as one piece
FITTED_CORNER = 0.020    # m: the same on a fitted head, around the middle of the mesh's own commissure
FITTED_ACROSS = 0.5      # share of that knot's sideways (x) blend: the corners still travel out and in


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _commissures(skin, rest: np.ndarray) -> list:
    """Per mouth corner: the nodes that move as one piece, their weights and the share of each axis blended.

    On the template the inner lip contours end where the lips meet at the corner, ~4 mm inside the outer
    contour's corner, and the knot is ``CORNER`` around that end. On a fitted head (it has a driven ring)
    the inner contours are the mesh's own lip margins, which stop where the artist's lips stop touching
    (the MakeHuman African head: 5 mm short of the corner, 6.4 mm from the outer contour's corner); the
    knot around their end left the mesh's commissure, small triangles between the margins' end and the
    outer corner, to muscles pulling a millimetre apart the opposite ways, and it folded whenever the lips
    pressed or rounded (mouthPress, mouthClose, viseme_PP, mouthPucker). There the knot is centred halfway
    between the margin's end and the outer corner and reaches ``FITTED_CORNER``; sideways it blends only
    ``FITTED_ACROSS``, so the corners still travel (mouthLeft/Right, mouthStretch) (3.1.2 "Muscles": the
    modiolus where the lip and cheek muscles meet)."""
    surface = ~skin.group("mouth_bag") | skin.group("lip_inner")
    fitted = skin.driven and "lips_outer_upper" in skin.contours
    corners = []
    for end in (skin.contours["lips_inner_upper"][0], skin.contours["lips_inner_upper"][-1]):
        centre, reach, axes = rest[end], CORNER, np.ones(3)
        if fitted:
            outer = np.asarray(skin.contours["lips_outer_upper"])[[0, -1]]
            corner = outer[np.argmin(np.linalg.norm(rest[outer] - rest[end], axis=1))]
            centre, reach = 0.5 * (rest[end] + rest[corner]), FITTED_CORNER
            axes = np.array([FITTED_ACROSS, 1.0, 1.0])
        distance = np.linalg.norm(rest - centre, axis=1)
        nodes = np.flatnonzero((distance < reach) & surface)
        corners.append((nodes, 1.0 - _smoothstep(distance[nodes] / reach), axes))
    return corners


class LipContact:
    """Keeps the lip margins' targets from crossing (module docstring). :meth:`build` returns None for a skin
    without both inner lip contours."""

    def __init__(self, upper: np.ndarray, lower: np.ndarray, rest_x: np.ndarray, members: list,
                 corners: list) -> None:
        self.upper, self.lower = upper, lower          # inner margin nodes, corners left out, by rest x
        self.rest_x = rest_x                           # (N,) rest x of every node
        self.members = members                         # per lip: (nodes that follow its margin, their weights)
        self.corners = corners                         # per commissure: (nodes, weights, axis shares)

    @classmethod
    def build(cls, skin, node_bone: np.ndarray) -> "LipContact | None":
        contours = skin.contours
        if "lips_inner_upper" not in contours or "lips_inner_lower" not in contours:
            return None
        rest = np.asarray(skin.vertices, np.float64)
        upper, lower = (np.asarray(contours[k])[1:-1] for k in ("lips_inner_upper", "lips_inner_lower"))
        if len(upper) < 3 or len(lower) < 3:
            return None
        upper, lower = upper[np.argsort(rest[upper, 0])], lower[np.argsort(rest[lower, 0])]
        distance = np.asarray(skin.lip_distance)
        near = (distance < SPREAD) & (~skin.group("mouth_bag") | skin.group("lip_inner"))
        members = []
        for margin, side in ((upper, 0), (lower, 1)):
            nodes = np.union1d(np.flatnonzero(near & (node_bone == side)), margin)
            fade = 1.0 - _smoothstep(distance[nodes] / SPREAD)
            fade[np.isin(nodes, margin)] = 1.0
            members.append((nodes, fade))
        return cls(upper, lower, rest[:, 0].copy(), members, _commissures(skin, rest))

    def commissures(self, target: np.ndarray, rest: np.ndarray) -> np.ndarray:
        """``target`` (N, 3) with each mouth corner moving as one piece: the displacement of the nodes
        around it blends into their mean displacement, fully at the corner, fading out at ``CORNER``. The
        corner's tiny triangles (where the lips meet) fold over when neighbours a millimetre apart follow
        different muscles and bones; a real commissure is a firm knot of fibres (the modiolus)."""
        out = target.copy()
        for nodes, weight, axes in self.corners:
            moved = target[nodes] - rest[nodes]
            mean = (weight[:, None] * moved).sum(axis=0) / weight.sum()
            share = weight[:, None] * axes[None, :]
            out[nodes] = rest[nodes] + (1.0 - share) * moved + share * mean
        return out

    def correction(self, target: np.ndarray) -> np.ndarray:
        """Vertical displacement (N,) that separates crossing lip margins in ``target`` (N, 3)."""
        up, low = target[self.upper], target[self.lower]
        up_order, low_order = np.argsort(up[:, 0]), np.argsort(low[:, 0])
        z_low_at_up = np.interp(up[:, 0], low[low_order, 0], low[low_order, 2])
        y_low_at_up = np.interp(up[:, 0], low[low_order, 0], low[low_order, 1])
        z_up_at_low = np.interp(low[:, 0], up[up_order, 0], up[up_order, 2])
        y_up_at_low = np.interp(low[:, 0], up[up_order, 0], up[up_order, 1])
        width = STACKED[1] - STACKED[0]
        touch_up = 1.0 - _smoothstep((np.abs(y_low_at_up - up[:, 1]) - STACKED[0]) / width)
        touch_low = 1.0 - _smoothstep((np.abs(low[:, 1] - y_up_at_low) - STACKED[0]) / width)
        lift = 0.5 * np.maximum(z_low_at_up - up[:, 2] - TOLERANCE, 0.0) * touch_up
        drop = 0.5 * np.maximum(low[:, 2] - z_up_at_low - TOLERANCE, 0.0) * touch_low
        out = np.zeros(len(target))
        if not (np.any(lift) or np.any(drop)):
            return out
        for (nodes, fade), margin, value in zip(self.members, (self.upper, self.lower), (lift, -drop)):
            out[nodes] += fade * np.interp(self.rest_x[nodes], self.rest_x[margin], value)   # smooth along x
        return out
