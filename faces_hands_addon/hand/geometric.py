# SPDX-License-Identifier: GPL-3.0-or-later
"""Geometric muscles (thesis 6.2.2 "Geometric Muscles", Figs. 6.15-6.18): the skin-bulging half of the hybrid
muscle model.

Each muscle is generated from a *muscle grid* on the skin surface (Fig. 6.17): the preset's spine points are
projected onto the skin, resampled into ``rows`` points and widened into ``columns`` across ``width``; every
grid point is projected onto the skin again. The muscle itself lies ``skin_distance`` below the grid along the
inward skin normal (so muscles can form layers, Fig. 6.16) with its own relaxed and contracted thickness
(6.2.2: "each individual muscle has its own minimum and maximum thickness").

Segments move with the bones the muscle is assigned to ("muscles may be assigned to several individual
bones", e.g. the abductor digiti minimi to the carpals, the fifth metacarpal and proximal phalanx): a grid
row's weights blend the listed bones along the spine. Contracting bulges the muscle, most in the middle of
its length and width; a muscle whose ends are carried apart by its bones thins and one whose ends come
together thickens (its volume is kept, ``thickness ~ rest length / length``). The change of the muscle's outer
surface moves the attachment points of the skin nodes above it (:meth:`GeometricMuscles.skin_displacement`),
and the spring network carries that into the skin.

A grid is the only spatial input of a muscle: the photo warp (6.2.3 step 4) moves the grid points and
:func:`build_geometric_muscles` rebuilds the rest on the warped skin.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from ..core import geometry
from ..core.errors import UserError
from .presets import require_keys
from .reference import PALM_NORMAL, RADIAL
from .skeleton import Skeleton

__all__ = ["GeometricMuscles", "muscle_grids", "build_geometric_muscles", "FOOTPRINT"]

#: radius of a grid point's footprint on the skin, in grid spacings (wide enough that a bulge is a swelling
#: of the eminence, Fig. 6.18, not a pimple over each grid point)
FOOTPRINT = 2.4


def _point_on_bone(skeleton: Skeleton, spec: list, where: str) -> np.ndarray:
    if (not isinstance(spec, list) or len(spec) != 4 or spec[0] not in skeleton.index
            or not all(isinstance(v, (int, float)) for v in spec[1:])):
        raise UserError(f"{where}: a path point must be [bone, t, palmar_mm, radial_mm] with a bone of the hand")
    b = skeleton.index[spec[0]]
    head, tail = skeleton.position[b], skeleton.tail[b]
    return head + float(spec[1]) * (tail - head) + PALM_NORMAL * spec[2] / 1000.0 + RADIAL * spec[3] / 1000.0


def _resample(points: np.ndarray, count: int) -> np.ndarray:
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    target = np.linspace(0.0, s[-1], count)
    return np.column_stack([np.interp(target, s, points[:, k]) for k in range(3)])


def _project(points, vertices, faces, normals):
    point, face, bary, _ = geometry.closest_points(vertices, faces, points)
    normal = np.einsum("ij,ijk->ik", bary, normals[faces[face]])
    return point, normal / np.linalg.norm(normal, axis=1, keepdims=True)


def muscle_grids(specs: list[dict], skeleton: Skeleton, vertices: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    """The muscle grids (rows, columns, 3) painted onto the skin ``vertices``/``faces`` (module docstring)."""
    normals = geometry.vertex_normals(vertices, faces)
    grids = []
    for spec in specs:
        where = f"hand/geometric_muscles.json: muscle {spec.get('name')!r}"
        require_keys(spec, ("name", "pseudo", "path", "bones", "width_mm", "thickness_mm", "skin_distance_mm",
                            "rows", "columns"), where)
        rows, columns = int(spec["rows"]), int(spec["columns"])
        if rows < 2 or columns < 2 or len(spec["path"]) < 2 or spec["width_mm"] <= 0:
            raise UserError(f"{where}: needs at least 2 path points, 2 rows, 2 columns and a width > 0")
        spine = np.array([_point_on_bone(skeleton, p, where) for p in spec["path"]])
        spine, normal = _project(_resample(spine, rows), vertices, faces, normals)
        tangent = np.gradient(spine, axis=0)
        across = np.cross(normal, tangent)
        across /= np.maximum(np.linalg.norm(across, axis=1, keepdims=True), 1e-12)
        offsets = np.linspace(-0.5, 0.5, columns) * spec["width_mm"] / 1000.0
        grid = spine[:, None, :] + across[:, None, :] * offsets[None, :, None]
        grid, _ = _project(grid.reshape(-1, 3), vertices, faces, normals)
        grids.append(grid.reshape(rows, columns, 3))
    return grids


@dataclass
class _Layout:
    rest_points: np.ndarray      # (P, 3) outer muscle surface at rest
    rest_normals: np.ndarray     # (P, 3) outward
    profile: np.ndarray          # (P,) bulge weight: sin along the length x parabola across
    muscle: np.ndarray           # (P,) muscle index
    bone_weights: sparse.csr_matrix   # (P, B)
    spine_rows: list[np.ndarray]      # per muscle: the point indices of the middle column, in order


class GeometricMuscles:
    """The geometric muscles of a hand, vectorised over all grid points (module docstring)."""

    def __init__(self, specs: list[dict], grids: list[np.ndarray], skeleton: Skeleton, vertices: np.ndarray,
                 faces: np.ndarray, muscle_names: list[str]):
        self.names = [s["name"] for s in specs]
        self.pseudo = []
        for spec in specs:
            if spec["pseudo"] not in muscle_names:
                raise UserError(f"hand/geometric_muscles.json: muscle {spec['name']!r} names the pseudo muscle "
                                f"{spec['pseudo']!r}, which presets/hand/muscles.json does not define")
            self.pseudo.append(muscle_names.index(spec["pseudo"]))
        self.pseudo = np.array(self.pseudo, np.int64)
        self.grids = [np.asarray(g, np.float64) for g in grids]
        self.thickness = np.array([s["thickness_mm"] for s in specs], np.float64) / 1000.0
        if self.thickness.shape != (len(specs), 2) or np.any(self.thickness[:, 0] <= 0) or \
                np.any(self.thickness[:, 1] < self.thickness[:, 0]):
            raise UserError("hand/geometric_muscles.json: thickness_mm must be [relaxed, contracted] with "
                            "0 < relaxed <= contracted")
        self.bulge = np.array([float(s.get("bulge", 1.0)) for s in specs])
        self.layout = self._layout(specs, skeleton, vertices, faces)
        self.skin_weights = self._skin_weights(vertices)
        spine = self.layout.spine_rows
        self._segment_start = np.concatenate([r[:-1] for r in spine])
        self._segment_end = np.concatenate([r[1:] for r in spine])
        self._segment_muscle = np.concatenate([np.full(len(r) - 1, m) for m, r in enumerate(spine)])
        self._rest_length = self._spine_lengths(self.layout.rest_points)

    def _spine_lengths(self, points: np.ndarray) -> np.ndarray:
        segments = np.linalg.norm(points[self._segment_end] - points[self._segment_start], axis=1)
        return np.bincount(self._segment_muscle, segments, len(self.names))

    def _layout(self, specs, skeleton, vertices, faces) -> _Layout:
        normals = geometry.vertex_normals(vertices, faces)
        pts, nrm, prof, mus, rows_w, spine = [], [], [], [], [], []
        offset = 0
        for m, (spec, grid) in enumerate(zip(specs, self.grids)):
            rows, columns = grid.shape[:2]
            on_skin, normal = _project(grid.reshape(-1, 3), vertices, faces, normals)
            depth = spec["skin_distance_mm"] / 1000.0
            pts.append(on_skin - normal * depth)        # the muscle's outer surface under the grid
            nrm.append(normal)
            s = np.repeat(np.linspace(0.0, 1.0, rows), columns)
            x = np.tile(np.linspace(-1.0, 1.0, columns), rows)
            prof.append(np.sin(np.pi * s) * (1.0 - 0.7 * x * x))
            mus.append(np.full(rows * columns, m))
            bones = [skeleton.index.get(b) for b in spec["bones"]]
            if not bones or None in bones:
                raise UserError(f"hand/geometric_muscles.json: muscle {spec['name']!r} lists a bone the hand "
                                "does not have")
            u = s * (len(bones) - 1)
            low = np.minimum(np.floor(u).astype(int), len(bones) - 1)
            high = np.minimum(low + 1, len(bones) - 1)
            frac = u - low
            w = np.zeros((rows * columns, len(skeleton.names)))
            np.add.at(w, (np.arange(len(u)), np.array(bones)[low]), 1.0 - frac)
            np.add.at(w, (np.arange(len(u)), np.array(bones)[high]), frac)
            rows_w.append(w)
            spine.append(offset + np.arange(rows) * columns + columns // 2)
            offset += rows * columns
        return _Layout(np.concatenate(pts), np.concatenate(nrm), np.concatenate(prof), np.concatenate(mus),
                       sparse.csr_matrix(np.concatenate(rows_w)), spine)

    def _skin_weights(self, vertices: np.ndarray) -> sparse.csr_matrix:
        """(N, P): how much each skin node follows each grid point's outward motion (a smooth footprint)."""
        lay = self.layout
        grid_on_skin = np.concatenate([g.reshape(-1, 3) for g in self.grids])
        blocks = []
        for m, grid in enumerate(self.grids):
            rows, columns = grid.shape[:2]
            spacing = max(np.linalg.norm(np.diff(grid, axis=0), axis=2).mean(),
                          np.linalg.norm(np.diff(grid, axis=1), axis=2).mean())
            radius = FOOTPRINT * spacing
            index = np.flatnonzero(lay.muscle == m)
            d = np.linalg.norm(vertices[:, None, :] - grid_on_skin[index][None], axis=2)
            f = np.clip(1.0 - (d / radius) ** 2, 0.0, None) ** 2
            total = f.sum(axis=1, keepdims=True)
            w = f / np.maximum(total, 1.0) * np.minimum(total, 1.0)
            full = np.zeros((len(vertices), len(lay.muscle)))
            full[:, index] = w
            blocks.append(sparse.csr_matrix(full))
        return sum(blocks[1:], blocks[0]).tocsr() if blocks else sparse.csr_matrix((len(vertices), 0))

    # -- per frame -------------------------------------------------------------------------------
    def surface(self, transforms: np.ndarray, contraction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Posed outer-surface points (P, 3) and their outward displacement by bulging (P, 3), for the bone
        ``transforms`` (B, 4, 4) and the pseudo-muscle ``contraction`` vector."""
        lay = self.layout
        blended = (lay.bone_weights @ transforms[:, :3, :].reshape(len(transforms), 12)).reshape(-1, 3, 4)
        points = np.einsum("pij,pj->pi", blended[:, :, :3], lay.rest_points) + blended[:, :, 3]
        normals = np.einsum("pij,pj->pi", blended[:, :, :3], lay.rest_normals)
        c = contraction[self.pseudo]
        lengths = self._spine_lengths(points)
        rest_t, full_t = self.thickness[:, 0], self.thickness[:, 1]
        thickness = (rest_t + c * (full_t - rest_t)) * self._rest_length / np.maximum(lengths, 1e-6)
        change = (thickness - rest_t) * self.bulge
        amount = change[lay.muscle] * lay.profile
        return points + normals * amount[:, None], normals * amount[:, None]

    def skin_displacement(self, displacement: np.ndarray) -> np.ndarray:
        """(N, 3) outward motion of the skin nodes' attachment points for the muscles' ``displacement``."""
        return self.skin_weights @ displacement

    def footprint_owner(self, least: float = 0.05) -> np.ndarray:
        """(N,) for each skin node the muscle whose footprint weighs most on it, -1 where none weighs ``least``."""
        per_muscle = np.column_stack([np.asarray(self.skin_weights[:, self.layout.muscle == m].sum(axis=1)).ravel()
                                      for m in range(len(self.names))])
        return np.where(per_muscle.max(axis=1) >= least, per_muscle.argmax(axis=1), -1)

    def grid_quads(self) -> np.ndarray:
        """(Q, 4) point indices of the muscle surfaces' quads, for display."""
        quads, offset = [], 0
        for grid in self.grids:
            rows, columns = grid.shape[:2]
            r, c = np.meshgrid(np.arange(rows - 1), np.arange(columns - 1), indexing="ij")
            a = offset + r * columns + c
            quads.append(np.stack([a, a + 1, a + columns + 1, a + columns], axis=-1).reshape(-1, 4))
            offset += rows * columns
        return np.concatenate(quads) if quads else np.zeros((0, 4), np.int64)


def build_geometric_muscles(specs, skeleton, vertices, faces, muscle_names, grids=None) -> GeometricMuscles:
    """Geometric muscles from their grids (painted from the preset when ``grids`` is None)."""
    if grids is None:
        grids = muscle_grids(specs, skeleton, vertices, faces)
    return GeometricMuscles(specs, grids, skeleton, vertices, faces, muscle_names)
