# SPDX-License-Identifier: GPL-3.0-or-later
"""The photo's colours as the fitted head's texture (thesis 3.2.4 "texture adaptation ... after removing
shading effects and shadows using the estimated rendering parameters"; 3.2.5 "where no texture can be
extracted from the image, the estimated texture from the model is used, and boundaries are smoothed. Facial
symmetry is exploited by mirroring the extracted texture from one side of the face, if the other side is
occluded").

Per texel of the head's UV layout (rows from the top, ``v`` up): its surface point and normal; the photo's
colour where that point is visible and faces the camera, divided by the fitted illumination (an albedo),
weighted by how squarely it faces the camera; the same for the mirrored surface point (the left/right vertex
map of the model) at a lower weight; where neither is seen well, the model's albedo (its fitted colour
coefficients), matched in level to the photo's albedo on the well-seen skin. The two are blended through a
smoothed coverage map, and the texture is padded past the UV layout's edges so filtering never reaches
empty texels. Stored as sRGB.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..core import geometry
from .appearance import Lighting, linear_to_srgb, sample_image, srgb_to_linear
from .camera import Camera
from .raster import rasterize

__all__ = ["Texture", "bake_texture", "scaled_texture", "texture_size", "uv_pixels"]

MIRROR_WEIGHT = 0.85          # a mirrored texel counts slightly less than one seen directly
FACING_LOW, FACING_HIGH = 0.15, 0.55
MIN_SHADING = 0.05


@dataclass
class Texture:
    """``srgb`` (T, T, 3) float32, rows from the top; ``coverage`` (T, T) how much of each texel came from the
    photo (directly or mirrored), 0..1; ``inside`` (T, T) texels of the UV layout."""
    srgb: np.ndarray
    coverage: np.ndarray
    inside: np.ndarray


def texture_size(face_width_px: float, uv_width: float, low: int = 256, high: int = 2048) -> int:
    """The power of two nearest to the texels the photo can fill: the face's width in the photo over the
    width its UVs span (``uv_width``, 0..1), within [low, high]."""
    size = 2 ** int(np.round(np.log2(max(face_width_px, 1.0) / max(uv_width, 0.05))))
    return int(np.clip(size, low, high))


def uv_pixels(uvs: np.ndarray, size: int) -> np.ndarray:
    """UVs (v up) -> texel coordinates (x right, y down) of a ``size`` texture."""
    uvs = np.asarray(uvs, np.float64)
    return np.column_stack([uvs[:, 0] * size, (1.0 - uvs[:, 1]) * size])


def _smoothstep(x: np.ndarray, low: float, high: float) -> np.ndarray:
    t = np.clip((x - low) / (high - low), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _photo_albedo(points, normals, camera: Camera, lighting: Lighting, image_linear, depth_raster):
    """Albedo (K, 3) and weight (K,) of surface points seen in the photo."""
    pixels, depth = camera.project(points)
    cam_normals = normals @ camera.rotation.T
    rays = camera.to_camera(points)
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    facing = -(cam_normals * rays).sum(axis=1)
    raster = depth_raster
    ix = np.floor(pixels[:, 0]).astype(int) - raster.origin[0]
    iy = np.floor(pixels[:, 1]).astype(int) - raster.origin[1]
    inside = (ix >= 0) & (iy >= 0) & (ix < raster.depth.shape[1]) & (iy < raster.depth.shape[0])
    nearest = np.full(len(points), -np.inf)
    nearest[inside] = raster.depth[iy[inside], ix[inside]]
    seen = inside & (depth <= nearest * 1.01 + 1e-4)
    weight = seen * _smoothstep(facing, FACING_LOW, FACING_HIGH)
    colour = sample_image(image_linear, pixels)
    shading = np.maximum(lighting.shading(cam_normals), MIN_SHADING)
    return colour / shading, weight


def bake_texture(vertices: np.ndarray, triangles: np.ndarray, uvs: np.ndarray, mirror: np.ndarray,
                 views: list[tuple[Camera, Lighting, np.ndarray]], model_albedo: np.ndarray,
                 size: int = 1024) -> Texture:
    """The head's texture (module docstring) from ``views`` (camera, illumination, linear photo), the first
    the main photo. ``vertices`` (n, 3) the fitted head, ``mirror`` (n,) its left/right vertex map,
    ``model_albedo`` (n, 3) linear."""
    triangles = np.asarray(triangles, np.int64)
    layout = rasterize(uv_pixels(uvs, size), triangles, size, size)
    inside = layout.mask
    tri = layout.triangle[inside]
    bary = layout.bary[inside].astype(np.float64)
    normals = geometry.vertex_normals(vertices, triangles)
    corners = triangles[tri]

    def at(values, map_=None):
        c = corners if map_ is None else map_[corners]
        return np.einsum("kj,kjc->kc", bary, values[c])

    points, point_normals = at(vertices), _unit(at(normals))
    mirrored_points, mirrored_normals = at(vertices, mirror), _unit(at(normals, mirror))
    own_sum, own_weight = np.zeros((len(tri), 3)), np.zeros(len(tri))
    mirror_sum, mirror_weight = np.zeros((len(tri), 3)), np.zeros(len(tri))
    for camera, lighting, image in views:
        pixels, depth = camera.project(vertices)
        lo = np.floor(pixels.min(axis=0)).astype(int) - 1
        hi = np.ceil(pixels.max(axis=0)).astype(int) + 2
        depth_raster = rasterize(pixels, triangles, camera.width, camera.height, depth, (lo[0], lo[1], hi[0], hi[1]))
        colour, weight = _photo_albedo(points, point_normals, camera, lighting, image, depth_raster)
        own_sum += colour * weight[:, None]
        own_weight += weight
        colour, weight = _photo_albedo(mirrored_points, mirrored_normals, camera, lighting, image, depth_raster)
        mirror_sum += colour * weight[:, None]
        mirror_weight += weight
    own = own_sum / np.maximum(own_weight, 1e-9)[:, None]
    mirrored = mirror_sum / np.maximum(mirror_weight, 1e-9)[:, None]
    w_own = np.clip(own_weight, 0.0, 1.0)
    w_mirror = MIRROR_WEIGHT * np.clip(mirror_weight, 0.0, 1.0) * (1.0 - w_own)
    total = w_own + w_mirror
    photo = (own * w_own[:, None] + mirrored * w_mirror[:, None]) / np.maximum(total, 1e-9)[:, None]
    model = at(np.asarray(model_albedo, np.float64))
    good = w_own > 0.8
    if good.sum() > 50:
        gain = np.median(photo[good], axis=0) / np.maximum(np.median(model[good], axis=0), 1e-3)
        model = model * gain
    coverage = np.zeros((size, size))
    coverage[inside] = np.clip(total, 0.0, 1.0)
    coverage = np.clip(ndimage.gaussian_filter(coverage, size / 128.0) * 1.15, 0.0, 1.0) * (coverage > 0)
    blend = coverage[inside][:, None]
    albedo = np.zeros((size, size, 3), np.float32)
    albedo[inside] = np.clip(blend * photo + (1.0 - blend) * model, 0.0, 1.0)
    albedo = _padded(albedo, inside)
    return Texture(linear_to_srgb(albedo), coverage.astype(np.float32), inside)


def scaled_texture(texture: Texture, uvs: np.ndarray, triangles: np.ndarray, ratio: np.ndarray) -> Texture:
    """``texture`` with its albedo multiplied per texel by the per-vertex ``ratio`` (n, 3) interpolated over
    the UV layout (a colour edit of the fitted person carried onto the photo's texture)."""
    size = texture.srgb.shape[0]
    layout = rasterize(uv_pixels(uvs, size), np.asarray(triangles, np.int64), size, size)
    inside = layout.mask
    corners = np.asarray(triangles, np.int64)[layout.triangle[inside]]
    factor = np.ones((size, size, 3))
    factor[inside] = np.einsum("kj,kjc->kc", layout.bary[inside].astype(np.float64), ratio[corners])
    factor = _padded(factor, inside)
    albedo = srgb_to_linear(texture.srgb) * factor
    return Texture(linear_to_srgb(np.clip(albedo, 0.0, 1.0)), texture.coverage, texture.inside)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)


def _padded(texture: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Texels outside the layout take the colour of the nearest texel inside."""
    if inside.all() or not inside.any():
        return texture
    _, (iy, ix) = ndimage.distance_transform_edt(~inside, return_indices=True)
    return texture[iy, ix]
