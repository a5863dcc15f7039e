# SPDX-License-Identifier: GPL-3.0-or-later
"""The forearm end of the reference skin: a clean, rounded cut (thesis 6.2.1: the skin surface round the 29
bones, of which radius and ulna reach into the forearm; the thesis' Fig. 6.13 ends its hand just past the
wrist).

The WebXR hand closes its forearm with a flat cap whose rim zig-zags 14 mm up and down (alternate rim
nodes at 7 and 21 mm above the wrist joint, edges folded 100-109 degrees): every contact-sheet cell showed
a saw-tooth at the cut. So the skin above ``CUT`` (along the forearm's axis from the wrist joint) is
removed; the cut's loop is levelled at ``CUT`` and closed by a dome up to ``TOP``: a quarter ellipse in
profile, one ring of new nodes per elevation of ``RINGS`` (every node of the loop, then every second or
fourth), then one node on the axis. The section is the cut's own, smoothed: its radius round the section
centre as a function of the angle, fitted by a Fourier series of ``HARMONICS`` terms, so the end is as
round as the forearm. Last, the skin ``BAND`` below the cut and the dome's first ring are faired
(:func:`fair`), so the forearm runs into the dome without a step. New nodes take the skinning weights and
UVs of the loop's nodes they grow from.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
import scipy.sparse.linalg  # noqa: F401  (sparse.linalg)

from ..core import geometry, refine
from .skeleton import Skeleton

__all__ = ["CUT", "TOP", "RINGS", "forearm_axis", "round_forearm_end"]

CUT = 0.008            # m above the wrist joint: skin above this goes
TOP = 0.020            # m: the top of the new end, on the axis (the asset's cap was at 15-21 mm)
RINGS = ((30.0, 1), (55.0, 1), (75.0, 2))   # dome rings: elevation (degrees) and node step along the cut
BAND = 0.010           # m below the cut whose skin is faired into the new end
HARMONICS = 3


def forearm_axis(skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """(wrist joint centre, unit direction up the forearm)."""
    wrist = skeleton.position[skeleton.index["wrist"]]
    axis = skeleton.position[skeleton.index["forearm"]] - wrist
    return wrist, axis / np.linalg.norm(axis)


def _section(points: np.ndarray, origin: np.ndarray, axis: np.ndarray):
    """(centre, in-plane basis (2, 3), angle per point, smoothed radius function) of the cut's loop; the basis
    is turned so that the angles grow along the loop."""
    e1 = np.cross(axis, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    basis = np.stack([e1, np.cross(axis, e1)])
    flat = (points - origin) @ basis.T
    centre2 = flat.mean(axis=0)
    d = flat - centre2
    if np.sum(d[:, 0] * np.roll(d[:, 1], -1) - np.roll(d[:, 0], -1) * d[:, 1]) < 0:
        basis[1], d[:, 1] = -basis[1], -d[:, 1]
    angle = np.arctan2(d[:, 1], d[:, 0])
    k = np.arange(1, HARMONICS + 1)

    def design(a):
        a = np.asarray(a, float)
        return np.column_stack([np.ones_like(a), np.cos(np.outer(a, k)), np.sin(np.outer(a, k))])

    coef = np.linalg.lstsq(design(angle), np.linalg.norm(d, axis=1), rcond=None)[0]
    return origin + centre2 @ basis, basis, angle, lambda a: design(a) @ coef


def _zip(lower: np.ndarray, lower_angle: np.ndarray, upper: np.ndarray, upper_angle: np.ndarray) -> list:
    """Triangles between two closed rings of node indices, both ordered along the cut loop (angles growing);
    oriented like the faces below ``lower``, whose edges run along it."""
    a_ang = np.unwrap(np.r_[lower_angle, lower_angle[0]])
    a_ang[-1] = a_ang[0] + 2 * np.pi
    start = int(np.argmin(np.abs(np.angle(np.exp(1j * (upper_angle - lower_angle[0]))))))
    upper, upper_angle = np.roll(upper, -start), np.roll(upper_angle, -start)
    b_ang = np.unwrap(np.r_[upper_angle, upper_angle[0]])
    b_ang += 2 * np.pi * np.round((a_ang[0] - b_ang[0]) / (2 * np.pi))
    b_ang[-1] = b_ang[0] + 2 * np.pi
    m, n = len(lower), len(upper)
    i = j = 0
    out = []
    while i < m or j < n:
        if j >= n or (i < m and a_ang[i + 1] <= b_ang[j + 1]):
            out.append((lower[(i + 1) % m], lower[i], upper[j % n]))
            i += 1
        else:
            out.append((lower[i % m], upper[j], upper[(j + 1) % n]))
            j += 1
    return out


def round_forearm_end(vertices, faces, corner_uvs, weights, skeleton: Skeleton):
    """The skin with its forearm end rebuilt (module docstring): (vertices, faces, corner_uvs, weights)."""
    origin, axis = forearm_axis(skeleton)
    gone = (vertices - origin) @ axis > CUT
    kept = ~gone[faces].any(axis=1)
    loop = refine.boundary_loops(faces[kept])[0]
    centre, basis, angle, radius = _section(vertices[loop], origin, axis)
    keep = np.flatnonzero(~gone)
    new_index = np.full(len(vertices), -1)
    new_index[keep] = np.arange(len(keep))
    corner_of = {}
    for face, corners in zip(faces[kept][::-1], corner_uvs[kept][::-1]):
        corner_of.update({int(v): uv for v, uv in zip(face, corners)})
    loop_uv = np.array([corner_of[int(v)] for v in loop])
    out_v, out_w, out_uv = [vertices[keep]], [weights[keep]], []
    count, ring, ring_angle, step, new_faces = len(keep), new_index[loop], angle, 1, []
    height = CUT - float((centre - origin) @ axis)
    dome = TOP - CUT

    def ring_points(elevation, pick):
        phi = np.radians(elevation)
        r = radius(angle[pick]) * np.cos(phi)
        return (centre + axis * (height + dome * np.sin(phi))
                + r[:, None] * (np.cos(angle[pick])[:, None] * basis[0] + np.sin(angle[pick])[:, None] * basis[1]))

    out_v[0][new_index[loop]] = ring_points(0.0, np.arange(len(loop)))     # the cut itself: level and round
    first_ring = count
    for elevation, more in RINGS:
        step *= more
        pick = np.arange(0, len(loop), step)
        out_v.append(ring_points(elevation, pick))
        out_w.append(weights[loop[pick]])
        out_uv.append(loop_uv[pick] + (elevation / 90.0) * (loop_uv.mean(axis=0) - loop_uv[pick]))
        index = count + np.arange(len(pick))
        count += len(pick)
        new_faces += _zip(ring, ring_angle, index, angle[pick])
        ring, ring_angle = index, angle[pick]
    out_v.append((centre + axis * (height + dome))[None])
    out_w.append(weights[loop].mean(axis=0)[None])
    out_uv.append(loop_uv.mean(axis=0)[None])
    new_faces += [(ring[(i + 1) % len(ring)], ring[i], count) for i in range(len(ring))]
    new_faces = np.array(new_faces, np.int64)
    uv = np.concatenate([loop_uv] + out_uv)
    local = {int(v): k for k, v in enumerate(new_index[loop])}
    uv_index = np.vectorize(lambda v: local[v] if v in local else v - len(keep) + len(loop))(new_faces)
    faces_out = np.concatenate([new_index[faces[kept]], new_faces])
    uvs_out = np.concatenate([corner_uvs[kept], uv[uv_index]])
    out = np.concatenate(out_v)
    free = np.zeros(len(out), bool)
    free[:len(keep)] = (vertices[keep] - origin) @ axis > CUT - BAND
    free[first_ring:first_ring + len(loop)] = True
    return fair(out, faces_out, free), faces_out, uvs_out, np.concatenate(out_w)


def fair(vertices: np.ndarray, faces: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``vertices`` with the ``free`` ones (N,) bool moved to where the mesh's squared umbrella Laplacian is
    least (a thin-plate surface over the mesh's connectivity, fixed by the others: smooth, and joined
    smoothly to the fixed surface round it)."""
    edges = geometry.unique_edges(faces)
    n = len(vertices)
    adjacency = sparse.coo_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                                              np.r_[edges[:, 1], edges[:, 0]])), (n, n)).tocsr()
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    laplacian = (sparse.identity(n) - sparse.diags(1.0 / degree) @ adjacency).tocsr()
    energy = (laplacian.T @ laplacian).tocsr()
    idx, fixed = np.flatnonzero(free), np.flatnonzero(~free)
    out = vertices.copy()
    out[idx] = sparse.linalg.spsolve(energy[idx][:, idx].tocsc(), -(energy[idx][:, fixed] @ vertices[fixed]))
    return out
