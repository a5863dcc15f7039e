# SPDX-License-Identifier: GPL-3.0-or-later
"""Faces back into their photographs (thesis 3.2.5): the fitted (edited, animated) head rendered with the
photo's estimated camera and illumination and composited over the original: the face region replaced, hair
and background kept, the edges feathered.

The renderer is the photo work's own (:mod:`.raster`), so the fit's image formation and the picture agree:
per pixel the head's UVs and normals interpolated, the texture (linear albedo) times the spherical-harmonic
shading, converted to sRGB. Rigid parts (eyes, teeth, tongue) are drawn with their own per-vertex colours.
Where the head's outline holds a gap that belongs to the face (an opened mouth) and no part covers it, the
mouth's cavity colour is drawn. The composite's alpha falls from 1 to 0 over ``feather`` pixels inside the
rendered outline (a distance transform), so the seam between render and photo is never a hard edge.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..core import geometry
from .appearance import Lighting, linear_to_srgb
from .camera import Camera
from .raster import rasterize

__all__ = ["Part", "Rendering", "render_head", "composite", "CAVITY"]

CAVITY = np.array([0.035, 0.012, 0.010])       # linear: the dark red of an open mouth's inside


@dataclass
class Part:
    """A mesh drawn with the head: ``vertices`` (n, 3) model coordinates, ``triangles``, per-vertex linear
    ``colours`` (n, 3), and ``rest`` (n, 3) its vertices where the photo saw them (for a projector)."""
    vertices: np.ndarray
    triangles: np.ndarray
    colours: np.ndarray
    rest: np.ndarray | None = None


@dataclass
class Rendering:
    """``colour`` (H, W, 3) sRGB and ``alpha`` (H, W) coverage of a render over the whole picture; ``window``
    (x0, y0, x1, y1) where anything was drawn."""
    colour: np.ndarray
    alpha: np.ndarray
    window: tuple[int, int, int, int]


def _texture_sample(texture_linear: np.ndarray, uv: np.ndarray) -> np.ndarray:
    size_y, size_x = texture_linear.shape[:2]
    coords = [(1.0 - uv[:, 1]) * size_y - 0.5, uv[:, 0] * size_x - 0.5]
    return np.stack([ndimage.map_coordinates(texture_linear[..., c], coords, order=1, mode="nearest")
                     for c in range(3)], axis=1)


def render_head(vertices: np.ndarray, triangles: np.ndarray, uvs: np.ndarray, texture_linear: np.ndarray,
                camera: Camera, lighting: Lighting, parts: list[Part] = (), mouth_fill: bool = True,
                margin: int = 4, projector=None, gap_colour=None) -> Rendering:
    """The head (and ``parts``) seen by ``camera`` under ``lighting`` (module docstring). ``projector(points,
    normals) -> (albedo, seen)`` colours the part pixels whose rest point (``Part.rest``) the photo saw;
    ``gap_colour(pixels) -> colours or None`` fills the gaps of an open mouth (default: the cavity's)."""
    meshes = [(np.asarray(vertices, np.float64), np.asarray(triangles, np.int64))]
    meshes += [(np.asarray(p.vertices, np.float64), np.asarray(p.triangles, np.int64)) for p in parts]
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
    all_vertices = np.vstack([v for v, _ in meshes])
    all_triangles = np.vstack([t + o for (_, t), o in zip(meshes, offsets)])
    pixels, depth = camera.project(all_vertices)
    head_pixels = pixels[:offsets[1]]
    lo = np.maximum(np.floor(head_pixels.min(axis=0)).astype(int) - margin, 0)
    hi = np.minimum(np.ceil(head_pixels.max(axis=0)).astype(int) + margin, [camera.width, camera.height])
    window = (int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1]))
    raster = rasterize(pixels, all_triangles, camera.width, camera.height, depth, window)
    mask = raster.mask
    tri = raster.triangle[mask]
    bary = raster.bary[mask].astype(np.float64)
    corners = all_triangles[tri]
    normals = np.vstack([geometry.vertex_normals(v, t) for v, t in meshes]) @ camera.rotation.T
    n = np.einsum("kj,kjc->kc", bary, normals[corners])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    rays = np.einsum("kj,kjc->kc", bary, camera.to_camera(all_vertices)[corners])
    n *= np.where((n * rays).sum(axis=1) > 0, -1.0, 1.0)[:, None]          # two-sided: shade the side seen
    shading = np.maximum(lighting.shading(n), 0.0)
    on_head = tri < len(triangles)
    albedo = np.zeros((len(tri), 3))
    uv = np.einsum("kj,kjc->kc", bary[on_head], np.asarray(uvs, np.float64)[corners[on_head]])
    albedo[on_head] = _texture_sample(texture_linear, uv)
    if parts:
        colours = np.vstack([np.zeros((offsets[1], 3))] + [np.asarray(p.colours, np.float64) for p in parts])
        albedo[~on_head] = np.einsum("kj,kjc->kc", bary[~on_head], colours[corners[~on_head]])
        if projector is not None and all(p.rest is not None for p in parts):
            _project_parts(albedo, ~on_head, bary, corners, meshes, parts, offsets, projector)
    h, w = mask.shape
    colour = np.zeros((h, w, 3))
    colour[mask] = albedo * shading
    alpha = mask.astype(np.float64)
    if mouth_fill:
        head_only = np.zeros_like(mask)
        head_only[mask] = on_head
        gaps = ndimage.binary_fill_holes(head_only) & ~mask
        colour[gaps] = CAVITY * max(float(lighting.shading(np.array([[0.0, 0.0, -1.0]])).mean()), 0.0)
        if gap_colour is not None and gaps.any():
            gy, gx = np.nonzero(gaps)
            filled = gap_colour(np.column_stack([gx + window[0] + 0.5, gy + window[1] + 0.5]))
            if filled is not None:
                colour[gaps] = filled
        alpha[gaps] = 1.0
    full = np.zeros((camera.height, camera.width, 3), np.float32)
    full_alpha = np.zeros((camera.height, camera.width), np.float32)
    full[window[1]:window[3], window[0]:window[2]] = linear_to_srgb(colour)
    full_alpha[window[1]:window[3], window[0]:window[2]] = alpha
    return Rendering(full, full_alpha, window)


def _project_parts(albedo, on_parts, bary, corners, meshes, parts, offsets, projector) -> None:
    """Part pixels whose rest point the photo saw take the photo's albedo there (``projector``)."""
    rest = np.vstack([np.zeros((offsets[1], 3))] + [np.asarray(p.rest, np.float64) for p in parts])
    rest_normals = np.vstack([np.zeros((offsets[1], 3))]
                             + [geometry.vertex_normals(np.asarray(p.rest, np.float64), np.asarray(p.triangles))
                                for p in parts])
    points = np.einsum("kj,kjc->kc", bary[on_parts], rest[corners[on_parts]])
    normals = np.einsum("kj,kjc->kc", bary[on_parts], rest_normals[corners[on_parts]])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    photo, seen = projector(points, normals)
    rows = np.flatnonzero(on_parts)[seen]
    albedo[rows] = photo[seen]


def composite(photo_srgb: np.ndarray, rendering: Rendering, feather: float) -> np.ndarray:
    """``rendering`` over ``photo_srgb`` (H, W, 3) with its alpha feathered over ``feather`` pixels inside
    the outline (module docstring)."""
    x0, y0, x1, y1 = rendering.window
    out = np.array(photo_srgb, np.float32, copy=True)
    if x1 <= x0 or y1 <= y0:
        return out
    pad = int(np.ceil(feather)) + 2
    a0, b0 = max(x0 - pad, 0), max(y0 - pad, 0)
    a1, b1 = min(x1 + pad, out.shape[1]), min(y1 + pad, out.shape[0])
    alpha = rendering.alpha[b0:b1, a0:a1] > 0.5
    inside = ndimage.distance_transform_edt(alpha)
    weight = np.clip((inside - 0.5) / max(feather, 1e-6), 0.0, 1.0)
    weight = (weight * weight * (3.0 - 2.0 * weight))[..., None]
    out[b0:b1, a0:a1] = weight * rendering.colour[b0:b1, a0:a1] + (1.0 - weight) * out[b0:b1, a0:a1]
    return out
