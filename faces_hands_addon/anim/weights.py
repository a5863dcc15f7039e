# SPDX-License-Identifier: GPL-3.0-or-later
"""Engine-ready animation: a simulated performance expressed as weights over a fixed set of targets.

Game engines retarget, blend, compress and stream a fixed set of named morph targets (the 52 ARKit shapes,
the 15 visemes, the rig's emotion targets) with animated weights; they cannot use one target per frame.
So every frame's simulated pose P_f is projected onto the baked targets: with the targets' displacements
B (rows: every coordinate of every exported vertex, the skin and the rigid parts alike; columns: targets) and
d_f = P_f - rest, the weights solve

    min_w || B w - d_f ||^2   subject to  0 <= w <= 1,

the bounds engines expect of ARKit-style weights. Since B has many rows and few columns, the problem is
reduced once to its Gram form (G = B^T B + eps I = L L^T, then min || L^T w - L^-1 B^T d_f ||), so each frame
is a tiny bounded least-squares problem. The residual per frame is the largest vertex distance between the
simulated pose and its weighted reconstruction.

A shape fit alone is ambiguous: many targets overlap (``jawOpen`` and ``viseme_aa``, the mouth corners of
the smiles, frowns and dimples), and the best-fitting mix on this head can be meaningless on another (an
open vowel as frowns plus a lowered lower lip). So the fit may be held near *prior* weights p_f (the frame's
semantic weights, ``semantic``): min_w ||B w - d_f||^2 + lambda s ||w - p_f||^2 (s: the Gram matrix's mean
diagonal), which costs little residual and keeps the weights' meaning. Frames that must show one viseme
(a lip closure) take the prior as it is, with no corrective weight.

The per-frame problems are tiny (a few hundred rows, ~120 columns), and a threaded BLAS spends longer waking
its threads than computing them, badly so on a busy machine (a render farm, or tests beside the bake): a
242 x 121 gradient took 3.4 ms with two OpenBLAS threads against 0.04 ms with one on this machine under
load, and ``./fh speak`` of 56.6 s of speech spent 43.6 s in the weight fit, 11.4 s with one BLAS thread for
the whole process (both runs under load). So the frame loops run with one BLAS thread (``threadpoolctl``);
the large products of a block keep every thread.

Where numba is loaded the frames are solved by compiled primal-dual active-set loops (``_box_normal`` and
``_box_qr``,
Hintermueller, Ito & Kunisch 2002): the free weights solve the least-squares problem of their columns, a
free weight beyond a bound is fixed there, a fixed one whose gradient points inside is freed, until the
sets repeat -- then the KKT conditions of ``_optimal`` hold. Each frame starts from the previous frame's
sets (~3 solves a frame). The free problem is solved from the normal equations by Cholesky where the prior
rows bound their condition (<= T / lambda + 1), else by Householder QR of the free columns (the correctives'
Gram matrix alone has condition ~4e10, too much to square). A frame it does not settle goes to
:func:`bounded_nnls`, the reference (scipy's Lawson-Hanson NNLS, ~10x slower here).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, solve_triangular
from scipy.optimize import lsq_linear, nnls
from ..core.blas import one_blas_thread
from ..core.errors import UserError
from ..physics import kernel

__all__ = ["TargetBasis", "WeightFit", "WeightSolver", "fit_weights", "stack_pose", "bounded_nnls"]

REGULARISATION = 1e-9      # relative to the Gram matrix's mean diagonal: equal targets share weight evenly
PRIOR_STRENGTH = 0.3       # lambda: measured on speech, residual median +0.1 mm, L1 distance to the prior / 4
BOX_ROUNDS = 30            # active-set rounds of the compiled solver before a frame falls back to bounded_nnls


@dataclass(frozen=True)
class TargetBasis:
    """The targets (name -> displacement of every exported vertex from rest, (V, 3)) of one rig, the
    vertices stacked in one fixed order (skin first, then each rigid part)."""
    names: tuple[str, ...]
    displacements: np.ndarray            # (T, V, 3) float64

    def __post_init__(self) -> None:
        if self.displacements.ndim != 3 or self.displacements.shape[0] != len(self.names):
            raise UserError("every target needs one displacement per vertex")
        if not np.all(np.isfinite(self.displacements)):
            raise UserError("a baked target holds non-finite positions; bake the targets again")

    @property
    def vertex_count(self) -> int:
        return int(self.displacements.shape[1])


@dataclass(frozen=True)
class WeightFit:
    """Per frame: the target weights (F, T) in [0, 1] and the largest vertex error of the reconstruction
    (F,) in metres."""
    names: tuple[str, ...]
    weights: np.ndarray
    residual: np.ndarray

    def residual_mm(self) -> tuple[float, float, float]:
        """Median, 90th percentile and maximum of the per-frame residual, in millimetres."""
        if not len(self.residual):
            return 0.0, 0.0, 0.0
        millimetres = self.residual * 1000.0
        return float(np.median(millimetres)), float(np.percentile(millimetres, 90)), float(millimetres.max())


def bounded_nnls(matrix: np.ndarray, rhs: np.ndarray, upper: float = 1.0, rounds: int = 12) -> np.ndarray:
    """``min ||A w - b||`` with ``0 <= w <= upper``. Fast path: non-negative least squares (Lawson-Hanson,
    compiled) with the weights that overshoot fixed at ``upper`` and those whose gradient asks to leave the
    bound released, until the optimality (KKT) conditions hold; when they do not within ``rounds``, scipy's
    bounded-variable least squares (BVLS, ~40x slower) gives the exact minimum."""
    count = matrix.shape[1]
    fixed = np.zeros(count, bool)
    weights = np.zeros(count)
    for _ in range(rounds):
        free = np.flatnonzero(~fixed)
        target = rhs - matrix[:, fixed].sum(axis=1) * upper
        solution = nnls(matrix[:, free], target, maxiter=50 * count)[0] if len(free) else np.zeros(0)
        weights[:] = upper * fixed
        weights[free] = np.minimum(solution, upper)
        over = free[solution > upper]
        gradient = matrix.T @ (matrix @ weights - rhs)
        release = np.flatnonzero(fixed & (gradient > 0))
        if not len(over) and not len(release):
            break
        fixed[over] = True
        fixed[release] = False
    if not _optimal(matrix, rhs, weights, upper):
        weights = lsq_linear(matrix, rhs, bounds=(0.0, upper), method="bvls").x
    return np.clip(weights, 0.0, upper)


def _box_normal(hessian, targets, tolerances, low, high, rounds, weights, solved):  # pragma: no cover - compiled
    """The active-set loop of the module docstring for each frame's ``targets`` row (A^T b), the free
    weights from the normal equations ``hessian`` (A^T A) by Cholesky. Scalar loops only (numba compiles
    them in about a second; numpy's array expressions took ~10 s). ``solved[f]`` False: not settled in
    ``rounds`` rounds or not positive definite (the caller solves that frame another way)."""
    n = hessian.shape[0]
    chol, right, w, free = np.empty((n, n)), np.empty(n), np.empty(n), np.empty(n, np.int64)
    for f in range(targets.shape[0]):
        at0, at1, solved[f], ok = low.copy(), high.copy(), False, True
        for _ in range(rounds):
            k = 0
            for i in range(n):
                w[i] = 1.0 if at1[i] else 0.0
                if not (at0[i] or at1[i]):
                    free[k], k = i, k + 1
            for a in range(k):
                total = targets[f, free[a]]
                for i in range(n):
                    total -= hessian[free[a], i] * w[i]
                right[a] = total
            for j in range(k):                          # Cholesky, lower triangle
                for i in range(j, k):
                    total = hessian[free[i], free[j]]
                    for p in range(j):
                        total -= chol[i, p] * chol[j, p]
                    if i == j:
                        ok = ok and total > 0.0
                        chol[j, j] = np.sqrt(total) if total > 0.0 else 1.0
                    else:
                        chol[i, j] = total / chol[j, j]
            for j in range(k):                          # L y = right, then L^T x = y
                for p in range(j):
                    right[j] -= chol[j, p] * right[p]
                right[j] /= chol[j, j]
            for j in range(k - 1, -1, -1):
                for p in range(j + 1, k):
                    right[j] -= chol[p, j] * right[p]
                right[j] /= chol[j, j]
            for a in range(k):
                w[free[a]] = right[a]
            if not ok:
                break
            if _sets_settled(hessian, targets[f], tolerances[f], w, at0, at1):
                solved[f] = True
                break
        if solved[f]:
            for i in range(n):
                weights[f, i] = min(max(w[i], 0.0), 1.0)
            low[:] = at0
            high[:] = at1


def _box_qr(matrix, rhs, hessian, targets, tolerances, low, high, rounds, weights,
            solved):  # pragma: no cover - compiled
    """:func:`_box_normal` with the free weights from Householder QR of the free columns of ``matrix``
    (the squared system's condition would be too large: the correctives' Gram matrix alone has ~4e10)."""
    m, n = matrix.shape
    work, right, w, free = np.empty((m, n)), np.empty(m), np.empty(n), np.empty(n, np.int64)
    for f in range(rhs.shape[0]):
        at0, at1, solved[f], ok = low.copy(), high.copy(), False, True
        for _ in range(rounds):
            k = 0
            for i in range(n):
                w[i] = 1.0 if at1[i] else 0.0
                if not (at0[i] or at1[i]):
                    free[k], k = i, k + 1
            for r in range(m):
                total = rhs[f, r]
                for i in range(n):
                    total -= matrix[r, i] * w[i]
                right[r] = total
                for c in range(k):
                    work[r, c] = matrix[r, free[c]]
            for j in range(k):
                size = 0.0
                for r in range(j, m):
                    size += work[r, j] * work[r, j]
                ok = ok and size > 0.0
                alpha = -np.sqrt(size) if work[j, j] > 0.0 else np.sqrt(size)
                work[j, j] -= alpha                     # the reflector v = x - alpha e1, kept in column j
                length = max(size - 2.0 * alpha * (work[j, j] + alpha) + alpha * alpha, 1e-300)
                for c in range(j + 1, k + 1):           # columns right of j, then the right-hand side
                    total = 0.0
                    for r in range(j, m):
                        total += work[r, j] * (work[r, c] if c < k else right[r])
                    for r in range(j, m):
                        if c < k:
                            work[r, c] -= 2.0 * total / length * work[r, j]
                        else:
                            right[r] -= 2.0 * total / length * work[r, j]
                work[j, j] = alpha if size > 0.0 else 1.0
            for j in range(k - 1, -1, -1):
                for p in range(j + 1, k):
                    right[j] -= work[j, p] * right[p]
                right[j] /= work[j, j]
            for a in range(k):
                w[free[a]] = right[a]
            if not ok:
                break
            if _sets_settled(hessian, targets[f], tolerances[f], w, at0, at1):
                solved[f] = True
                break
        if solved[f]:
            for i in range(n):
                weights[f, i] = min(max(w[i], 0.0), 1.0)
            low[:] = at0
            high[:] = at1


def _sets_settled(hessian, target, tolerance, w, at0, at1) -> bool:  # pragma: no cover - compiled
    """One active-set update (in place): a free weight beyond a bound is fixed there, a fixed one whose
    gradient (A^T (A w - b)) points inside is freed. True when nothing changed (the KKT point)."""
    changed = False
    for i in range(len(w)):
        gradient = -target[i]
        for c in range(len(w)):
            gradient += hessian[i, c] * w[c]
        fixed = at0[i] or at1[i]
        now0 = (at0[i] and gradient >= -tolerance) if fixed else w[i] < 0.0
        now1 = (at1[i] and gradient <= tolerance) if fixed else w[i] > 1.0
        changed = changed or now0 != at0[i] or now1 != at1[i]
        at0[i], at1[i] = now0, now1
    return not changed


def _optimal(matrix: np.ndarray, rhs: np.ndarray, weights: np.ndarray, upper: float) -> bool:
    """KKT conditions of the bounded problem: zero gradient where a weight is free, pointing outwards
    where it sits on a bound (relative tolerance)."""
    gradient = matrix.T @ (matrix @ weights - rhs)
    tolerance = 1e-9 * max(1.0, float(np.abs(matrix.T @ rhs).max(initial=0.0)))
    low, high = weights <= 1e-12, weights >= upper - 1e-12
    inside = ~(low | high)
    return bool(np.all(np.abs(gradient[inside]) <= tolerance) and np.all(gradient[low] >= -tolerance)
                and np.all(gradient[high] <= tolerance))


class _Stage:
    """One Gram-reduced bounded least-squares problem over a basis (module docstring)."""

    def __init__(self, basis: TargetBasis) -> None:
        self.columns = basis.displacements.reshape(len(basis.names), -1).T        # (3V, T)
        gram = self.columns.T @ self.columns
        scale = float(np.mean(np.diag(gram))) if len(gram) else 1.0
        if not scale > 0:
            raise UserError("the baked targets do not move anything; bake expressions on the rig first")
        self.lower = np.tril(cho_factor(gram + REGULARISATION * scale * np.eye(len(gram)), lower=True)[0])
        self.scale = scale
        self._sets = (np.ones(len(gram), bool), np.zeros(len(gram), bool))    # warm start: all at 0

    def solve_many(self, flat: np.ndarray | None, prior: np.ndarray | None = None, strength: float = 0.0,
                   skip: np.ndarray | None = None, projected: np.ndarray | None = None) -> np.ndarray:
        """Weights (F, T) of the rows of ``flat`` (F, 3V), held near ``prior`` (F, T) with ``strength``;
        rows where ``skip`` is set are not solved (zeros: the caller overwrites them). ``projected``: the
        product ``columns^T flat^T`` (T, F) when the caller has it (``flat`` is then not needed)."""
        count = self.columns.shape[1]
        if projected is None:
            projected = self.columns.T @ flat.T
        frames = projected.shape[1]
        if not frames:
            return np.zeros((0, count))
        rows = np.arange(frames) if skip is None else np.flatnonzero(~np.asarray(skip, bool))
        rhs = solve_triangular(self.lower, projected[:, rows], lower=True)       # (T, F)
        matrix = self.lower.T
        if prior is not None and strength > 0:
            root = np.sqrt(strength * self.scale)
            matrix = np.vstack([matrix, root * np.eye(count)])
            rhs = np.vstack([rhs, root * prior[rows].T])
        out = np.zeros((frames, count))
        with one_blas_thread():
            out[rows] = self._solve_rows(np.ascontiguousarray(matrix), np.ascontiguousarray(rhs.T))
        return out

    def _solve_rows(self, matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Bounded least squares for every row of ``rhs``: the compiled active-set loop (:func:`_box_normal`
        / :func:`_box_qr`, warm-started frame to frame) where numba is usable, :func:`bounded_nnls` for the frames it leaves
        and everywhere without numba (the reference)."""
        weights = np.zeros((len(rhs), matrix.shape[1]))
        solved = np.zeros(len(rhs), bool)
        # numba here (not merely loaded by whatever ran before in this process): the compiled and the
        # scipy solvers agree to rounding only, so the choice may not depend on the process's history; and
        # compiled standalone: a fit without physics (a retarget) does not pay for the substep kernel's load
        if kernel.numba_usable() and kernel.compiled(_sets_settled, standalone=True) is not None:
            low, high = self._sets
            hessian = np.ascontiguousarray(matrix.T @ matrix)
            targets = np.ascontiguousarray(rhs @ matrix)                  # A^T b of every frame
            tolerances = 1e-9 * np.maximum(1.0, np.abs(targets).max(axis=1))   # as _optimal's
            if matrix.shape[0] > matrix.shape[1]:                        # the prior rows stacked below
                box_normal = kernel.compiled(_box_normal, _sets_settled, standalone=True)
                box_normal(hessian, targets, tolerances, low, high, BOX_ROUNDS, weights, solved)
            else:
                box_qr = kernel.compiled(_box_qr, _sets_settled, standalone=True)
                box_qr(matrix, rhs, hessian, targets, tolerances, low, high, BOX_ROUNDS, weights, solved)
        for f in np.flatnonzero(~solved):
            weights[f] = bounded_nnls(matrix, rhs[f])
        return weights


class WeightSolver:
    """Weights of the ``basis`` targets for a frame, then (optional) ``correctives`` fitted to what the
    targets left over: engines that know only the standard targets (ARKit, visemes) get the best animation
    those can carry; the rig's own corrective targets (its muscle basis) add the rest for the rig itself.
    :meth:`solve_many` gives the weights (primary then corrective names) and the residual of each frame."""

    def __init__(self, basis: TargetBasis, correctives: TargetBasis | None = None,
                 prior_strength: float = PRIOR_STRENGTH) -> None:
        if correctives is not None and correctives.vertex_count != basis.vertex_count:
            raise UserError("the corrective targets do not match the targets' vertices; bake them again")
        with one_blas_thread():         # a threaded BLAS sums the Gram products in another order
            self.stages = [_Stage(basis)] + ([_Stage(correctives)] if correctives is not None else [])
        self.names = basis.names + (correctives.names if correctives is not None else ())
        self.primary = len(basis.names)
        self.prior_strength = prior_strength
        self.vertex_count = basis.vertex_count
        self.columns = np.hstack([stage.columns for stage in self.stages])
        # what the correctives see of the primary weights (C2^T C1): their right-hand sides without the
        # full-size residual of the first stage
        with one_blas_thread():
            self._cross = self.stages[1].columns.T @ self.stages[0].columns if correctives is not None else None

    def solve_many(self, displacements: np.ndarray, prior: np.ndarray | None = None,
                   exact: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Weights (F, T) and residuals (F,) of a block of frames (F, V, 3), the primary targets held near
        ``prior`` (F, primary) when given: the large products as one matrix product each, the small bounded
        problems frame by frame. Rows where ``exact`` (F,) is set take the prior as it is and no corrective
        weight (a lip closure must read as its viseme, whatever the simulated pose)."""
        displacements = np.asarray(displacements, np.float64)
        if displacements.ndim != 3 or displacements.shape[1:] != (self.vertex_count, 3) \
                or not np.all(np.isfinite(displacements)):
            raise UserError("the poses do not match the baked targets; bake them again")
        if prior is not None and np.shape(prior) != (len(displacements), self.primary):
            raise UserError("the prior weights do not match the frames and targets")
        with one_blas_thread():         # the same bytes on any machine, whatever its core count
            return self._solve_block(displacements.reshape(len(displacements), -1), prior, exact)

    def _solve_block(self, flat: np.ndarray, prior: np.ndarray | None,
                     exact: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        projected = self.columns.T @ flat.T                          # (T, F): every stage's, in one product
        rows = np.asarray(exact, bool) if exact is not None and prior is not None else None
        first = self.stages[0].columns.shape[1]
        weights = self.stages[0].solve_many(None, prior, self.prior_strength, rows, projected[:first])
        if rows is not None:
            weights[rows] = np.clip(prior[rows], 0.0, 1.0)
        found = [weights]
        if len(self.stages) > 1:                # the correctives fit what the targets left over
            left = projected[first:] - self._cross @ weights.T
            correctives = self.stages[1].solve_many(None, skip=rows, projected=left)
            if rows is not None:
                correctives[rows] = 0.0
            found.append(correctives)
        weights = np.hstack(found)
        error = (flat - weights @ self.columns.T).reshape(len(flat), -1, 3)
        residual = np.sqrt(np.einsum("fij,fij->fi", error, error).max(axis=1)) if error.size else np.zeros(len(flat))
        return weights, residual

    def solve(self, displacement: np.ndarray) -> tuple[np.ndarray, float]:
        """Weights (T,) of one frame's displacement (V, 3) and the largest vertex error (m)."""
        weights, residual = self.solve_many(np.asarray(displacement, np.float64)[None])
        return weights[0], float(residual[0])


def stack_pose(skin: np.ndarray, part_rest: dict[str, np.ndarray], transforms: dict[str, np.ndarray]) -> np.ndarray:
    """One frame's exported vertices in a fixed order: the skin (V_s, 3), then each part of ``part_rest`` (in
    its order) moved by its 4x4 transform (identity when the pose does not name it)."""
    pieces = [np.asarray(skin, np.float64)]
    for role, rest in part_rest.items():
        matrix = np.asarray(transforms.get(role, np.eye(4)), np.float64)
        pieces.append(np.asarray(rest, np.float64) @ matrix[:3, :3].T + matrix[:3, 3])
    return np.concatenate(pieces) if pieces else np.zeros((0, 3))


def fit_weights(basis: TargetBasis, displacements, progress=None) -> WeightFit:
    """Weights of every frame (``displacements``: an iterable of (V, 3) arrays, pose minus rest, in the
    basis' vertex order). ``progress(fraction)`` is called now and then when the frame count is known."""
    solver = WeightSolver(basis)
    frames = displacements if isinstance(displacements, (list, tuple)) else list(displacements)
    weights = np.zeros((len(frames), len(basis.names)))
    residual = np.zeros(len(frames))
    for index, frame in enumerate(frames):
        weights[index], residual[index] = solver.solve(frame)
        if progress is not None and index % 16 == 0:
            progress(index / max(len(frames), 1))
    return WeightFit(basis.names, weights, residual)
