# SPDX-License-Identifier: GPL-3.0-or-later
"""Synthetic target heads with KNOWN landmark positions, for testing and benchmarking the fitter.

A target is the canonical face re-triangulated from scratch (blue-noise points in its UV layout: a
jittered, randomly rotated hexagonal lattice, a cheap stand-in for Poisson-disk sampling; + Delaunay,
mapped back through the UV-to-surface barycentric map), with the eye and mouth openings cut
out as holes, then deformed by a known map ``F`` (local sculpt + non-uniform scale + similarity). The
ground truth landmarks are ``F(canonical vertices)``: the same surface points the template vertices
mark, so a fitter that recovers them has found corresponding locations (thesis 3.1.2 "Creating New
Animatable Head Models from the Template"). ``full_head`` adds a crude cranium/hair cap, ears, a neck and
shoulders whose chest reaches further forward than the nose. Deterministic for a given seed.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import Delaunay, cKDTree

from .. import assets
from .surface import TargetSurface
from .template import face_template

__all__ = ["SyntheticHead", "remeshed_face", "full_head", "rotated_head", "inside_polygon"]


@dataclass(frozen=True)
class SyntheticHead:
    """A test target mesh and the true positions of the 468 landmarks on it."""
    vertices: np.ndarray      # (N, 3)
    faces: np.ndarray         # (M, 3)
    truth: np.ndarray         # (468, 3) F(canonical vertices)
    face_width: float         # |truth[454] - truth[234]|
    symmetry_x: float         # the target's mirror plane is x = symmetry_x (when symmetric)
    description: str


def inside_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test of (K, 2) points against a closed (P, 2) polygon."""
    x, y = points[:, :1], points[:, 1:2]
    x1, y1 = polygon[:, 0], polygon[:, 1]
    x2, y2 = np.roll(x1, -1), np.roll(y1, -1)
    dy = np.where(y2 != y1, y2 - y1, 1e-300)
    crosses = ((y1 > y) != (y2 > y)) & (x < (x2 - x1) * (y - y1) / dy + x1)
    return crosses.sum(axis=1) % 2 == 1


def _resample_polyline(points: np.ndarray, spacing: float, closed: bool, phase: float) -> np.ndarray:
    """Points every ``spacing`` along a polyline, starting ``phase * spacing`` from its first point."""
    if closed:
        points = np.vstack([points, points[:1]])
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    count = max(int(arc[-1] / spacing), 3)
    stations = (np.arange(count) + phase) * (arc[-1] / count)
    if not closed:
        stations = np.concatenate([[0.0], stations[(stations > 0) & (stations < arc[-1])], [arc[-1]]])
    return np.stack([np.interp(stations, arc, points[:, k]) for k in range(points.shape[1])], axis=1)


def _hole_polygons(contours: dict) -> list[np.ndarray]:
    mouth = np.concatenate([contours["lips_inner_upper"], contours["lips_inner_lower"][-2:0:-1]])
    return [contours["eye_L"], contours["eye_R"], mouth]


def _remesh_canonical(spacing: float, rng: np.random.Generator, holes: bool):
    """Blue-noise re-triangulation of the canonical face; returns (vertices, faces) in canonical metres."""
    template = face_template()
    uv = np.asarray(assets.canonical_face().uvs, np.float64)
    metres_per_uv = template.width / (uv[454, 0] - uv[234, 0])
    step = spacing / metres_per_uv
    outline = template.contours["face_oval"]
    hole_polys = _hole_polygons(template.contours) if holes else []
    rim = [_resample_polyline(uv[outline], 0.8 * step, True, rng.uniform())]
    rim += [_resample_polyline(uv[p], 0.8 * step, True, rng.uniform()) for p in hole_polys]
    rim_points = np.vstack(rim)
    # jittered, randomly rotated hexagonal lattice (a cheap blue-noise / Poisson-disk stand-in)
    centre = uv.mean(axis=0)
    half = 0.75 * np.ptp(uv, axis=0).max()
    rows = np.arange(-half, half, step * np.sqrt(3) / 2)
    cols = np.arange(-half, half, step)
    gx, gy = np.meshgrid(cols, rows)
    gx = gx + (np.arange(len(rows))[:, None] % 2) * step / 2
    lattice = np.stack([gx.ravel(), gy.ravel()], axis=1)
    angle = rng.uniform(0, np.pi)
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    lattice = lattice @ rot.T + centre + rng.uniform(-0.2, 0.2, lattice.shape) * step
    keep = inside_polygon(lattice, uv[outline])
    for poly in hole_polys:
        keep &= ~inside_polygon(lattice, uv[poly])
    lattice = lattice[keep]
    gap, _ = cKDTree(rim_points).query(lattice)
    points = np.vstack([rim_points, lattice[gap > 0.6 * step]])
    points = np.unique(np.round(points, 12), axis=0)
    triangles = Delaunay(points).simplices
    centroid = points[triangles].mean(axis=1)
    keep = inside_polygon(centroid, uv[outline])
    for poly in hole_polys:
        keep &= ~inside_polygon(centroid, uv[poly])
    triangles = triangles[keep]
    d = points[triangles]
    u, v = d[:, 1] - d[:, 0], d[:, 2] - d[:, 0]
    signed = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]          # 2-D cross product (numpy 2 refuses np.cross here)
    triangles = np.where((signed < 0)[:, None], triangles[:, [0, 2, 1]], triangles)
    triangles = triangles[np.abs(signed) > 1e-14]
    used, triangles = np.unique(triangles, return_inverse=True)
    points = points[used]
    # UV -> surface: barycentric coordinates in the canonical UV triangle that holds each point
    flat = TargetSurface(np.column_stack([uv, np.zeros(len(uv))]), template.faces)
    hit = flat.closest(np.column_stack([points, np.zeros(len(points))]))
    corners = template.vertices[template.faces[hit.triangles]]
    vertices = (hit.barycentric[:, :, None] * corners).sum(axis=1)
    return vertices, triangles.reshape(-1, 3).astype(np.int64)


def _deformation(stretch, sculpt: str, scale: float, offset, pitch_degrees: float):
    """The known map F: local sculpt, non-uniform stretch, pitch about X, uniform scale, translation."""
    template = face_template()
    v = template.vertices
    bumps = []
    if sculpt in ("nose", "both"):        # a longer nose
        bumps.append((v[1], 0.012, 0.008 * np.array([0.0, -1.0, 0.0])))
    if sculpt in ("cheeks", "both"):      # fuller cheeks, left and right alike
        for index, side in ((280, 1.0), (50, -1.0)):
            bumps.append((v[index], 0.02, 0.006 * np.array([side, -1.0, 0.0]) / np.sqrt(2)))
    stretch = np.asarray(stretch, np.float64)
    c, s = np.cos(np.radians(pitch_degrees)), np.sin(np.radians(pitch_degrees))
    pitch = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    offset = np.asarray(offset, np.float64)

    def apply(points: np.ndarray) -> np.ndarray:
        out = np.array(points, np.float64)
        for centre, sigma, push in bumps:
            weight = np.exp(-((points - centre) ** 2).sum(1) / (2 * sigma * sigma))
            out += weight[:, None] * push
        return scale * (out * stretch) @ pitch.T + offset
    return apply


def remeshed_face(seed: int = 0, *, spacing: float = 0.005, stretch=(1.15, 1.05, 0.9), sculpt: str = "both",
                  scale: float = 1.7, offset=(0.3, -0.2, 1.4), pitch_degrees: float = 0.0,
                  holes: bool = True) -> SyntheticHead:
    """A face mask: the canonical face re-triangulated (edge length ~``spacing`` canonical metres),
    eye/mouth openings cut out, then sculpted ("nose", "cheeks", "both" or "none"), stretched per axis,
    pitched, scaled and moved. Symmetric about ``x = offset[0]`` when ``pitch_degrees`` is anything."""
    rng = np.random.default_rng(seed)
    vertices, faces = _remesh_canonical(spacing, rng, holes)
    warp = _deformation(stretch, sculpt, scale, offset, pitch_degrees)
    truth = warp(face_template().vertices)
    width = float(np.linalg.norm(truth[454] - truth[234]))
    return SyntheticHead(warp(vertices), faces, truth, width, float(offset[0]),
                         f"remeshed face mask, {len(vertices)} vertices, sculpt={sculpt}, stretch={tuple(stretch)}")


def ellipsoid(centre, axes, rings: int, keep=None):
    """UV-sphere ellipsoid (outward triangles); ``keep(centroids) -> bool`` selects a part."""
    lat = np.linspace(0, np.pi, rings + 1)[1:-1]
    lon = np.linspace(0, 2 * np.pi, 2 * rings, endpoint=False)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    unit = np.stack([np.sin(la) * np.cos(lo), np.sin(la) * np.sin(lo), np.cos(la)], -1).reshape(-1, 3)
    unit = np.vstack([[0, 0, 1], unit, [0, 0, -1]])
    n = len(lon)
    idx = 1 + np.arange((rings - 1) * n).reshape(rings - 1, n)
    nxt = np.roll(idx, -1, axis=1)
    faces = [np.stack([np.zeros(n, int), idx[0], nxt[0]], 1)]
    for r in range(rings - 2):
        faces += [np.stack([idx[r], idx[r + 1], nxt[r + 1]], 1), np.stack([idx[r], nxt[r + 1], nxt[r]], 1)]
    faces.append(np.stack([np.full(n, len(unit) - 1), nxt[-1], idx[-1]], 1))
    faces = np.vstack(faces)
    vertices = np.asarray(centre) + unit * np.asarray(axes)
    if keep is not None:
        faces = faces[keep(vertices[faces].mean(axis=1))]
    used, faces = np.unique(faces, return_inverse=True)
    return vertices[used], faces.reshape(-1, 3)


def _cylinder(centre_xy, radius: float, z_top: float, z_bottom: float, around: int, along: int):
    angle = np.linspace(0, 2 * np.pi, around, endpoint=False)
    z = np.linspace(z_top, z_bottom, along)
    a, zz = np.meshgrid(angle, z)
    vertices = np.stack([centre_xy[0] + radius * np.cos(a), centre_xy[1] + radius * np.sin(a), zz], -1)
    idx = np.arange(along * around).reshape(along, around)
    nxt = np.roll(idx, -1, axis=1)
    faces = np.vstack([np.stack([idx[:-1], idx[1:], nxt[1:]], -1).reshape(-1, 3),
                       np.stack([idx[:-1], nxt[1:], nxt[:-1]], -1).reshape(-1, 3)])
    return vertices.reshape(-1, 3), faces


def full_head(seed: int = 0, *, spacing: float = 0.005, body_spacing: float | None = None,
              stretch=(1.15, 1.05, 0.9), sculpt: str = "both", scale: float = 1.0, offset=(-0.1, 0.05, 1.6),
              pitch_degrees: float = 0.0) -> SyntheticHead:
    """The remeshed face (edge length ~``spacing``) plus a crude cranium/hair cap, ears, neck and
    shoulders (separate shells, edge length ~``body_spacing``, default 1.4 x ``spacing``), all through the
    same map F. The chest reaches further forward (-Y) than the nose tip."""
    rng = np.random.default_rng(seed)
    face_v, face_f = _remesh_canonical(spacing, rng, holes=True)
    body = 1.4 * spacing if body_spacing is None else body_spacing

    def rings(axes):        # UV-sphere ring count for an edge length of about `body`
        return max(int(np.pi * max(axes) / body), 8)

    cap_axes, ear_axes, chest_axes = (0.079, 0.105, 0.118), (0.012, 0.022, 0.032), (0.21, 0.13, 0.11)
    cap = ellipsoid((0.0, 0.035, 0.012), cap_axes, rings(cap_axes),
                     keep=lambda c: (c[:, 1] > 0.0) | (c[:, 2] > 0.07))
    ears = [ellipsoid((side * 0.083, 0.03, 0.0), ear_axes, rings(ear_axes)) for side in (-1.0, 1.0)]
    neck = _cylinder((0.0, 0.03), 0.055, -0.04, -0.21, max(int(0.35 / body), 16), max(int(0.17 / body), 4))
    chest = ellipsoid((0.0, 0.03, -0.30), chest_axes, rings(chest_axes))
    parts = [(face_v, face_f), cap, *ears, neck, chest]
    vertices, faces, base = [], [], 0
    for v, f in parts:
        vertices.append(v)
        faces.append(f + base)
        base += len(v)
    warp = _deformation(stretch, sculpt, scale, offset, pitch_degrees)
    truth = warp(face_template().vertices)
    width = float(np.linalg.norm(truth[454] - truth[234]))
    all_v = warp(np.vstack(vertices))
    return SyntheticHead(all_v, np.vstack(faces).astype(np.int64), truth, width, float(offset[0]),
                         f"full head with neck and shoulders, {len(all_v)} vertices, sculpt={sculpt}")


def rotated_head(head: SyntheticHead, facing: str = "+Y") -> SyntheticHead:
    """The same head turned about the vertical axis through its face so that it looks along ``facing``
    (``+Y``, ``+X``, ``-X``), or lying face-up as after a Y-up import without axis conversion (``+Z``)."""
    centre = head.truth.mean(axis=0)
    turns = {"+Y": np.diag([-1.0, -1.0, 1.0]),
             "+X": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
             "-X": np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
             "+Z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])}
    if facing not in turns:
        raise ValueError(f"facing must be one of {sorted(turns)}")
    rot = turns[facing]
    vertices = (head.vertices - centre) @ rot.T + centre
    truth = (head.truth - centre) @ rot.T + centre
    return replace(head, vertices=vertices, truth=truth, description=f"{head.description}, facing {facing}")
