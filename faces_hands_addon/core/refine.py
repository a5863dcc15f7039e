# SPDX-License-Identifier: GPL-3.0-or-later
"""Mesh refinement and boundaries (thesis 3.1.2 "Skin": the template skin is refined from the canonical
face): boundary loops, one conforming pass of long-edge splitting, and Loop subdivision, each as a sparse
matrix from the old vertices to the new ones so a refined mesh can be rebuilt from any warped copy of its
base. numpy/scipy only.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse

from .errors import UserError
from .geometry import unique_edges

__all__ = ["boundary_loops", "loop_subdivision", "split_long_edges"]


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


def loop_subdivision(vertex_count: int, faces: np.ndarray) -> tuple[sparse.csr_matrix, np.ndarray]:
    """One level of Loop subdivision as a sparse matrix ``S`` (new = S @ old) and the new faces.

    Interior rules: even vertices ``(1 - n b) v + b sum(neighbours)`` (Warren's ``b``), odd vertices
    ``3/8 (a + b) + 1/8 (c + d)``; boundary (and hole) vertices use the cubic B-spline curve rules, so
    the holes of the mouth and the eyes stay clean loops. Old vertices keep their indices; edge
    vertices follow in the order of :func:`unique_edges`.
    """
    faces = np.asarray(faces, np.int64)
    n = vertex_count
    edges, counts = unique_edges(faces, return_counts=True)
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
