# SPDX-License-Identifier: GPL-3.0-or-later
"""Meshes for the synthetic photographs and the replay, as plain arrays: the marked ball (a sphere with its
12 painted markers as flat decals, Fig. 6.28), a strobe's light baked into vertex colours (the front pair's
full discs, the back pair's side-lit half-moons, Fig. 6.29), the checkerboard and the 3D calibration object,
the glove's markers and the hand's skin posed by its bones (linear blend skinning of the rig's rest skin)."""
from __future__ import annotations

import numpy as np

from .ball_model import BallModel

__all__ = ["ball_mesh", "shade", "board_mesh", "icosphere", "skinned", "MeshArrays", "shape_inside"]


class MeshArrays:
    """vertices (V, 3), faces (list of index tuples), colours (V, 3) linear RGB, normals (V, 3)."""

    def __init__(self, vertices, faces, colours, normals):
        self.vertices, self.faces, self.colours, self.normals = vertices, faces, colours, normals

    def transformed(self, rotation: np.ndarray, translation: np.ndarray) -> "MeshArrays":
        return MeshArrays(self.vertices @ rotation.T + translation, self.faces, self.colours.copy(),
                          self.normals @ rotation.T)


def _tangent_frame(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, d)
    u /= np.linalg.norm(u)
    return u, np.cross(d, u)


def shape_inside(shape: str, x: np.ndarray, y: np.ndarray, r: float) -> np.ndarray:
    """Which of the points (x, y) lie inside a marker ``shape`` of half-width ``r`` (Fig. 6.28's shapes)."""
    if shape == "square":
        return (np.abs(x) <= 0.89 * r) & (np.abs(y) <= 0.89 * r)
    if shape == "triangle":
        k = 1.1 * r                                    # circumradius; edges at distance k / 2 from the centre
        normals = np.array([[np.cos(a), np.sin(a)] for a in np.radians([270.0, 30.0, 150.0])])
        return np.all(np.column_stack([x, y]) @ normals.T <= 0.5 * k, axis=1)
    d = np.hypot(x, y)
    return (d <= r) & (d >= 0.55 * r) if shape == "ring" else d <= r


def _decal(shape: str, size: float, cells: int = 12) -> tuple[np.ndarray, list]:
    """A marker shape ``size`` metres across as the cells of a fine grid whose centres fall inside it (so the
    decal can hug the sphere): 2D grid points and quad faces."""
    r = 0.5 * size
    ticks = np.linspace(-r * 1.12, r * 1.12, cells + 1)
    gx, gy = np.meshgrid(ticks, ticks, indexing="xy")
    points = np.column_stack([gx.ravel(), gy.ravel()])
    mid = 0.5 * (ticks[:-1] + ticks[1:])
    cx, cy = np.meshgrid(mid, mid, indexing="xy")
    keep = shape_inside(shape, cx.ravel(), cy.ravel(), r)
    faces = []
    for k in np.flatnonzero(keep):
        j, i = divmod(int(k), cells)
        a = j * (cells + 1) + i
        faces.append((a, a + 1, a + cells + 2, a + cells + 1))
    return points, faces


def ball_mesh(model: BallModel, segments: int = 64, rings: int = 32) -> MeshArrays:
    """The white ball with its markers in the ball's own frame (decals 0.15 mm above the leather)."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    dirs = np.column_stack([(np.sin(t) * np.cos(p)).ravel(), (np.sin(t) * np.sin(p)).ravel(), np.cos(t).ravel()])
    dirs = np.vstack([dirs, [[0, 0, 1], [0, 0, -1]]])
    top, bottom = len(dirs) - 2, len(dirs) - 1
    faces = []
    for i in range(rings - 2):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            faces.append((a, b, b + segments, a + segments))
    last = (rings - 2) * segments
    for j in range(segments):
        faces.append((top, (j + 1) % segments, j))
        faces.append((bottom, last + j, last + (j + 1) % segments))
    vertices, normals = [dirs * model.radius], [dirs]
    colours = [np.full((len(dirs), 3), 0.92)]
    count = len(dirs)
    for d, kind in zip(model.directions, model.types):
        outline, polys = _decal(model.shapes[kind], model.marker_size)
        u, v = _tangent_frame(d)
        pts = d * model.radius + outline[:, :1] * u + outline[:, 1:] * v
        pts = pts / np.linalg.norm(pts, axis=1, keepdims=True) * model.radius * 1.004
        vertices.append(pts)
        normals.append(pts / np.linalg.norm(pts, axis=1, keepdims=True))
        colours.append(np.tile(model.rgb[kind], (len(pts), 1)))
        faces += [tuple(count + i for i in poly) for poly in polys]
        count += len(pts)
    return MeshArrays(np.vstack(vertices), faces, np.vstack(colours), np.vstack(normals))


def shade(mesh: MeshArrays, light: np.ndarray | None, ambient: float) -> MeshArrays:
    """Lambert shading by a point ``light`` (world) baked into the colours, plus ``ambient`` (0..1);
    ``light=None`` leaves the colours flat."""
    if light is None:
        return mesh
    to_light = light - mesh.vertices
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    lambert = np.clip(np.sum(mesh.normals * to_light, axis=1), 0.0, 1.0)
    factor = ambient + (1.0 - ambient) * lambert
    return MeshArrays(mesh.vertices, mesh.faces, mesh.colours * factor[:, None], mesh.normals)


def board_mesh(inner: tuple[int, int], square: float, border: float = 0.6) -> MeshArrays:
    """A checkerboard with ``inner`` (columns, rows) inner corners, square edge ``square``, inner corner (0, 0)
    at the origin, in the z = 0 plane, with a white border of ``border`` squares."""
    cols, rows = inner
    vertices, faces, colours = [], [], []

    def quad(x0, y0, x1, y1, value):
        k = len(vertices)
        vertices.extend([[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0]])
        colours.extend([[value] * 3] * 4)
        faces.append((k, k + 1, k + 2, k + 3))

    for j in range(rows + 1):
        for i in range(cols + 1):
            x0, y0 = (i - 1) * square, (j - 1) * square
            quad(x0, y0, x0 + square, y0 + square, 0.9 if (i + j) % 2 == 0 else 0.04)
    lo_x, lo_y = -square - border * square, -square - border * square
    hi_x, hi_y = cols * square + border * square, rows * square + border * square
    quad(lo_x, lo_y, hi_x, -square, 0.9)
    quad(lo_x, rows * square, hi_x, hi_y, 0.9)
    quad(lo_x, -square, -square, rows * square, 0.9)
    quad(cols * square, -square, hi_x, rows * square, 0.9)
    v = np.array(vertices, float)
    v[:, 2] -= 1e-4 * (np.arange(len(v)) >= 4 * (cols + 1) * (rows + 1))   # border just behind the squares
    return MeshArrays(v, faces, np.array(colours, float), np.tile([0.0, 0.0, 1.0], (len(v), 1)))


def icosphere(radius: float, colour, subdivisions: int = 2) -> MeshArrays:
    t = (1 + 5 ** 0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        cache, faces = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = faces
    n = np.array(verts)
    return MeshArrays(n * radius, f, np.tile(np.asarray(colour, float), (len(n), 1)), n)


def skinned(rest: np.ndarray, weights, transforms: np.ndarray, root: np.ndarray) -> np.ndarray:
    """Linear blend skinning: rest vertices (N, 3) carried by bone ``transforms`` (B, 4, 4) with ``weights``
    (N, B, dense or sparse), then by ``root`` (4x4)."""
    flat = transforms[:, :3, :].reshape(len(transforms), 12)
    blended = np.asarray(weights @ flat).reshape(-1, 3, 4)
    posed = np.einsum("nij,nj->ni", blended[:, :, :3], rest) + blended[:, :, 3]
    return posed @ root[:3, :3].T + root[:3, 3]
