# SPDX-License-Identifier: GPL-3.0-or-later
"""Triangle-mesh helpers for the head template (thesis 3.1.2 "Skin": "The skin surface is represented as a
triangle mesh"): edges and boundary loops, Loop subdivision as a sparse matrix, vertex areas and normals,
closest points on a mesh, mirror maps. numpy/scipy only.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from ..errors import UserError

__all__ = ["unique_edges", "boundary_loops", "loop_subdivision", "vertex_normals", "vertex_areas",
           "face_normals", "closest_points", "mirror_map", "split_long_edges", "edge_face_counts",
           "winding_number"]


def unique_edges(faces: np.ndarray) -> np.ndarray:
    """Sorted unique undirected edges (E, 2) of a triangle list, in a deterministic order."""
    faces = np.asarray(faces, np.int64)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e.sort(axis=1)
    return np.unique(e, axis=0)


def edge_face_counts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique edges and how many faces use each (1 = boundary edge)."""
    faces = np.asarray(faces, np.int64)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e.sort(axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    return edges, counts


def boundary_loops(faces: np.ndarray) -> list[np.ndarray]:
    """Closed boundary loops (vertex index arrays) following the faces' orientation, longest first."""
    faces = np.asarray(faces, np.int64)
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = {(int(a), int(b)) for a, b in directed}
    nxt = {}
    for a, b in directed:
        if (int(b), int(a)) not in key:
            nxt[int(a)] = int(b)
    loops, seen = [], set()
    for start in sorted(nxt):
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen:
            seen.add(v)
            loop.append(v)
            v = nxt.get(v)
            if v is None:
                raise UserError("the mesh boundary is not manifold (a boundary vertex is used twice)")
        loops.append(np.array(loop, np.int64))
    loops.sort(key=lambda l: (-len(l), int(l.min())))
    return loops


def face_normals(vertices: np.ndarray, faces: np.ndarray, normalise: bool = True) -> np.ndarray:
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    if normalise:
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    return n


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (N, 3)."""
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


def loop_subdivision(vertex_count: int, faces: np.ndarray) -> tuple[sparse.csr_matrix, np.ndarray]:
    """One level of Loop subdivision as a sparse matrix ``S`` (new = S @ old) and the new faces.

    Interior rules: even vertices ``(1 - n b) v + b sum(neighbours)`` (Warren's ``b``), odd vertices
    ``3/8 (a + b) + 1/8 (c + d)``; boundary (and hole) vertices use the cubic B-spline curve rules, so
    the holes of the mouth and the eyes stay clean loops. Old vertices keep their indices; edge
    vertices follow in the order of :func:`unique_edges`.
    """
    faces = np.asarray(faces, np.int64)
    n = vertex_count
    edges, counts = edge_face_counts(faces)
    edge_id = {(int(a), int(b)): i for i, (a, b) in enumerate(edges)}
    boundary_edge = counts == 1
    rows, cols, vals = [], [], []
    # odd (edge) vertices
    opposite = [[] for _ in range(len(edges))]
    for f in faces:
        for k in range(3):
            a, b, c = int(f[k]), int(f[(k + 1) % 3]), int(f[(k + 2) % 3])
            opposite[edge_id[(min(a, b), max(a, b))]].append(c)
    for i, (a, b) in enumerate(edges):
        r = n + i
        if boundary_edge[i] or len(opposite[i]) != 2:
            rows += [r, r]; cols += [int(a), int(b)]; vals += [0.5, 0.5]
        else:
            c, d = opposite[i]
            rows += [r, r, r, r]; cols += [int(a), int(b), c, d]; vals += [0.375, 0.375, 0.125, 0.125]
    # even vertices
    neighbours = [set() for _ in range(n)]
    boundary_neighbours = [[] for _ in range(n)]
    for i, (a, b) in enumerate(edges):
        neighbours[a].add(int(b)); neighbours[b].add(int(a))
        if boundary_edge[i]:
            boundary_neighbours[a].append(int(b)); boundary_neighbours[b].append(int(a))
    for v in range(n):
        if len(boundary_neighbours[v]) == 2:
            b1, b2 = boundary_neighbours[v]
            rows += [v, v, v]; cols += [v, b1, b2]; vals += [0.75, 0.125, 0.125]
        elif len(boundary_neighbours[v]) > 0 or not neighbours[v]:
            rows.append(v); cols.append(v); vals.append(1.0)          # corner / isolated: keep
        else:
            k = len(neighbours[v])
            beta = 3.0 / 16.0 if k == 3 else 3.0 / (8.0 * k)
            rows.append(v); cols.append(v); vals.append(1.0 - k * beta)
            for w in sorted(neighbours[v]):
                rows.append(v); cols.append(w); vals.append(beta)
    matrix = sparse.csr_matrix((vals, (rows, cols)), shape=(n + len(edges), n))
    # new faces: each triangle -> 4
    ids = np.array([[n + edge_id[(min(int(f[k]), int(f[(k + 1) % 3])), max(int(f[k]), int(f[(k + 1) % 3])))]
                     for k in range(3)] for f in faces], np.int64)
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    ab, bc, ca = ids[:, 0], ids[:, 1], ids[:, 2]
    new_faces = np.concatenate([np.stack([a, ab, ca], 1), np.stack([ab, b, bc], 1),
                                np.stack([ca, bc, c], 1), np.stack([ab, bc, ca], 1)])
    return matrix, new_faces


def split_long_edges(vertices: np.ndarray, faces: np.ndarray, max_length: float,
                     keep: set[int] | None = None) -> tuple[sparse.csr_matrix, np.ndarray]:
    """Split every triangle that has an edge longer than ``max_length`` into 4 (midpoints), and its
    neighbours conformingly into 2 or 3 (red-green refinement, one pass). Returns ``S`` (new = S @ old,
    rows = old vertices then edge midpoints) and the new faces."""
    faces = np.asarray(faces, np.int64)
    edges = unique_edges(faces)
    length = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)
    marked = set()
    for (a, b), l in zip(edges, length):
        if l > max_length:
            marked.add((int(a), int(b)))
    n = len(vertices)
    mid = {e: n + i for i, e in enumerate(sorted(marked))}
    mid_pairs = {index: edge for edge, index in mid.items()}
    rows, cols, vals = list(range(n)), list(range(n)), [1.0] * n
    for (a, b), r in mid.items():
        rows += [r, r]; cols += [a, b]; vals += [0.5, 0.5]
    matrix = sparse.csr_matrix((vals, (rows, cols)), shape=(n + len(mid), n))
    out = []
    for f in faces:
        f = [int(x) for x in f]
        m = [mid.get((min(f[k], f[(k + 1) % 3]), max(f[k], f[(k + 1) % 3]))) for k in range(3)]
        count = sum(x is not None for x in m)
        if count == 0:
            out.append(f)
        elif count == 3:
            out += [[f[0], m[0], m[2]], [m[0], f[1], m[1]], [m[2], m[1], f[2]], [m[0], m[1], m[2]]]
        else:
            # rotate so the split edges come first, then fan (conforming green/blue split)
            k = next(k for k in range(3) if m[k] is not None and (count == 1 or m[(k + 2) % 3] is None))
            a, b, c = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
            mab, mbc = m[k], m[(k + 1) % 3]
            if count == 1:
                out += [[a, mab, c], [mab, b, c]]
            else:
                # quad a, mab, mbc, c: cut along the shorter diagonal (a mirror-symmetric choice)
                p = lambda i: vertices[i] if i < n else 0.5 * (vertices[mid_pairs[i][0]] + vertices[mid_pairs[i][1]])
                if np.linalg.norm(p(a) - p(mbc)) <= np.linalg.norm(p(mab) - p(c)):
                    out += [[a, mab, mbc], [a, mbc, c], [mab, b, mbc]]
                else:
                    out += [[a, mab, c], [mab, mbc, c], [mab, b, mbc]]
    return matrix, np.array(out, np.int64)


def _point_triangle_closest(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Vectorised closest point on triangles (Ericson, Real-Time Collision Detection 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1 = np.einsum("ij,ij->i", ab, ap); d2 = np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3 = np.einsum("ij,ij->i", ab, bp); d4 = np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5 = np.einsum("ij,ij->i", ab, cp); d6 = np.einsum("ij,ij->i", ac, cp)
    va = d3 * d6 - d5 * d4; vb = d5 * d2 - d1 * d6; vc = d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(np.abs(denom) < 1e-300, 1e-300, denom)
    v = vb / denom; w = vc / denom
    bary = np.stack([1 - v - w, v, w], 1)
    # region tests, applied in reverse priority so the first matching rule wins
    def setb(mask, b0, b1, b2):
        bary[mask] = np.stack([b0[mask], b1[mask], b2[mask]], 1)
    one, zero = np.ones(len(p)), np.zeros(len(p))
    with np.errstate(divide="ignore", invalid="ignore"):
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        setb((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), zero, 1 - t_bc, t_bc)
        t_ac = d2 / (d2 - d6)
        setb((vb <= 0) & (d2 >= 0) & (d6 <= 0), 1 - t_ac, zero, t_ac)
        setb((d6 >= 0) & (d5 <= d6), zero, zero, one)
        t_ab = d1 / (d1 - d3)
        setb((vc <= 0) & (d1 >= 0) & (d3 <= 0), 1 - t_ab, t_ab, zero)
        setb((d3 >= 0) & (d4 <= d3), zero, one, zero)
        setb((d1 <= 0) & (d2 <= 0), one, zero, zero)
    bary = np.nan_to_num(bary)
    point = bary[:, :1] * a + bary[:, 1:2] * b + bary[:, 2:] * c
    return point, bary


def closest_points(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, candidates: int = 12):
    """Closest points on a triangle mesh: ``(point (M,3), face index (M,), barycentric (M,3), distance)``.

    Candidate triangles come from a KD-tree on triangle centroids (exact for meshes whose triangles are
    small relative to the query distance; ``candidates`` widens the search)."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    points = np.asarray(points, np.float64)
    centroids = vertices[faces].mean(axis=1)
    k = min(candidates, len(faces))
    _, cand = cKDTree(centroids).query(points, k=k)
    cand = cand.reshape(len(points), k)
    best_d = np.full(len(points), np.inf)
    best_p = np.zeros_like(points)
    best_f = np.zeros(len(points), np.int64)
    best_b = np.zeros((len(points), 3))
    for j in range(k):
        f = cand[:, j]
        tri = vertices[faces[f]]
        p, b = _point_triangle_closest(points, tri[:, 0], tri[:, 1], tri[:, 2])
        d = np.linalg.norm(p - points, axis=1)
        better = d < best_d
        best_d[better] = d[better]; best_p[better] = p[better]
        best_f[better] = f[better]; best_b[better] = b[better]
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
