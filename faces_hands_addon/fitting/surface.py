# SPDX-License-Identifier: GPL-3.0-or-later
"""The target head mesh as a queryable surface: input checks, triangle normals, boundary edges and
closest points on TRIANGLES (not only vertices).

Thesis 3.1.2 "Creating New Animatable Head Models from the Template": feature points "must be placed at
corresponding locations on the target skin mesh"; every located landmark is therefore a point on one of
the target's triangles, stored as (triangle index, barycentric coordinates) so it can be re-evaluated or
re-projected after the artist drags a marker. numpy/scipy only.
"""
from __future__ import annotations

import copy
import itertools
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..core.errors import UserError
from ..core.geometry import boundary_edge_flags, checked_mesh, closest_points_on_triangles, triangle_normals

__all__ = ["TargetSurface", "SurfaceHit", "least_squares", "project_to_surface"]

_NEAREST_VERTICES = 2      # candidate triangles: those around the k nearest vertices ...
_NEAREST_CENTROIDS = 8     # ... and the k triangles with the nearest centroids (long thin triangles)
_MAX_VALENCE = 12          # incident triangles kept per vertex in the candidate table


def least_squares(rows: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Small dense least squares via the normal equations, summed with einsum instead of BLAS so that
    the result does not depend on the BLAS thread count (the columns are pre-scaled by the callers)."""
    normal = np.einsum("ri,rj->ij", rows, rows)
    return np.linalg.solve(normal + 1e-12 * np.trace(normal) / len(normal) * np.eye(len(normal)),
                           np.einsum("ri,r->i", rows, rhs))


@dataclass
class SurfaceHit:
    """Closest surface points of a batch of query points."""
    points: np.ndarray        # (K, 3)
    triangles: np.ndarray     # (K,) index into the surface's triangles
    barycentric: np.ndarray   # (K, 3)
    distances: np.ndarray     # (K,)
    normals: np.ndarray       # (K, 3) unit normal of the hit triangle
    on_border: np.ndarray     # (K,) the point lies on a border edge (hole rim / mesh edge)


class TargetSurface:
    """A triangle mesh prepared for repeated closest-point queries.

    Candidate triangles for a query are those around its nearest vertices plus those with the nearest
    centroids (scipy ``cKDTree``), then the exact point-triangle distance decides. ``triangle_subset``
    restricts the search (e.g. to the face region of a full body) while keeping the global triangle
    indices and the global border status (computed on the whole mesh, so a crop adds no false borders).
    Fewer candidates (``nearest_vertices``, ``nearest_centroids``) suffice for evenly meshed surfaces.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, triangle_subset: np.ndarray | None = None,
                 border: np.ndarray | None = None, normals: np.ndarray | None = None,
                 nearest_vertices: int = _NEAREST_VERTICES, nearest_centroids: int = _NEAREST_CENTROIDS):
        self._nearest_vertices, self._nearest_centroids = nearest_vertices, nearest_centroids
        self.vertices = vertices
        self.faces = faces
        self.border = boundary_edge_flags(faces, len(vertices)) if border is None else border
        self.normals = triangle_normals(vertices, faces)[0] if normals is None else normals
        self.border_vertex = np.zeros(len(vertices), bool)
        self.border_vertex[faces[:, [1, 2, 0]][self.border]] = True
        self.border_vertex[faces[:, [2, 0, 1]][self.border]] = True
        subset = np.arange(len(faces)) if triangle_subset is None else np.asarray(triangle_subset, np.int64)
        if len(subset) == 0:
            raise UserError("no part of the head mesh lies where the face was expected")
        self.subset = subset
        local_faces = faces[subset]
        used, local = np.unique(local_faces, return_inverse=True)
        local = local.reshape(local_faces.shape)
        self._used_vertices = used
        self._vertex_tree = cKDTree(vertices[used])
        # padded vertex -> incident local triangles table (-1 = none); very high valences are cut at
        # _MAX_VALENCE, the nearest-centroid candidates cover what is cut
        flat = local.ravel()
        order = np.argsort(flat, kind="stable")
        starts = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=len(used)))])
        rank = np.arange(len(flat)) - starts[flat[order]]
        keep = rank < _MAX_VALENCE
        self._incident = np.full((len(used), _MAX_VALENCE), -1, np.int64)
        self._incident[flat[order][keep], rank[keep]] = (order // 3)[keep]
        self._centroids = vertices[local_faces].mean(axis=1)
        self._centroid_tree = cKDTree(self._centroids)
        self._size_buckets = None

    def _buckets(self):
        """Triangles grouped by size (bounding-sphere radius within a factor 2), each with a centroid tree
        and its largest radius: the exact pass looks for triangles whose sphere reaches the query's ball."""
        if self._size_buckets is None:
            corners = self.vertices[self.faces[self.subset]]
            radius = np.linalg.norm(corners - self._centroids[:, None], axis=2).max(axis=1)
            typical = float(np.median(radius)) or 1.0
            level = np.floor(np.log2(np.maximum(radius / typical, 1.0))).astype(np.int64)
            self._radius = radius
            self._size_buckets = [(np.flatnonzero(level == k), float(radius[level == k].max()))
                                  for k in np.unique(level)]
            self._size_buckets = [(index, cKDTree(self._centroids[index]), top) for index, top in self._size_buckets]
        return self._size_buckets

    def flipped(self) -> "TargetSurface":
        """The same surface with inverted normals (for meshes whose normals point inwards); the search
        structures are shared, not rebuilt."""
        other = copy.copy(self)
        other.normals = -self.normals
        return other

    def closest(self, queries: np.ndarray, chunk: int = 20000, exact: bool = False) -> SurfaceHit:
        """Closest points on the (subset of) triangles for (K, 3) query points.

        The fast candidate search is exact for reasonably even meshes; ``exact=True`` adds a pass that
        checks every triangle whose bounding sphere comes closer than the point found (costly for queries
        far from the surface, so the registration iterations skip it)."""
        queries = np.asarray(queries, np.float64).reshape(-1, 3)
        parts = [self._closest_chunk(queries[i:i + chunk], exact) for i in range(0, len(queries), chunk)]
        if not parts:
            empty = np.zeros((0, 3))
            return SurfaceHit(empty, np.zeros(0, np.int64), empty, np.zeros(0), empty, np.zeros(0, bool))
        return SurfaceHit(*[np.concatenate([getattr(p, f) for p in parts]) for f in
                            ("points", "triangles", "barycentric", "distances", "normals", "on_border")])

    def _closest_chunk(self, queries: np.ndarray, exact: bool) -> SurfaceHit:
        count = len(queries)
        kv = min(self._nearest_vertices, len(self._used_vertices))
        kt = min(self._nearest_centroids, len(self.subset))
        _, near_v = self._vertex_tree.query(queries, k=kv)
        _, near_t = self._centroid_tree.query(queries, k=kt)
        candidates = np.concatenate([self._incident[near_v.reshape(count, kv)].reshape(count, -1),
                                     near_t.reshape(count, kt)], axis=1)          # (count, K) local, -1 pad
        valid = candidates >= 0
        owner = np.broadcast_to(np.arange(count)[:, None], candidates.shape)[valid]
        local, point, bary, dist = self._best_of(queries, owner, candidates[valid], count)
        if exact:
            for index, tree, top in self._buckets():
                reach = tree.query_ball_point(queries, r=dist + top)
                sizes = np.fromiter((len(r) for r in reach), np.int64, count)
                if not sizes.any():
                    continue
                owner = np.repeat(np.arange(count), sizes)
                extra = index[np.fromiter(itertools.chain.from_iterable(reach), np.int64, int(sizes.sum()))]
                gap = np.linalg.norm(queries[owner] - self._centroids[extra], axis=1) - self._radius[extra]
                owner, extra = owner[gap < dist[owner]], extra[gap < dist[owner]]
                if len(extra):
                    owner = np.concatenate([np.arange(count), owner])
                    extra = np.concatenate([local, extra])
                    local, point, bary, dist = self._best_of(queries, owner, extra, count)
        tri = self.subset[local]
        on_border = ((bary == 0.0) & self.border[tri]).any(axis=1)
        at_corner = bary.max(axis=1) == 1.0
        corner_vertex = self.faces[tri, bary.argmax(axis=1)]
        on_border |= at_corner & self.border_vertex[corner_vertex]
        return SurfaceHit(point, tri, bary, dist, self.normals[tri], on_border)

    def _best_of(self, queries: np.ndarray, owner: np.ndarray, local: np.ndarray, count: int):
        """Nearest of the candidate (query ``owner``, local triangle) pairs for each query (ties: first)."""
        corners = self.vertices[self.faces[self.subset[local]]]
        point, bary = closest_points_on_triangles(queries[owner], corners[:, 0], corners[:, 1], corners[:, 2])
        dist2 = ((point - queries[owner]) ** 2).sum(axis=1)
        order = np.lexsort((dist2, owner))
        first = order[np.concatenate([[True], owner[order][1:] != owner[order][:-1]])]
        if len(first) != count:
            raise UserError("closest-point search found no triangle for some points")
        return local[first], point[first], bary[first], np.sqrt(dist2[first])


def project_to_surface(points, target_vertices, target_faces):
    """Closest points on the target mesh's triangles: ``(points (K, 3), triangle (K,), barycentric (K, 3))``.

    Use it to snap markers back onto the skin after the artist dragged them; evaluate a stored landmark
    later with ``(bary[:, :, None] * vertices[faces[tri]]).sum(1)``.
    """
    vertices, faces = checked_mesh(target_vertices, target_faces)
    points = np.asarray(points, np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
        raise UserError("points to project must be a finite (K, 3) array")
    hit = TargetSurface(vertices, faces).closest(points, exact=True)
    return hit.points, hit.triangles, hit.barycentric
