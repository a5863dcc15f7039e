# SPDX-License-Identifier: GPL-3.0-or-later
"""A small triangle rasteriser in numpy, the renderer of the photo work's analysis by synthesis (thesis
3.2.4: the fit compares "the face in the original image and a rendering of the textured 3D face model") and
of rendering a face back into its photograph (3.2.5); the same code finds which surface point each texel of
a UV layout is (rasterising in UV space).

Pixel centres sit at +0.5 (x right, y down). A pixel is covered by a triangle when its centre is inside
(edge functions >= 0 with a top-left-free tie rule: a centre on a shared edge goes to the nearer triangle);
the nearest cover wins (depth of the perspective-correct interpolation of camera depth). Work is vectorised
over every (triangle, pixel of its bounding box) pair, in chunks of bounded size.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Raster", "rasterize", "interpolate"]

CHUNK = 2_000_000          # (triangle, pixel) pairs per vectorised pass


@dataclass
class Raster:
    """``triangle`` (H, W) int32, -1 where nothing is drawn; ``bary`` (H, W, 3) float32 barycentric weights
    (perspective-correct when depths were given); ``depth`` (H, W) float32 (inf where empty); ``origin``
    (x0, y0) of the window the arrays cover in the full picture."""
    triangle: np.ndarray
    bary: np.ndarray
    depth: np.ndarray
    origin: tuple[int, int] = (0, 0)

    @property
    def mask(self) -> np.ndarray:
        return self.triangle >= 0


def rasterize(xy: np.ndarray, triangles: np.ndarray, width: int, height: int, depth: np.ndarray | None = None,
              window: tuple[int, int, int, int] | None = None) -> Raster:
    """Rasterise triangles with screen positions ``xy`` (N, 2) pixels into a ``width`` x ``height`` picture,
    or only into ``window`` (x0, y0, x1, y1) of it; ``depth`` (N,) camera depths (nearest wins, barycentrics
    perspective-correct); without it the triangles must not overlap (a UV layout)."""
    xy = np.asarray(xy, np.float64)
    triangles = np.asarray(triangles, np.int64)
    x0, y0, x1, y1 = window if window is not None else (0, 0, width, height)
    x0, y0, x1, y1 = max(int(x0), 0), max(int(y0), 0), min(int(x1), width), min(int(y1), height)
    w, h = max(x1 - x0, 0), max(y1 - y0, 0)
    tri_out = np.full(h * w, -1, np.int32)
    bary_out = np.zeros((h * w, 3), np.float32)
    depth_out = np.full(h * w, np.inf, np.float64)
    if w == 0 or h == 0 or not len(triangles):
        return Raster(tri_out.reshape(h, w), bary_out.reshape(h, w, 3), depth_out.reshape(h, w).astype(np.float32),
                      (x0, y0))
    p = xy[triangles]                                                      # (M, 3, 2)
    z = np.ones(triangles.shape) if depth is None else np.asarray(depth, np.float64)[triangles]
    area = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1])
    lo = np.floor(p.min(axis=1) - 0.5).astype(np.int64) + 1
    hi = np.floor(p.max(axis=1) - 0.5).astype(np.int64)
    lo = np.maximum(lo, [x0, y0])
    hi = np.minimum(hi, [x1 - 1, y1 - 1])
    keep = (np.abs(area) > 1e-12) & (hi >= lo).all(axis=1) & (z > 0).all(axis=1)
    index = np.flatnonzero(keep)
    counts = (hi[index, 0] - lo[index, 0] + 1) * (hi[index, 1] - lo[index, 1] + 1)
    starts = np.concatenate([[0], np.cumsum(counts)])
    begin = 0
    while begin < len(index):
        end = int(np.searchsorted(starts, starts[begin] + CHUNK, side="right")) - 1
        end = max(end, begin + 1)
        _pass(index[begin:end], counts[begin:end], lo, hi, p, z, area, (x0, y0, w), depth is not None,
              tri_out, bary_out, depth_out)
        begin = end
    return Raster(tri_out.reshape(h, w), bary_out.reshape(h, w, 3), depth_out.reshape(h, w).astype(np.float32),
                  (x0, y0))


def _pass(index, counts, lo, hi, p, z, area, frame, perspective, tri_out, bary_out, depth_out) -> None:
    x0, y0, w = frame
    tri = np.repeat(index, counts)
    local = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    span = np.repeat(hi[index, 0] - lo[index, 0] + 1, counts)
    px = np.repeat(lo[index, 0], counts) + local % span
    py = np.repeat(lo[index, 1], counts) + local // span
    cx, cy = px + 0.5, py + 0.5
    a, b, c = p[tri, 0], p[tri, 1], p[tri, 2]
    w0 = (b[:, 0] - cx) * (c[:, 1] - cy) - (c[:, 0] - cx) * (b[:, 1] - cy)
    w1 = (c[:, 0] - cx) * (a[:, 1] - cy) - (a[:, 0] - cx) * (c[:, 1] - cy)
    w2 = (a[:, 0] - cx) * (b[:, 1] - cy) - (b[:, 0] - cx) * (a[:, 1] - cy)
    sign = np.sign(area[tri])
    inside = (w0 * sign >= 0) & (w1 * sign >= 0) & (w2 * sign >= 0)
    if not inside.any():
        return
    tri, px, py = tri[inside], px[inside], py[inside]
    bary = np.stack([w0[inside], w1[inside], w2[inside]], axis=1) / area[tri][:, None]
    if perspective:
        inverse = bary / z[tri]
        depth = 1.0 / inverse.sum(axis=1)
        bary = inverse * depth[:, None]
    else:
        depth = np.zeros(len(tri))
    pixel = (py - y0) * w + (px - x0)
    order = np.lexsort((depth, pixel))
    pixel, depth, tri, bary = pixel[order], depth[order], tri[order], bary[order]
    first = np.concatenate([[True], pixel[1:] != pixel[:-1]])
    pixel, depth, tri, bary = pixel[first], depth[first], tri[first], bary[first]
    nearer = depth < depth_out[pixel]
    pixel = pixel[nearer]
    tri_out[pixel] = tri[nearer]
    bary_out[pixel] = bary[nearer]
    depth_out[pixel] = depth[nearer]


def interpolate(raster: Raster, triangles: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Per-vertex ``values`` (N, C) interpolated at the covered pixels: (K, C) in row-major order of
    ``raster.mask``."""
    mask = raster.mask
    corners = np.asarray(triangles)[raster.triangle[mask]]                 # (K, 3)
    weights = raster.bary[mask].astype(np.float64)
    values = np.asarray(values, np.float64)
    return np.einsum("kj,kjc->kc", weights, values[corners])
