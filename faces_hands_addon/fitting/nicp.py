# SPDX-License-Identifier: GPL-3.0-or-later
"""Optimal-step non-rigid ICP of the 468-vertex template onto the target surface.

Amberg, Romdhani & Vetter, "Optimal Step Nonrigid ICP Algorithms for Surface Registration", CVPR 2007:
every template vertex ``v_i`` gets its own affine map ``X_i`` (4x3). For a fixed set of closest-point
correspondences ``u_i`` with weights ``w_i`` the energy

    E(X) = alpha^2 * || (M kron G) X ||^2  +  || W (D X - U) ||^2

(``M`` the template's node-arc incidence matrix, ``G = diag(1, 1, 1, gamma)``, ``D`` the sparse matrix
of the vertices' homogeneous coordinates) is quadratic, so its optimum is one sparse linear solve
(scipy SuperLU on the 4n x 4n normal equations, three right-hand sides). Correspondences are re-found
until they settle, then the stiffness ``alpha`` is lowered, so the template bends more and more locally
(a longer nose, fuller cheeks).

Point-to-point ICP needs many iterations to discover a global change such as a non-uniform scale, so
the stiff end of Amberg's schedule is replaced by a global affine ICP with the point-to-plane metric
(Chen & Medioni 1992; 12 unknowns, converges in a few iterations; :func:`affine_icp`). Closest points also
pull tangentially, which biases where the template ends up along the surface (worst at the face's sides);
a final stage (:func:`plane_refinement`) therefore repeats the lowest stiffness with mostly point-to-plane
rows (the x, y, z columns of ``X`` couple, so it solves one 12n x 12n system): the template may slide
along the surface and its tangential placement is decided by the stiffness and the reverse term.

Correspondences are closest points on the target TRIANGLES; they are dropped (weight 0) when they lie on
a mesh border, i.e. the rim of an eye or mouth opening or the edge of a face mask (Amberg's rule, so holes
and boundaries do not drag the template), when the normals disagree by more than 60 degrees, or when they
are far compared with the others. Such template vertices are carried by the stiffness term.

Closest points from template to target alone cannot pull the template into a protrusion it lacks (a
longer nose: the template's tip finds the sides of the target's nose and stays put). A reverse term adds,
for points sampled uniformly on the target's face region, their closest points on the deformed template
(a barycentric combination of three template vertices, so still linear in ``X``), with the same
rejection rules (here a template border means "this target point lies outside the face"). Symmetric
closest-point terms of this kind are standard in template fitting (e.g. Li, Sumner & Pauly, "Global
Correspondence Optimization for Non-Rigid Registration of Depth Scans", SGP 2008). This is how
thesis 3.1.2 ("feature points must be placed at corresponding locations on the target skin mesh") gets
its feature points without hand placement.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import cg, splu

from ..core.errors import UserError
from .align import correspondence_mask
from ..core.geometry import vertex_normals
from .surface import SurfaceHit, TargetSurface, least_squares
from .template import LEFT_TRAGUS, RIGHT_TRAGUS, FaceTemplate

__all__ = ["NicpResult", "affine_icp", "nonrigid_icp", "plane_refinement", "STIFFNESS_SCHEDULE"]

STIFFNESS_SCHEDULE = (20.0, 5.0, 1.5, 0.5)
_GAMMA = 1.0                  # weight of the translation column in the stiffness term (face width = 1)
_MAX_ITERATIONS_PER_STAGE = 4
_SETTLED = 5e-4               # max vertex motion between iterations, in face widths
_AFFINE_ITERATIONS = 30
_AFFINE_KEEP = 0.85           # trimmed affine ICP keeps the best 85 % of the correspondences
_POINT_WEIGHT = 0.3           # affine ICP: point-to-point rows relative to the point-to-plane row
_PLANE_STIFFNESS = 0.5        # final point-to-plane stage: stiffness, ...
_PLANE_ITERATIONS = 4         # ... iterations, ...
_PLANE_POINT_WEIGHT = 0.1     # ... and weight of its point-to-point rows
_MAX_NORMAL_ANGLE = 60.0
_DISTANCE_FACTOR = 3.0        # reject correspondences beyond this many times the median distance ...
_MIN_DISTANCE_LIMIT = 0.02    # ... but never below 2 % of the face width
_REVERSE_WEIGHT = 1.0         # total weight of the target->template term relative to template->target


@dataclass
class NicpResult:
    vertices: np.ndarray      # (n, 3) deformed template, world units
    hit: SurfaceHit           # closest points of the final vertices
    matched: np.ndarray       # (n,) bool: had a usable correspondence in the last iteration
    iterations: int


def _face_size(points: np.ndarray) -> float:
    return float(np.linalg.norm(points[LEFT_TRAGUS] - points[RIGHT_TRAGUS])) or float(np.ptp(points, axis=0).max())


def _correspondences(template: FaceTemplate, surface: TargetSurface, points: np.ndarray, size: float,
                     keep_fraction: float = 1.0, exact: bool = False):
    hit = surface.closest(points, exact=exact)
    normals = vertex_normals(points, template.faces)
    ok = correspondence_mask(hit, normals, _MAX_NORMAL_ANGLE, _DISTANCE_FACTOR, _MIN_DISTANCE_LIMIT * size,
                             keep_fraction)
    return hit, ok


def affine_icp(template: FaceTemplate, surface: TargetSurface, start: np.ndarray) -> np.ndarray:
    """Global affine ICP of the placed template vertices ``start`` onto the surface (point-to-plane with
    a small point-to-point term, trimmed); returns the moved vertices. Linearised around the current
    pose: ``p' = p + B (p - c) + t`` with a general 3x3 ``B``."""
    points = np.array(start, np.float64)
    size = _face_size(points)
    for _ in range(_AFFINE_ITERATIONS):
        hit, ok = _correspondences(template, surface, points, size, _AFFINE_KEEP)
        if ok.sum() < 12:
            break
        p, q, n = points[ok], hit.points[ok], hit.normals[ok]
        centre = p.mean(axis=0)
        rel = (p - centre) / size
        plane = np.column_stack([(n[:, :, None] * rel[:, None, :]).reshape(-1, 9), n])   # B_bc: n_b rel_c
        point = np.zeros((len(p), 3, 12))
        for b in range(3):
            point[:, b, 3 * b:3 * b + 3] = rel
            point[:, b, 9 + b] = 1.0
        rows = np.vstack([plane, _POINT_WEIGHT * point.reshape(-1, 12)])
        rhs = np.concatenate([(n * (q - p)).sum(1), _POINT_WEIGHT * (q - p).reshape(-1)]) / size
        solution = least_squares(rows, rhs)
        linear, shift = solution[:9].reshape(3, 3), solution[9:] * size
        moved = points + (points - centre) @ linear.T + shift
        step = float(np.abs(moved - points).max()) / size
        points = moved
        if step < _SETTLED:
            break
    return points


def _stiffness_matrix(edges: np.ndarray, count: int, weights) -> sparse.csr_matrix:
    """``(M kron G)^T (M kron G)`` for the template's edges: ``M`` the node-arc incidence matrix, ``G`` the
    diagonal ``weights`` of one vertex's unknowns (``[1, 1, 1, gamma]``: unknowns ``4 i + a``)."""
    rows = np.repeat(np.arange(len(edges)), 2)
    vals = np.tile([1.0, -1.0], len(edges))
    incidence = sparse.csr_matrix((vals, (rows, edges.ravel())), shape=(len(edges), count))
    block = sparse.kron(incidence, sparse.diags(np.asarray(weights, np.float64)), format="csr")
    return (block.T @ block).tocsr()


def _barycentric_rows(corners: np.ndarray, bary: np.ndarray, base: np.ndarray) -> sparse.csr_matrix:
    """Sparse rows (m x 4n) giving ``sum_k bary_k [v_k, 1] X_k`` (a point of the deformed template)."""
    m = len(corners)
    homog = np.concatenate([base[corners], np.ones(corners.shape + (1,))], axis=2)    # (m, 3, 4)
    rows = np.repeat(np.arange(m), 12)
    cols = (4 * corners[:, :, None] + np.arange(4)).reshape(-1)
    vals = (bary[:, :, None] * homog).reshape(-1)
    return sparse.csr_matrix((vals, (rows, cols)), shape=(m, 4 * len(base)))


def _reverse_correspondences(template: FaceTemplate, current: np.ndarray, samples: np.ndarray,
                             sample_normals: np.ndarray):
    """Closest points on the deformed template (normalised units) for the target samples: the template
    triangle corners and barycentric weights of the kept ones, and the keep mask."""
    back = TargetSurface(current, template.faces, nearest_vertices=1, nearest_centroids=4).closest(samples)
    keep = correspondence_mask(back, sample_normals, _MAX_NORMAL_ANGLE, _DISTANCE_FACTOR, _MIN_DISTANCE_LIMIT)
    return template.faces[back.triangles[keep]], back.barycentric[keep], keep


def nonrigid_icp(template: FaceTemplate, surface: TargetSurface, start: np.ndarray, *,
                 target_samples: np.ndarray | None = None, target_sample_normals: np.ndarray | None = None,
                 schedule=STIFFNESS_SCHEDULE, progress=None) -> NicpResult:
    """Deform the template vertices ``start`` ((n, 3), roughly aligned, world units) onto ``surface``.

    ``target_samples`` (with unit normals) are points spread over the target's face region for the
    reverse term; without them only template->target correspondences are used. Works in coordinates
    normalised by the template's current tragus-to-tragus width, so the stiffness schedule is scale
    free. ``progress(fraction, message)`` is called once per stiffness stage.
    """
    count = len(start)
    centre = start.mean(axis=0)
    size = _face_size(start)
    base = (start - centre) / size
    stiffness = _stiffness_matrix(template.edges, count, [1.0, 1.0, 1.0, _GAMMA])
    homogeneous = _barycentric_rows(np.column_stack([np.arange(count), np.zeros((count, 2), np.int64)]),
                                    np.tile([1.0, 0.0, 0.0], (count, 1)), base)       # Amberg's D
    samples = None if target_samples is None else (np.asarray(target_samples) - centre) / size
    current = base.copy()
    iterations = 0
    matched = np.zeros(count, bool)
    for stage, alpha in enumerate(schedule):
        for _ in range(_MAX_ITERATIONS_PER_STAGE):
            hit, matched = _correspondences(template, surface, current * size + centre, size)
            if matched.sum() < 12:
                break
            weighted = homogeneous.T @ sparse.diags(matched.astype(np.float64))
            system = (alpha * alpha) * stiffness + weighted @ homogeneous
            rhs = weighted @ ((hit.points - centre) / size)
            if samples is not None and len(samples):
                corners, bary, keep = _reverse_correspondences(template, current, samples, target_sample_normals)
                if keep.sum() >= 12:
                    rows = _barycentric_rows(corners, bary, base)
                    weight = _REVERSE_WEIGHT * matched.sum() / keep.sum()
                    system = system + weight * (rows.T @ rows)
                    rhs = rhs + weight * (rows.T @ samples[keep])
            moved = homogeneous @ _lu_solve(system, rhs)
            step = float(np.abs(moved - current).max())
            current = moved
            iterations += 1
            if step < _SETTLED:
                break
        if progress is not None:
            progress((stage + 1) / len(schedule), f"non-rigid registration, stiffness {alpha:g}")
    vertices = current * size + centre
    hit, matched = _correspondences(template, surface, vertices, size)
    return NicpResult(vertices, hit, matched, iterations)


def _plane_rows(corners: np.ndarray, bary: np.ndarray, base: np.ndarray, points: np.ndarray,
                normals: np.ndarray, weight: float):
    """Rows over the 12n unknowns (``12 i + 3 a + b``: vertex i, homogeneous row a, coordinate b) asking the
    template point ``sum_k bary_k X_k^T [v_k, 1]`` to lie on the plane through ``points`` with ``normals``
    (one row each), plus ``_PLANE_POINT_WEIGHT`` x point-to-point rows (three each); scaled by sqrt(weight)."""
    m = len(corners)
    coeff = bary[:, :, None] * np.concatenate([base[corners], np.ones(corners.shape + (1,))], axis=2)
    columns = 12 * corners[:, :, None] + 3 * np.arange(4)                           # (m, 3, 4)
    root = np.sqrt(weight)
    point_rows = np.repeat(np.arange(3 * m), 12)
    point_cols = (columns[:, None] + np.arange(3)[None, :, None, None]).reshape(-1)
    point_vals = np.broadcast_to(coeff[:, None], (m, 3, 3, 4)).reshape(-1) * (root * _PLANE_POINT_WEIGHT)
    plane_rows = 3 * m + np.repeat(np.arange(m), 36)
    plane_cols = (columns[..., None] + np.arange(3)).reshape(-1)
    plane_vals = (coeff[..., None] * normals[:, None, None, :]).reshape(-1) * root
    matrix = sparse.csr_matrix((np.concatenate([point_vals, plane_vals]),
                                (np.concatenate([point_rows, plane_rows]), np.concatenate([point_cols, plane_cols]))),
                               shape=(4 * m, 12 * len(base)))
    rhs = np.concatenate([points.reshape(-1) * (root * _PLANE_POINT_WEIGHT), (points * normals).sum(1) * root])
    return matrix, rhs


def _block_jacobi(system: sparse.csr_matrix, block: int) -> sparse.csr_matrix:
    """Inverse of the ``block`` x ``block`` diagonal blocks, as a sparse preconditioner."""
    coo = system.tocoo()
    same = coo.row // block == coo.col // block
    count = system.shape[0] // block
    blocks = np.zeros((count, block, block))
    blocks[coo.row[same] // block, coo.row[same] % block, coo.col[same] % block] = coo.data[same]
    scale = np.abs(blocks).max() or 1.0
    inverse = np.linalg.inv(blocks + 1e-12 * scale * np.eye(block))
    index = np.arange(block * count).reshape(count, block)
    rows = np.repeat(index, block, axis=1).ravel()
    cols = np.tile(index, (1, block)).ravel()
    return sparse.csr_matrix((inverse.ravel(), (rows, cols)), shape=system.shape)


def _lu_solve(system: sparse.spmatrix, vector: np.ndarray) -> np.ndarray:
    """Sparse LU solve; a singular system (a head mesh whose parts cannot hold the template: degenerate or
    detached) is the artist's mesh's problem, said as such, not SuperLU's 'Factor is exactly singular'."""
    try:
        return splu(system.tocsc()).solve(vector)
    except RuntimeError as error:
        if "singular" not in str(error).lower():
            raise
        raise UserError("the face template cannot be registered onto this mesh (its equations are singular): "
                        "remove degenerate, duplicate or detached parts of the head mesh, or place the "
                        "landmarks by hand") from None


def _solve_spd(system: sparse.csr_matrix, vector: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """Symmetric positive definite solve: block-Jacobi conjugate gradients warm-started from ``guess``
    (the previous iteration's maps, so few iterations are needed), sparse LU when CG does not converge."""
    solution, info = cg(system, vector, x0=guess, rtol=1e-6, maxiter=600, M=_block_jacobi(system, 12))
    if info != 0 or not np.isfinite(solution).all():
        solution = _lu_solve(system, vector)
    return solution


def plane_refinement(template: FaceTemplate, surface: TargetSurface, start: np.ndarray, *,
                     target_samples: np.ndarray | None = None, target_sample_normals: np.ndarray | None = None,
                     alpha: float = _PLANE_STIFFNESS, iterations: int = _PLANE_ITERATIONS) -> NicpResult:
    """Final non-rigid stage with the point-to-plane metric (see the module docstring)."""
    count = len(start)
    centre = start.mean(axis=0)
    size = _face_size(start)
    base = (start - centre) / size
    stiffness = _stiffness_matrix(template.edges, count, np.repeat([1.0, 1.0, 1.0, _GAMMA], 3))
    own = np.column_stack([np.arange(count), np.zeros((count, 2), np.int64)])
    unit = np.tile([1.0, 0.0, 0.0], (count, 1))
    homog = np.column_stack([base, np.ones(count)])
    samples = None if target_samples is None else (np.asarray(target_samples) - centre) / size
    current = base.copy()
    done = 0
    maps = None
    for _ in range(iterations):
        hit, matched = _correspondences(template, surface, current * size + centre, size)
        if matched.sum() < 12:
            break
        matrix, rhs = _plane_rows(own[matched], unit[matched], base, (hit.points[matched] - centre) / size,
                                  hit.normals[matched], 1.0)
        system = (alpha * alpha) * stiffness + matrix.T @ matrix
        vector = matrix.T @ rhs
        if samples is not None and len(samples):
            corners, bary, keep = _reverse_correspondences(template, current, samples, target_sample_normals)
            if keep.sum() >= 12:
                weight = _REVERSE_WEIGHT * matched.sum() / keep.sum()
                matrix, rhs = _plane_rows(corners, bary, base, samples[keep], target_sample_normals[keep], weight)
                system = system + matrix.T @ matrix
                vector = vector + matrix.T @ rhs
        guess = np.tile(np.vstack([np.eye(3), np.zeros((1, 3))]), (count, 1)).reshape(-1) if done == 0 else maps
        maps = _solve_spd(system.tocsr(), vector, guess.reshape(-1)).reshape(count, 4, 3)
        moved = np.einsum("na,nab->nb", homog, maps)
        step = float(np.abs(moved - current).max())
        current = moved
        done += 1
        if step < _SETTLED:
            break
    vertices = current * size + centre
    hit, matched = _correspondences(template, surface, vertices, size, exact=True)
    return NicpResult(vertices, hit, matched, done)
