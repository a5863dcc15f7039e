# SPDX-License-Identifier: GPL-3.0-or-later
"""Triangle-mesh geometry shared by every subsystem (thesis 3.1.2 "Skin": "The skin surface is represented
as a triangle mesh"; 6.2 likewise for the hand): one copy each of edges, normals, areas, closest points on
triangles, mirror maps, winding numbers and the input check for a user's mesh. numpy/scipy only.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .errors import UserError

__all__ = ["unique_edges", "median_edge_length", "edge_length_graph", "face_normals", "triangle_normals",
           "vertex_normals", "vertex_areas", "boundary_edge_flags", "closest_points_on_triangles", "closest_points",
           "centroid_tree", "mirror_map", "winding_number", "checked_mesh", "MAX_VERTICES", "MAX_TRIANGLES",
           "similarity_transform"]

MAX_VERTICES = 5_000_000
MAX_TRIANGLES = 10_000_000
CLOSEST_CANDIDATES = 12     # triangles (nearest centroids) :func:`closest_points` tries per point
_CLOSEST_ROWS = 65536      # point x candidate pairs :func:`closest_points` evaluates in one pass


def unique_edges(faces: np.ndarray, return_counts: bool = False):
    """Sorted unique undirected edges (E, 2) int64 of a triangle list (lexicographic order, deterministic),
    and with ``return_counts`` how many triangles use each (1 = a border edge). One 1-D sort of integer
    keys, fast for large meshes."""
    faces = np.asarray(faces, np.int64)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e.sort(axis=1)
    base = int(e.max()) + 1 if len(e) else 1
    keys, counts = np.unique(e[:, 0] * base + e[:, 1], return_counts=True)
    edges = np.stack([keys // base, keys % base], axis=1)
    return (edges, counts) if return_counts else edges


def median_edge_length(vertices: np.ndarray, edges: np.ndarray) -> float:
    """The median length of ``edges`` (E, 2) over ``vertices`` (the mesh's own scale; NaN for no edges)."""
    return float(np.median(np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)))


def edge_length_graph(vertices: np.ndarray, edges: np.ndarray):
    """Symmetric sparse (N, N) graph of ``edges`` weighted by their lengths (coincident vertices are still
    neighbours, at 1e-12 m), for distances over the surface (``scipy.sparse.csgraph.dijkstra``)."""
    from scipy import sparse
    length = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)
    length = np.maximum(length, 1e-12)
    n = len(vertices)
    return sparse.csr_matrix((np.r_[length, length], (np.r_[edges[:, 0], edges[:, 1]],
                                                       np.r_[edges[:, 1], edges[:, 0]])), shape=(n, n))


def face_normals(vertices: np.ndarray, faces: np.ndarray, normalise: bool = True) -> np.ndarray:
    """Triangle normals (M, 3), counter-clockwise = outside; unit length unless ``normalise=False`` (then
    their length is twice the triangle's area)."""
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    if normalise:
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    return n


def triangle_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit triangle normals (zero for degenerate triangles) and triangle areas."""
    cross = face_normals(vertices, faces, normalise=False)
    norm = np.linalg.norm(cross, axis=1)
    return cross / np.where(norm > 0, norm, 1.0)[:, None], 0.5 * norm


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (N, 3); zero for vertices no triangle uses."""
    fn = face_normals(vertices, faces, normalise=False)
    n = np.zeros_like(vertices, dtype=np.float64)
    for corner in range(3):
        for axis in range(3):
            n[:, axis] += np.bincount(faces[:, corner], fn[:, axis], len(vertices))
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)


def vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Barycentric vertex areas (a third of each incident triangle), m^2."""
    area = 0.5 * np.linalg.norm(face_normals(vertices, faces, normalise=False), axis=1)
    out = np.zeros(len(vertices))
    for corner in range(3):
        out += np.bincount(faces[:, corner], area / 3.0, len(vertices))
    return out


def boundary_edge_flags(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(M, 3) bool: the edge opposite corner k of triangle t is used by no other triangle (a mesh border,
    e.g. the rim of an eye or mouth opening, or the edge of a face mask)."""
    opposite = np.stack([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]], axis=1)  # (M, 3, 2)
    low = opposite.min(axis=2).astype(np.int64)
    high = opposite.max(axis=2).astype(np.int64)
    keys = (low * np.int64(vertex_count) + high).ravel()
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return (counts[inverse] == 1).reshape(faces.shape)


def closest_points_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Closest point on triangle (a, b, c) to p, row by row, and its barycentric coordinates (clipped to
    [0, 1]). Vectorised Ericson, *Real-Time Collision Detection* (2005) 5.1.5. On an edge or a corner the
    barycentric coordinates of the other corner(s) are exactly 0 (used to detect borders); degenerate
    triangles give a finite answer."""
    def dot(x, y):
        return np.einsum("ij,ij->i", x, y)

    ab, ac = b - a, c - a
    ap, bp, cp = p - a, p - b, p - c
    d1, d2 = dot(ab, ap), dot(ac, ap)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2

    def ratio(num, den):
        return num / np.where(np.abs(den) > 1e-300, den, 1e-300)

    denom = va + vb + vc
    v, w = ratio(vb, denom), ratio(vc, denom)
    u = 1.0 - v - w
    zero, one = np.zeros_like(u), np.ones_like(u)
    t_bc = ratio(d4 - d3, (d4 - d3) + (d5 - d6))
    t_ac = ratio(d2, d2 - d6)
    t_ab = ratio(d1, d1 - d3)
    # later rules win, so go from the lowest to the highest priority of Ericson's order
    rules = (((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), (zero, 1 - t_bc, t_bc)),   # edge BC
             ((vb <= 0) & (d2 >= 0) & (d6 <= 0), (1 - t_ac, zero, t_ac)),             # edge AC
             ((d6 >= 0) & (d5 <= d6), (zero, zero, one)),                             # corner C
             ((vc <= 0) & (d1 >= 0) & (d3 <= 0), (1 - t_ab, t_ab, zero)),             # edge AB
             ((d3 >= 0) & (d4 <= d3), (zero, one, zero)),                             # corner B
             ((d1 <= 0) & (d2 <= 0), (one, zero, zero)))                              # corner A
    for region, (nu, nv, nw) in rules:
        u, v, w = np.where(region, nu, u), np.where(region, nv, v), np.where(region, nw, w)
    bary = np.clip(np.stack([u, v, w], axis=1), 0.0, 1.0)
    point = bary[:, :1] * a + bary[:, 1:2] * b + bary[:, 2:] * c
    return point, bary


def centroid_tree(vertices: np.ndarray, faces: np.ndarray) -> cKDTree:
    """The KD-tree on triangle centroids :func:`closest_points` searches; build it once for a mesh that is
    queried again and again (a bone the skin guard re-anchors on every frame) and pass it as ``tree``."""
    return cKDTree(np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)].mean(axis=1))


def closest_points(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, candidates: int = CLOSEST_CANDIDATES,
                   tree: cKDTree | None = None):
    """Closest points on a triangle mesh: ``(point (M,3), face index (M,), barycentric (M,3), distance)``.

    Candidate triangles come from a KD-tree on triangle centroids (exact for meshes whose triangles are
    small relative to the query distance; ``candidates`` widens the search); ``tree``: that tree
    (:func:`centroid_tree`) when the caller keeps it, the same answer without rebuilding it. For uneven
    meshes and repeated queries use ``fitting.surface.TargetSurface``."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    points = np.asarray(points, np.float64)
    k = min(candidates, len(faces))
    _, cand = (centroid_tree(vertices, faces) if tree is None else tree).query(points, k=k)
    cand = cand.reshape(len(points), k)
    best_p, best_b = np.zeros_like(points), np.zeros((len(points), 3))
    best_f, best_d = np.zeros(len(points), np.int64), np.full(len(points), np.inf)
    chunk = max(1, _CLOSEST_ROWS // k)
    for begin in range(0, len(points), chunk):     # every candidate of a chunk of points in one pass
        rows = slice(begin, begin + chunk)
        f = cand[rows].ravel()
        p = np.repeat(points[rows], k, axis=0)
        tri = vertices[faces[f]]
        q, b = closest_points_on_triangles(p, tri[:, 0], tri[:, 1], tri[:, 2])
        d = np.linalg.norm(q - p, axis=1)
        d = np.where(d < np.inf, d, np.inf).reshape(-1, k)          # NaN never wins
        pick = np.argmin(d, axis=1)                                  # the first of equals, as a j loop
        at = np.arange(len(pick)) * k + pick
        found = d[np.arange(len(pick)), pick] < np.inf
        best_d[rows] = np.where(found, d.ravel()[at], np.inf)
        best_p[rows] = np.where(found[:, None], q[at], 0.0)
        best_f[rows] = np.where(found, f[at], 0)
        best_b[rows] = np.where(found[:, None], b[at], 0.0)
    return best_p, best_f, best_b, best_d


def mirror_map(vertices: np.ndarray, tolerance: float = 1e-3) -> np.ndarray:
    """Index of each vertex's left/right mirror image (x -> -x); -1 where none lies within tolerance."""
    mirrored = vertices * np.array([-1.0, 1.0, 1.0])
    d, idx = cKDTree(vertices).query(mirrored)
    return np.where(d <= tolerance, idx, -1)


def winding_number(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Generalised winding number of a triangle mesh at ``points`` (~1 inside, ~0 outside; robust to small
    holes), from the solid angles of the triangles (Van Oosterom & Strackee 1983)."""
    tri = np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)]
    out = np.empty(len(points))
    for begin in range(0, len(points), chunk):
        p = np.asarray(points[begin:begin + chunk], np.float64)
        a = tri[None, :, 0] - p[:, None]
        b = tri[None, :, 1] - p[:, None]
        c = tri[None, :, 2] - p[:, None]
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
        det = np.einsum("ijk,ijk->ij", a, np.cross(b, c))
        div = (la * lb * lc + np.einsum("ijk,ijk->ij", a, b) * lc + np.einsum("ijk,ijk->ij", b, c) * la
               + np.einsum("ijk,ijk->ij", c, a) * lb)
        out[begin:begin + chunk] = np.arctan2(det, div).sum(axis=1) / (2 * np.pi)
    return out


def checked_mesh(vertices, faces, what: str = "the head mesh") -> tuple[np.ndarray, np.ndarray]:
    """Validate a triangle mesh given as (N, 3) vertices and (M, 3) vertex-index triangles; returns them as
    float64 / int64 arrays.

    Raises :class:`UserError` (naming ``what``) for anything the engine cannot use: no triangles,
    non-triangles, bad indices, NaN/inf, a degenerate (flat-to-a-point or zero-area) mesh, or more than
    ``MAX_VERTICES`` / ``MAX_TRIANGLES``.
    """
    try:
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces)
    except (TypeError, ValueError):
        raise UserError(f"{what} must be given as numeric vertex and triangle arrays") from None
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise UserError(f"{what}: vertices must be an (N, 3) array, not {vertices.shape}")
    if faces.size == 0:
        raise UserError(f"{what} has no faces; select a mesh with faces, not a point cloud")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise UserError(f"{what}: faces must be triangles, an (M, 3) index array, not {faces.shape}; "
                        "triangulate the mesh (or pass its loop triangles)")
    if faces.dtype.kind not in "iu":
        raise UserError(f"{what}: face indices must be integers")
    if len(vertices) > MAX_VERTICES or len(faces) > MAX_TRIANGLES:
        raise UserError(f"{what} is too large ({len(vertices):,} vertices, {len(faces):,} triangles); "
                        f"at most {MAX_VERTICES:,} vertices and {MAX_TRIANGLES:,} triangles are accepted: "
                        "decimate it (Decimate modifier) first")
    faces = faces.astype(np.int64, copy=False)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise UserError(f"{what}: faces index vertices outside 0..{len(vertices) - 1}")
    if not np.isfinite(vertices).all():
        raise UserError(f"{what} has NaN or infinite vertex coordinates; fix the mesh first")
    used = vertices[np.unique(faces)]
    extent = float(np.linalg.norm(used.max(0) - used.min(0)))
    magnitude = float(np.abs(used).max())
    if extent <= 1e-9 * max(magnitude, 1.0) or extent < 1e-12:
        raise UserError(f"{what} is degenerate: all its vertices (nearly) coincide")
    area = triangle_normals(vertices, faces)[1]
    if not (area > 0.5e-12 * extent * extent).any():
        raise UserError(f"{what} is degenerate: all its triangles have zero area")
    return vertices, faces


def similarity_transform(source: np.ndarray, target: np.ndarray, allow_rotation: bool = True) -> np.ndarray:
    """Least-squares similarity (Umeyama 1991) mapping ``source`` onto ``target`` points, as a 4x4 matrix."""
    mu_s, mu_t = source.mean(0), target.mean(0)
    s, t = source - mu_s, target - mu_t
    if allow_rotation:
        u, sig, vt = np.linalg.svd(t.T @ s / len(source))
        d = np.ones(3)
        if np.linalg.det(u @ vt) < 0:
            d[-1] = -1
        rot = u @ np.diag(d) @ vt
        scale = float((sig * d).sum() / max((s ** 2).sum() / len(source), 1e-30))
    else:
        rot = np.eye(3)
        scale = float(np.sqrt((t ** 2).sum() / max((s ** 2).sum(), 1e-30)))
    out = np.eye(4)
    out[:3, :3] = scale * rot
    out[:3, 3] = mu_t - scale * rot @ mu_s
    return out
