# SPDX-License-Identifier: GPL-3.0-or-later
"""Analysis by synthesis of a photo's colours (thesis 3.2.4): the model's colour coefficients ``beta`` and
the illumination, refined until a rendering of the textured model matches the face in the photograph.

Illumination is second-order spherical harmonics in the camera's frame (9 coefficients per colour channel:
the irradiance of any distant light on a Lambertian surface is within a few percent of its first nine
harmonics, Ramamoorthi and Hanrahan 2001). A visible vertex ``v`` with camera-frame normal ``n_v`` shows
``I_v = a_v(beta) * (H(n_v) . l)`` per channel, ``a_v(beta) = mean_v + B_v beta`` the model's linear albedo.
The photo is linearised (sRGB) and sampled at the projections of the visible, front-facing vertices
(a small blur first, at the scale of the mesh's spacing). Alternating least squares: the light for the
current albedo; then ``beta`` for that light, with the Mahalanobis prior ``sum beta_i^2 / sigma_i^2`` of the
colour model (3.2.2) against the colour noise ``sigma_colour``; a few rounds, with Huber weights against
highlights, hair and shadows the model cannot explain.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..core import geometry
from .camera import Camera
from .head_model import HeadModel
from .raster import rasterize

__all__ = ["Lighting", "sh_basis", "srgb_to_linear", "linear_to_srgb", "fit_appearance", "visible_vertices",
           "sample_image", "AppearanceFit"]

SIGMA_COLOUR = 0.04        # linear units: the colour noise the prior is weighed against
ROUNDS = 4


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = np.asarray(c, np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(c, np.float32), 0.0, None)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055).astype(np.float32)


def sh_basis(normals: np.ndarray) -> np.ndarray:
    """(N, 9) real spherical harmonics up to order 2 of unit ``normals`` (N, 3)."""
    x, y, z = np.asarray(normals, np.float64).T
    return np.stack([0.282095 * np.ones_like(x), 0.488603 * y, 0.488603 * z, 0.488603 * x,
                     1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z,
                     0.546274 * (x * x - y * y)], axis=1)


@dataclass
class Lighting:
    """Spherical-harmonic illumination (9, 3) in the camera frame (module docstring)."""
    coefficients: np.ndarray

    def shading(self, camera_normals: np.ndarray) -> np.ndarray:
        """(N, 3) irradiance of unit normals in the camera frame."""
        return sh_basis(camera_normals) @ self.coefficients

    @classmethod
    def ambient(cls, level: float = 1.0) -> "Lighting":
        c = np.zeros((9, 3))
        c[0] = level / 0.282095
        return cls(c)


@dataclass
class AppearanceFit:
    """``beta`` the colour coefficients, ``lighting``, ``albedo`` (n, 3) linear, and the RMS colour error of
    the visible vertices (linear units)."""
    beta: np.ndarray | None
    lighting: Lighting
    albedo: np.ndarray
    rms: float
    visible: np.ndarray


def visible_vertices(vertices: np.ndarray, triangles: np.ndarray, camera: Camera,
                     min_facing: float = 0.2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(visible (n,) bool, pixels (n, 2), camera-frame unit normals (n, 3)): a vertex is visible when it is in
    the picture, nearest at its pixel (within 1.5 % of its depth) and faces the camera by at least
    ``min_facing`` (cosine)."""
    pixels, depth = camera.project(vertices)
    normals = geometry.vertex_normals(vertices, triangles) @ camera.rotation.T
    rays = camera.to_camera(vertices)
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    facing = -(normals * rays).sum(axis=1)
    lo = np.floor(pixels.min(axis=0)).astype(int) - 1
    hi = np.ceil(pixels.max(axis=0)).astype(int) + 2
    raster = rasterize(pixels, triangles, camera.width, camera.height, depth, (lo[0], lo[1], hi[0], hi[1]))
    inside = (pixels[:, 0] >= 0) & (pixels[:, 1] >= 0) & (pixels[:, 0] < camera.width) & (pixels[:, 1] < camera.height)
    visible = np.zeros(len(vertices), bool)
    ix = np.clip(np.floor(pixels[:, 0]).astype(int) - raster.origin[0], 0, raster.depth.shape[1] - 1)
    iy = np.clip(np.floor(pixels[:, 1]).astype(int) - raster.origin[1], 0, raster.depth.shape[0] - 1)
    if raster.depth.size:
        nearest = raster.depth[iy, ix]
        visible = inside & (depth <= nearest * 1.015) & (facing >= min_facing)
    return visible, pixels, normals


def sample_image(image: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Bilinear samples (N, C) of ``image`` (H, W, C) at pixel positions (x, y), edges repeated."""
    coords = [np.asarray(pixels[:, 1]) - 0.5, np.asarray(pixels[:, 0]) - 0.5]
    return np.stack([ndimage.map_coordinates(image[..., k], coords, order=1, mode="nearest")
                     for k in range(image.shape[2])], axis=1)


def _blurred(image: np.ndarray, sigma: float) -> np.ndarray:
    if sigma < 0.5:
        return image
    return np.stack([ndimage.gaussian_filter(image[..., k], sigma) for k in range(image.shape[2])], axis=2)


def _huber(residual: np.ndarray, limit: float) -> np.ndarray:
    size = np.abs(residual)
    return np.where(size <= limit, 1.0, limit / np.maximum(size, 1e-12))


def fit_appearance(model: HeadModel, vertices: np.ndarray, camera: Camera, image_linear: np.ndarray,
                   with_colour_model: bool = True) -> AppearanceFit:
    """Colour coefficients and lighting of the photo ``image_linear`` (H, W, 3) for the fitted ``vertices``
    seen by ``camera`` (module docstring)."""
    visible, pixels, normals = visible_vertices(vertices, model.triangles, camera)
    spacing = np.median(np.linalg.norm(np.diff(pixels[model.landmarks[[33, 263]]], axis=0))) / 30.0
    samples = sample_image(_blurred(image_linear, 0.5 * spacing), pixels[visible])         # (V, 3)
    basis = sh_basis(normals[visible])                                                      # (V, 9)
    beta = np.zeros(len(model.colour_sd)) if (with_colour_model and model.colour_sd is not None) else None
    albedo = model.albedo(beta)
    weights = np.ones((int(visible.sum()), 3))
    coefficients = np.zeros((9, 3))
    for _ in range(ROUNDS):
        for c in range(3):
            design = basis * albedo[visible, c:c + 1]
            w = np.sqrt(weights[:, c])[:, None]
            coefficients[:, c] = np.linalg.lstsq(design * w, samples[:, c] * w[:, 0], rcond=None)[0]
        shade = basis @ coefficients                                                       # (V, 3)
        if beta is not None:
            beta = _colour_coefficients(model, visible, shade, samples, weights)
            albedo = model.albedo(beta)
        residual = albedo[visible] * shade - samples
        weights = _huber(residual, 2.5 * SIGMA_COLOUR)
    residual = albedo[visible] * (basis @ coefficients) - samples
    return AppearanceFit(beta, Lighting(coefficients), np.clip(albedo, 0.0, 1.0),
                         float(np.sqrt((residual ** 2).mean())) if residual.size else 0.0, visible)


def _colour_coefficients(model: HeadModel, visible: np.ndarray, shade: np.ndarray, samples: np.ndarray,
                         weights: np.ndarray) -> np.ndarray:
    """``beta`` minimising sum w ((mean + B beta) * shade - I)^2 / sigma^2 + sum beta^2 / sd^2."""
    k = len(model.colour_sd)
    rows = model.colour_basis.reshape(model.vertex_count, 3, k)[visible]                    # (V, 3, k)
    design = (rows * shade[:, :, None]).reshape(-1, k)
    target = (samples - model.colour_mean[visible] * shade).ravel()
    w = weights.ravel() / SIGMA_COLOUR ** 2
    normal = design.T @ (design * w[:, None]) + np.diag(1.0 / model.colour_sd ** 2)
    return np.linalg.solve(normal, design.T @ (target * w))
