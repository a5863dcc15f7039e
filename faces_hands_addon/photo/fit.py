# SPDX-License-Identifier: GPL-3.0-or-later
"""The morphable model fitted to one or more photographs of a person (thesis 3.2.4): shape coefficients
``alpha`` shared by all views, and per view the camera (focal length, rotation, translation).

The error is the negative log of the posterior the thesis' fit maximises ("the probability of rendering
parameters and of the output face with respect to the variations in face space", 3.2.5)::

    E = sum_views sum_l rho(|P_v(s_l(alpha)) - x_l|^2 / sigma_2d^2)        landmarks (2D, Huber rho)
      + w_z sum_views sum_l ((d_l(alpha) - z_l) / sigma_z)^2                 MediaPipe's relative depths
      + sum_views sum_c ((n_c . (P_v(s_c) - e_c)) / sigma_edge)^2            silhouette (contour vertices)
      + sum_i alpha_i^2 / sigma_i^2                                          the Mahalanobis prior (3.2.2)
      + sum_views (log f_v - log f0_v)^2 / sigma_logf^2                      the focal length's prior

``P_v`` projects with view ``v``'s camera (:mod:`.camera`); ``s_l`` is landmark ``l``'s model vertex;
``sigma_2d`` and ``sigma_z`` are fractions of the view's inter-ocular distance; ``d_l`` the landmark's
depth relative to the landmarks' mean depth, in pixels at the face's distance. Silhouette terms exist where
the model's face rim turns away from the camera: each such vertex is pulled along its image normal ``n_c`` to
the strongest colour edge ``e_c`` nearby (:mod:`.silhouette`). Gauss-Newton with Levenberg damping on
(axis-angle, translation, log focal) per view and ``alpha``; the pose starts from a similarity between the
model's mean landmarks and MediaPipe's (x, y, depth) points; the focal length from EXIF when the photo
has it, else from a scan over 35 mm equivalents (the energy's best) refined continuously.

Then, beyond the model's span, an optional smooth per-vertex correction (a membrane-regularised offset,
solved linearly): the synthetic default model knows few shape variations, the landmarks know more.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from ..core import geometry
from ..core.errors import UserError
from .camera import Camera, FRONT, focal_from_35mm, rotation, skew
from .head_model import HeadModel

__all__ = ["View", "FitSettings", "ShapeFit", "fit_views", "initial_pose", "FOCAL_SCAN_35MM"]

HIDDEN_WEIGHT = 0.15
FOCAL_SCAN_35MM = (20.0, 28.0, 35.0, 50.0, 70.0, 100.0, 140.0, 200.0, 300.0)


@dataclass
class View:
    """One photograph's landmarks: ``points`` (478, 3) pixels (x, y, MediaPipe's relative depth), ``width`` x
    ``height`` the picture, ``focal_35mm`` from EXIF (0: unknown), ``weights`` (478,) how much each landmark
    is trusted (0: ignore), ``edges`` an optional :class:`.silhouette.EdgeMap` of the picture."""
    points: np.ndarray
    width: int
    height: int
    focal_35mm: float = 0.0
    weights: np.ndarray | None = None
    edges: object = None

    @property
    def inter_ocular(self) -> float:
        p = self.points
        if len(p) >= 478:
            return float(np.linalg.norm(p[468, :2] - p[473, :2]))
        return float(np.linalg.norm(p[33, :2] - p[263, :2])) * 0.68


@dataclass
class FitSettings:
    """The fit's constants (module docstring): noise levels as fractions of the inter-ocular distance, the
    depth term's weight, the focal prior, iterations, and the correction beyond the model. ``sigma_2d``:
    MediaPipe's landmarks on synthetic renders of heads with known landmarks differ from them by 2.5-7 %
    (median 4.3 %) of the inter-ocular distance, and the differences are correlated over the face, so the
    weight is that of 6 % (chosen on a tuning set of renders: pose error 5.0 -> 4.2 degrees against 2 %);
    ``sigma_z``: MediaPipe's depths differ from the true ones by 3-5 mm RMS; 3 % weighs them as the tuning
    set preferred (``bench/photo.py --tune``)."""
    sigma_2d: float = 0.06
    sigma_z: float = 0.03
    depth_weight: float = 1.0
    sigma_edge: float = 0.03
    silhouette: bool = True
    sigma_logf: float = 0.7
    focal_scan: bool = True
    focal_default_35mm: float = 50.0
    iterations: int = 30
    huber: float = 2.5
    correction: bool = True
    correction_stiffness: float = 4.0


@dataclass
class ShapeFit:
    """The fit: ``alpha`` (k,), ``correction`` (n, 3) metres beyond the model, ``cameras`` one per view,
    ``vertices`` (n, 3) the fitted head, the final ``energy`` and per-view landmark ``residuals`` (468,) px."""
    alpha: np.ndarray
    correction: np.ndarray
    cameras: list[Camera]
    vertices: np.ndarray
    energy: float
    residuals: list[np.ndarray] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def _umeyama(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Scale, rotation and translation with ``target ~ s R source + t`` (least squares, proper rotation)."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    u, d, vt = np.linalg.svd(b.T @ a)
    fix = np.eye(3)
    fix[2, 2] = np.sign(np.linalg.det(u @ vt)) or 1.0
    r = u @ fix @ vt
    s = float(np.trace(np.diag(d) @ fix) / max((a ** 2).sum(), 1e-18))
    return s, r, mu_t - s * r @ mu_s


def initial_pose(model_landmarks: np.ndarray, view: View, focal: float) -> Camera:
    """Camera of ``view`` at ``focal`` px from a similarity between the model's landmarks and MediaPipe's
    (x, y, depth) points, read as a scaled orthographic view: the scale gives the distance ``f / s``."""
    pts = np.asarray(view.points[:468], np.float64)
    w = _weights(view)[:468] > 0
    s, r, t = _umeyama(model_landmarks[w], pts[w])
    camera = Camera(view.width, view.height, focal, r, np.zeros(3))
    depth = focal / max(s, 1e-9)
    centre = model_landmarks[w].mean(axis=0)
    target = pts[w, :2].mean(axis=0)
    xy = (target - camera.centre) * depth / focal
    camera.translation = np.array([xy[0], xy[1], depth]) - r @ centre
    return camera


def _weights(view: View) -> np.ndarray:
    weights = np.ones(len(view.points)) if view.weights is None else np.asarray(view.weights, np.float64)
    return weights


class _Problem:
    """The energy of the module docstring for a set of views, with its Gauss-Newton pieces."""

    def __init__(self, model: HeadModel, views: list[View], settings: FitSettings):
        self.model, self.views, self.settings = model, views, settings
        self.mean_l, self.basis_l = model.landmark_basis()
        self.k = model.components
        self.focal0 = [np.log(focal_from_35mm(v.focal_35mm or settings.focal_default_35mm, v.width, v.height))
                       for v in views]
        self.fixed_focal = [v.focal_35mm > 0 for v in views]
        self.silhouette_targets: list = [None] * len(views)
        self.visibility: list[np.ndarray] = [np.ones(468) for _ in views]

    def update_visibility(self, alpha: np.ndarray, cameras: list[Camera]) -> None:
        """Landmarks on surface turned away from a view's camera are MediaPipe's guesses: their weight falls to
        :data:`HIDDEN_WEIGHT` as the surface turns away (facing cosine from 0.15 down to -0.15)."""
        shape = self.model.shape(alpha)
        normals = geometry.vertex_normals(shape, self.model.triangles)[self.model.landmarks]
        points = shape[self.model.landmarks]
        for index, camera in enumerate(cameras):
            rays = camera.to_camera(points)
            rays /= np.linalg.norm(rays, axis=1, keepdims=True)
            facing = -((normals @ camera.rotation.T) * rays).sum(axis=1)
            self.visibility[index] = np.clip((facing + 0.15) / 0.3, HIDDEN_WEIGHT, 1.0)

    def residuals(self, alpha: np.ndarray, cameras: list[Camera], robust: list[np.ndarray] | None = None,
                  jacobian: bool = True):
        """(r, J) stacked over the views and the priors; unknowns: per view (w, t, log f), then alpha."""
        s, k, n_views = self.settings, self.k, len(self.views)
        points = self.mean_l + self.basis_l @ alpha                       # (468, 3)
        rows, jacs = [], []
        width = 7 * n_views + k
        for index, (view, camera) in enumerate(zip(self.views, cameras)):
            iod = max(view.inter_ocular, 1.0)
            weights = _weights(view)[:468] * self.visibility[index]
            if robust is not None:
                weights = weights * robust[index]
            cam = camera.to_camera(points)
            z = cam[:, 2]
            uv = camera.focal * cam[:, :2] / z[:, None] + camera.centre
            sigma = s.sigma_2d * iod
            scale = np.sqrt(weights)[:, None] / sigma
            rows.append(((uv - view.points[:468, :2]) * scale).ravel())
            # depth term: depths relative to their weighted mean, in pixels at the face's distance
            zbar = np.average(z, weights=weights)
            d_pred = (z - zbar) * camera.focal / zbar
            d_obs = view.points[:468, 2] - np.average(view.points[:468, 2], weights=weights)
            zscale = np.sqrt(s.depth_weight * weights) / (s.sigma_z * iod)
            rows.append((d_pred - d_obs) * zscale)
            edge = self._edge_rows(index, camera, alpha)
            if edge is not None:
                rows.append(edge[0])
            if not jacobian:
                continue
            jac = np.zeros((2 * 468 + 468, width))
            d_uv = np.zeros((468, 2, 3))                                   # d(u, v) / d(camera point)
            d_uv[:, 0, 0] = camera.focal / z
            d_uv[:, 1, 1] = camera.focal / z
            d_uv[:, :, 2] = -camera.focal * cam[:, :2] / z[:, None] ** 2
            rotated = points @ camera.rotation.T
            d_w = -skew(rotated)                                           # d(camera point) / d(w)
            d_alpha = np.einsum("ij,ljk->lik", camera.rotation, self.basis_l)
            block = slice(7 * index, 7 * index + 7)
            j_uv = np.concatenate([d_uv @ d_w, d_uv, (uv - camera.centre)[:, :, None]], axis=2)   # (468, 2, 7)
            jac[:936, block] = (j_uv * scale[:, :, None]).reshape(936, 7)
            jac[:936, 7 * n_views:] = ((d_uv @ d_alpha) * scale[:, :, None]).reshape(936, k)
            # depth rows: d(d_pred) ~ f / zbar * d(z - zbar) (the factor's own change is second order)
            centre_w = weights / weights.sum()
            d_z = np.concatenate([d_w[:, 2, :], np.tile([0.0, 0.0, 0.0], (468, 1)), np.zeros((468, 1))], axis=1)
            d_z = d_z - centre_w @ d_z
            jac[936:, block] = d_z * (camera.focal / zbar * zscale)[:, None]
            dz_alpha = d_alpha[:, 2, :] - centre_w @ d_alpha[:, 2, :]
            jac[936:, 7 * n_views:] = dz_alpha * (camera.focal / zbar * zscale)[:, None]
            jacs.append(jac)
            if edge is not None:
                jacs.append(edge[1])
        rows.append(alpha / self.model.sd)
        focal_rows = [((np.log(c.focal) - f0) / s.sigma_logf) if not fixed else 0.0
                      for c, f0, fixed in zip(cameras, self.focal0, self.fixed_focal)]
        rows.append(np.array(focal_rows))
        r = np.concatenate(rows)
        if not jacobian:
            return r, None
        prior = np.zeros((k, width))
        prior[:, 7 * n_views:] = np.diag(1.0 / self.model.sd)
        jf = np.zeros((n_views, width))
        for index, fixed in enumerate(self.fixed_focal):
            jf[index, 7 * index + 6] = 0.0 if fixed else 1.0 / s.sigma_logf
        return r, np.vstack(jacs + [prior, jf])

    def _edge_rows(self, index: int, camera: Camera, alpha: np.ndarray):
        targets = self.silhouette_targets[index]
        if targets is None:
            return None
        from .silhouette import edge_residuals
        return edge_residuals(self, index, camera, alpha, targets)

    def landmark_errors(self, alpha, cameras) -> list[np.ndarray]:
        points = self.mean_l + self.basis_l @ alpha
        return [np.linalg.norm(c.project(points)[0] - v.points[:468, :2], axis=1) for v, c in zip(self.views, cameras)]


def _update(problem: _Problem, alpha, cameras, step) -> tuple[np.ndarray, list[Camera]]:
    n_views = len(cameras)
    out = []
    for index, camera in enumerate(cameras):
        d = step[7 * index:7 * index + 7]
        focal = camera.focal if problem.fixed_focal[index] else camera.focal * float(np.exp(d[6]))
        out.append(Camera(camera.width, camera.height, focal, rotation(d[:3]) @ camera.rotation,
                          camera.translation + d[3:6]))
    return alpha + step[7 * n_views:], out


def _robust(problem: _Problem, alpha, cameras) -> list[np.ndarray]:
    """Huber weights of the landmarks (IRLS): 1 inside ``huber`` sigmas, ``huber sigma / error`` beyond."""
    out = []
    for view, errors in zip(problem.views, problem.landmark_errors(alpha, cameras)):
        limit = problem.settings.huber * problem.settings.sigma_2d * max(view.inter_ocular, 1.0)
        out.append(np.where(errors <= limit, 1.0, limit / np.maximum(errors, 1e-12)))
    return out


def _gauss_newton(problem: _Problem, alpha, cameras, iterations: int, silhouette_from: int | None = None):
    damping = 1e-3
    robust = _robust(problem, alpha, cameras)
    r, jac = problem.residuals(alpha, cameras, robust)
    energy = float(r @ r)
    for iteration in range(iterations):
        if silhouette_from is not None and iteration >= silhouette_from:
            from .silhouette import contour_targets
            problem.silhouette_targets = [contour_targets(problem, i, c, alpha) for i, c in enumerate(cameras)]
            r, jac = problem.residuals(alpha, cameras, robust)
            energy = float(r @ r)
        normal = jac.T @ jac
        gradient = jac.T @ r
        improved = False
        for _ in range(8):
            step = -np.linalg.solve(normal + damping * np.diag(np.diag(normal) + 1e-9), gradient)
            new_alpha, new_cameras = _update(problem, alpha, cameras, step)
            if min(c.translation[2] for c in new_cameras) <= 0:
                damping *= 10.0
                continue
            new_r, _ = problem.residuals(new_alpha, new_cameras, robust, jacobian=False)
            new_energy = float(new_r @ new_r)
            if new_energy < energy:
                alpha, cameras, damping, improved = new_alpha, new_cameras, max(damping / 3.0, 1e-7), True
                break
            damping *= 10.0
        if not improved:
            break
        robust = _robust(problem, alpha, cameras)
        r, jac = problem.residuals(alpha, cameras, robust)
        previous, energy = energy, float(r @ r)
        if abs(previous - energy) < 1e-7 * max(energy, 1.0) and silhouette_from is None:
            break
    return alpha, cameras, energy


def _start(problem: _Problem, focal_35mm: list[float]) -> tuple[np.ndarray, list[Camera]]:
    alpha = np.zeros(problem.k)
    cameras = [initial_pose(problem.mean_l, view, focal_from_35mm(f, view.width, view.height))
               for view, f in zip(problem.views, focal_35mm)]
    return alpha, cameras


def fit_views(model: HeadModel, views: list[View], settings: FitSettings | None = None) -> ShapeFit:
    """Fit ``model`` to ``views`` (module docstring). The first view is the main photo (its camera renders the
    head back into it); further views (a profile, other frames of the person) share the shape."""
    settings = settings or FitSettings()
    if not views:
        raise UserError("no photo to fit")
    problem = _Problem(model, views, settings)
    notes = []
    # the focal length: EXIF where known, else the scan's best 35 mm equivalent (each fitted briefly)
    best = None
    unknown = [v.focal_35mm <= 0 for v in views]
    scan = FOCAL_SCAN_35MM if any(unknown) and settings.focal_scan else (settings.focal_default_35mm,)
    for candidate in scan:
        focal = [v.focal_35mm if v.focal_35mm > 0 else candidate for v in views]
        problem.focal0 = [np.log(focal_from_35mm(f, v.width, v.height)) for f, v in zip(focal, views)]
        problem.fixed_focal = [True] * len(views)
        alpha, cameras = _start(problem, focal)
        alpha, cameras, energy = _gauss_newton(problem, alpha, cameras, 8)
        energy += sum(((np.log(f) - np.log(settings.focal_default_35mm)) / settings.sigma_logf) ** 2
                      for f, u in zip(focal, unknown) if u)
        if best is None or energy < best[0]:
            best = (energy, alpha, cameras, focal)
    _, alpha, cameras, focal = best
    problem.focal0 = [np.log(focal_from_35mm(v.focal_35mm or settings.focal_default_35mm, v.width, v.height))
                      for v in views]
    problem.fixed_focal = [v.focal_35mm > 0 for v in views]
    if any(unknown):
        notes.append("focal length estimated: " + ", ".join(f"{f:.0f} mm (35 mm equivalent)" for f in focal))
    problem.update_visibility(alpha, cameras)
    alpha, cameras, energy = _gauss_newton(problem, alpha, cameras, settings.iterations)
    if settings.silhouette and any(v.edges is not None for v in views):
        alpha, cameras, energy = _gauss_newton(problem, alpha, cameras, 6, silhouette_from=0)
    vertices = model.shape(alpha)
    correction = np.zeros_like(vertices)
    if settings.correction:
        correction = _correction(problem, alpha, cameras)
        vertices = vertices + correction
    residuals = [np.linalg.norm(c.project(vertices[model.landmarks])[0] - v.points[:468, :2], axis=1)
                 for v, c in zip(views, cameras)]
    return ShapeFit(alpha, correction, cameras, vertices, energy, residuals, notes)


def _membrane(model: HeadModel) -> sparse.csr_matrix:
    """The graph Laplacian (uniform weights) of the model's mesh, (n, n)."""
    n = model.vertex_count
    edges = geometry.unique_edges(model.triangles)
    a = sparse.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    a = (a + a.T).tocsr()
    return sparse.diags(np.asarray(a.sum(axis=1)).ravel()) - a


def _correction(problem: _Problem, alpha, cameras) -> np.ndarray:
    """The smooth offset (n, 3) beyond the model (module docstring): the landmarks' linearised 2D residuals
    over all views, plus ``stiffness * |L d|^2`` (in units of the landmark noise, per unit of the face's
    size) and a small pull to zero; solved as one sparse linear system."""
    model, s = problem.model, problem.settings
    n = model.vertex_count
    shape = model.shape(alpha)
    rows, cols, vals, rhs = [], [], [], []
    row = 0
    size = float(np.linalg.norm(shape[model.landmarks[454]] - shape[model.landmarks[234]]))
    for view, camera, robust, visibility in zip(problem.views, cameras, _robust(problem, alpha, cameras),
                                                problem.visibility):
        points = shape[model.landmarks]
        cam = camera.to_camera(points)
        z = cam[:, 2]
        uv = camera.focal * cam[:, :2] / z[:, None] + camera.centre
        d_uv = np.zeros((468, 2, 3))
        d_uv[:, 0, 0] = d_uv[:, 1, 1] = camera.focal / z
        d_uv[:, :, 2] = -camera.focal * cam[:, :2] / z[:, None] ** 2
        d_model = d_uv @ camera.rotation                                    # (468, 2, 3)
        weight = np.sqrt(_weights(view)[:468] * robust * visibility) / (s.sigma_2d * max(view.inter_ocular, 1.0))
        residual = view.points[:468, :2] - uv
        for axis in range(2):
            for c in range(3):
                rows.append(row + np.arange(468))
                cols.append(3 * model.landmarks + c)
                vals.append(d_model[:, axis, c] * weight)
            rhs.append(residual[:, axis] * weight)
            row += 468
    data = sparse.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(row, 3 * n)).tocsr()
    laplacian = sparse.kron(_membrane(model), sparse.eye(3)).tocsr()
    stiffness = s.correction_stiffness * len(problem.views) * 468 / max(size, 1e-6)
    system = data.T @ data + stiffness * (laplacian.T @ laplacian) * size + 1e-3 * sparse.eye(3 * n)
    offset = spsolve(system.tocsc(), data.T @ np.concatenate(rhs))
    return np.asarray(offset).reshape(n, 3)
