# SPDX-License-Identifier: GPL-3.0-or-later
"""Radial-basis-function warps with an affine part (thesis 3.1.2 "Building the Reference Head" and
"Creating New Animatable Head Models from the Template"; 6.2.3 uses the same tool for photographs).

``f(x) = sum_i w_i phi(|x - c_i|) + A x + b`` interpolates landmark correspondences ``c_i -> d_i``.
In 3D the biharmonic kernel ``phi(r) = r`` is the thin-plate spline's counterpart (it minimises the
bending energy); ``phi(r) = r^3`` (triharmonic) gives a smoother warp. The side conditions
``sum w_i = 0, sum w_i c_i = 0`` make the affine part carry all linear motion, so a purely affine
landmark change is reproduced exactly everywhere.
"""
from __future__ import annotations

import numpy as np
from scipy import linalg

from ..core.errors import UserError

__all__ = ["RBFWarp"]

_KERNELS = {
    "linear": lambda r: r,           # biharmonic: 3D thin-plate spline
    "cubic": lambda r: r * r * r,    # triharmonic
}


class RBFWarp:
    """Landmark warp ``source -> target`` ((K, 3) each). ``smoothing >= 0`` trades exactness for smoothness
    (added to the kernel diagonal, in the kernel's units). Call the object on (M, 3) points."""

    def __init__(self, source: np.ndarray, target: np.ndarray, kernel: str = "linear",
                 smoothing: float = 0.0) -> None:
        source = np.asarray(source, np.float64)
        target = np.asarray(target, np.float64)
        if source.ndim != 2 or source.shape[1] != 3 or source.shape != target.shape:
            raise UserError("RBF warp needs two (K, 3) landmark arrays of the same size")
        if source.shape[0] < 4:
            raise UserError("RBF warp needs at least 4 landmarks (not all in one plane)")
        if kernel not in _KERNELS:
            raise UserError(f"unknown RBF kernel {kernel!r}; use one of {sorted(_KERNELS)}")
        if not np.all(np.isfinite(source)) or not np.all(np.isfinite(target)):
            raise UserError("RBF landmarks contain NaN or infinity")
        self.kernel = kernel
        self.centres = source
        count = source.shape[0]
        # normalise coordinates so the linear system is well conditioned at any scale
        self._offset = source.mean(axis=0)
        self._scale = float(np.sqrt(((source - self._offset) ** 2).sum(axis=1).mean())) or 1.0
        c = (source - self._offset) / self._scale
        t = (target - self._offset) / self._scale
        phi = _KERNELS[kernel](self._distances(c, c))
        poly = np.hstack([np.ones((count, 1)), c])
        system = np.zeros((count + 4, count + 4))
        system[:count, :count] = phi + smoothing / self._scale * np.eye(count)
        system[:count, count:] = poly
        system[count:, :count] = poly.T
        rhs = np.zeros((count + 4, 3))
        rhs[:count] = t
        try:
            solution = linalg.solve(system, rhs, assume_a="sym")
        except linalg.LinAlgError:
            solution = linalg.lstsq(system, rhs)[0]
        if not np.all(np.isfinite(solution)):
            raise UserError("RBF warp is degenerate: landmarks coincide or lie in one plane; move some of them")
        self._weights = solution[:count]
        self._affine = solution[count:]
        self._normalised_centres = c

    @staticmethod
    def _distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d2 = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
        return np.sqrt(np.maximum(d2, 0.0))

    def __call__(self, points: np.ndarray, chunk: int = 20000) -> np.ndarray:
        points = np.asarray(points, np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise UserError("RBF warp applies to (M, 3) point arrays")
        out = np.empty_like(points)
        kernel = _KERNELS[self.kernel]
        for begin in range(0, points.shape[0], chunk):
            p = (points[begin:begin + chunk] - self._offset) / self._scale
            value = kernel(self._distances(p, self._normalised_centres)) @ self._weights
            value += self._affine[0] + p @ self._affine[1:]
            out[begin:begin + chunk] = value * self._scale + self._offset
        return out

    def jacobian(self, points: np.ndarray, eps: float = 1e-4) -> np.ndarray:
        """Finite-difference Jacobians (M, 3, 3) of the warp (for carrying normals and offsets along)."""
        points = np.asarray(points, np.float64)
        step = eps * self._scale
        jac = np.empty((points.shape[0], 3, 3))
        for axis in range(3):
            d = np.zeros(3)
            d[axis] = step
            jac[:, :, axis] = (self(points + d) - self(points - d)) / (2 * step)
        return jac
