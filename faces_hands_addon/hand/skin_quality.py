# SPDX-License-Identifier: GPL-3.0-or-later
"""Skin quality of a posed hand, measured on its triangle mesh: the acceptance measures for the hand's skin
(thesis 6.2: "geometric muscles deform the skin surface via a mass-spring system"), which must hold its shape
in every pose:

- :func:`edge_ratios`: every skin edge's length over its rest length (goal: all within 0.6-1.6);
- :func:`self_intersections`: skin triangle pairs that pass through each other (goal: 0). Triangles that share
  a vertex are not counted (neighbours meet by construction); two fingers that touch without crossing are
  not an intersection;
- :func:`surface_gap`: the smallest distance between two patches of skin (the pinch's fingertip gap).

Pure numpy/scipy; the intersection test is the segment-triangle test of Moller and Trumbore (1997) run for the
three edges of each triangle against the other triangle, both ways (two non-coplanar triangles intersect
exactly when an edge of one crosses the other); candidate pairs come from a k-d tree of the triangle centres.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..core import geometry

__all__ = ["edge_ratios", "intersecting_pairs", "self_intersections", "surface_gap", "patch_near", "thenar_bulge"]

_EPS = 1e-12            # rest edge length below which an edge has no ratio (units of the mesh)
_PARALLEL = 1e-9        # |det| over |segment| |edge 1| |edge 2|: a segment this near the triangle's plane misses


def edge_ratios(rest: np.ndarray, posed: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each skin edge's posed length over its rest length (edges of zero rest length are left out)."""
    edges = geometry.unique_edges(np.asarray(faces, dtype=np.int64))
    rest_len = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1)
    posed_len = np.linalg.norm(posed[edges[:, 0]] - posed[edges[:, 1]], axis=1)
    keep = rest_len > _EPS
    return posed_len[keep] / rest_len[keep]


def _segments_cross_triangles(p0, p1, a, b, c) -> np.ndarray:
    """Row-wise: does the segment p0-p1 cross the triangle abc (Moller-Trumbore, parameter in (0, 1))?"""
    direction = p1 - p0
    e1, e2 = b - a, c - a
    h = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, h)
    scale = np.linalg.norm(direction, axis=1) * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    ok = np.abs(det) > _PARALLEL * scale       # relative: the same answer in mm, m or inches
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p0 - a
    u = inv * np.einsum("ij,ij->i", s, h)
    q = np.cross(s, e1)
    v = inv * np.einsum("ij,ij->i", direction, q)
    t = inv * np.einsum("ij,ij->i", e2, q)
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < 1)


def _candidate_pairs(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Triangle pairs (i < j) near enough to touch and without a shared vertex."""
    corners = vertices[faces]
    centres = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centres[:, None], axis=2).max()
    pairs = cKDTree(centres).query_pairs(2.0 * radius, output_type="ndarray")
    if len(pairs) == 0:
        return pairs.reshape(0, 2)
    fa, fb = faces[pairs[:, 0]], faces[pairs[:, 1]]
    shared = (fa[:, :, None] == fb[:, None, :]).any(axis=(1, 2))
    return pairs[~shared]


def intersecting_pairs(vertices: np.ndarray, faces: np.ndarray, chunk: int = 200_000) -> np.ndarray:
    """The pairs (P, 2) of triangles without a shared vertex that pass through each other."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    pairs = _candidate_pairs(vertices, faces)
    found = []
    for start in range(0, len(pairs), chunk):
        part = pairs[start:start + chunk]
        tri_a, tri_b = vertices[faces[part[:, 0]]], vertices[faces[part[:, 1]]]
        hit = np.zeros(len(part), dtype=bool)
        for first, second in ((tri_a, tri_b), (tri_b, tri_a)):
            for k in range(3):
                hit |= _segments_cross_triangles(first[:, k], first[:, (k + 1) % 3],
                                                 second[:, 0], second[:, 1], second[:, 2])
        found.append(part[hit])
    return np.concatenate(found) if found else np.zeros((0, 2), dtype=np.int64)


def self_intersections(vertices: np.ndarray, faces: np.ndarray) -> int:
    """How many pairs of triangles without a shared vertex pass through each other."""
    return len(intersecting_pairs(vertices, faces))


def patch_near(rest: np.ndarray, point: np.ndarray, radius: float) -> np.ndarray:
    """Indices of the rest skin vertices within ``radius`` of ``point`` (a fingertip's pad)."""
    return np.flatnonzero(np.linalg.norm(rest - point, axis=1) <= radius)


def surface_gap(vertices: np.ndarray, patch_a: np.ndarray, patch_b: np.ndarray) -> float:
    """The smallest distance between a vertex of ``patch_a`` and one of ``patch_b`` (same units)."""
    distances, _ = cKDTree(vertices[patch_b]).query(vertices[patch_a])
    return float(distances.min())


THENAR = ("adductor_pollicis", "opponens_pollicis")     # the geometric muscles under the thenar eminence


def thenar_bulge(rig, muscle: str = "opponens_pollicis", settle_time: float = 2.0) -> float:
    """The thenar bulge (m) of a hand rig at full contraction of ``muscle`` (6.2.2, Fig. 6.18): the hand settles
    from rest with ``muscle`` at 1; at the joint angles reached, the skin is settled with and without the
    geometric muscles' bulge (:meth:`.rig.HandRig.bulge_lift`); the largest outward lift of a skin node whose
    heaviest geometric-muscle footprint is one of :data:`THENAR`. The rig is left reset."""
    rig.reset()
    rig.set_controls({muscle: 1.0})
    rig.relax(settle_time)
    lift, _, _ = rig.bulge_lift(rig.joint_angles)
    owner = rig.geometric.footprint_owner()
    region = np.isin(owner, [rig.geometric.names.index(n) for n in THENAR])
    rig.reset()
    return float(lift[region].max())
