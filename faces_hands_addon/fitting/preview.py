# SPDX-License-Identifier: GPL-3.0-or-later
"""A picture of where the fitter thinks the face is: the target mesh seen from the front and from the side
of the face it found, with the located eye, brow, nose, lip and outline landmarks drawn on it.

Shown next to a refusal (:mod:`.quality`) so the artist sees at once whether the face was looked for on the
back of the head, upside down or on something that is not a face. Software rendering in numpy (no Blender):
dense area-uniform surface samples splatted into a z-buffer (orthographic), Lambert-shaded with a headlight;
returns an (H, W, 3) uint8 image, top row first. Deterministic for a given seed.
"""
from __future__ import annotations

import numpy as np

from .template import face_template

__all__ = ["preview_image", "png_bytes"]

_SIZE = (400, 360)          # one panel, height x width
_COLOURS = {"eye": (40, 200, 60), "eyebrow": (230, 160, 20), "lips": (220, 40, 40), "nose": (40, 110, 240),
            "face_oval": (200, 40, 200)}


def _panel(head_points, head_normals, landmarks, view: np.ndarray, centre, half: float, contours):
    """One orthographic view: ``view`` rows are (screen right, screen up, towards the viewer)."""
    h, w = _SIZE
    pixel = 2 * half / min(h, w)
    p = (head_points - centre) @ view.T
    n = head_normals @ view.T
    col = np.floor(p[:, 0] / pixel + w / 2).astype(np.int64)
    row = np.floor(h / 2 - p[:, 1] / pixel).astype(np.int64)
    ok = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    flat = row[ok] * w + col[ok]
    depth = p[ok, 2]
    shade = np.abs(n[ok, 2])
    order = np.lexsort((-depth, flat))
    first = order[np.concatenate([[True], flat[order][1:] != flat[order][:-1]])] if len(order) else order
    image = np.full((h * w, 3), 245, np.uint8)
    grey = (60 + 170 * shade[first]).astype(np.uint8)
    image[flat[first]] = grey[:, None]
    image = image.reshape(h, w, 3)
    q = (landmarks - centre) @ view.T
    for name, line in contours.items():
        colour = next((c for key, c in _COLOURS.items() if name.startswith(key)), (0, 0, 0))
        for index in line:
            c = int(np.floor(q[index, 0] / pixel + w / 2))
            r = int(np.floor(h / 2 - q[index, 1] / pixel))
            image[max(r - 2, 0):max(r + 3, 0), max(c - 2, 0):max(c + 3, 0)] = colour
    image[[0, -1], :] = 0
    image[:, [0, -1]] = 0
    return image


def preview_image(vertices, faces, landmarks, rotation: np.ndarray, *, seed: int = 0,
                  samples: int = 400_000) -> np.ndarray:
    """Front and side view of the face as found, side by side: ``rotation`` (3x3) turns the mesh's axes into
    the face's (face along -Y, top along +Z); framed on the landmarks, showing at least a third of the mesh."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    rotation = np.asarray(rotation, np.float64)[:3, :3]
    head = vertices @ rotation.T
    marks = np.asarray(landmarks, np.float64) @ rotation.T
    corners = head[faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas = np.linalg.norm(cross, axis=1)
    normals = cross / np.maximum(areas, 1e-300)[:, None]
    template = face_template()
    centre = 0.5 * (marks.min(axis=0) + marks.max(axis=0))
    used = head[np.unique(faces)]
    half = max(0.6 * float(np.ptp(marks, axis=0).max()), 0.35 * float(np.ptp(used, axis=0).max()), 1e-12)
    rng = np.random.default_rng(seed)
    near = (np.abs(corners.mean(axis=1) - centre) < 3 * half).all(axis=1) & (areas > 0)
    if near.any():
        weights = areas * near
        tri = rng.choice(len(faces), size=samples, p=weights / weights.sum())
        r1, r2 = rng.random(samples), rng.random(samples)
        root = np.sqrt(r1)
        bary = np.stack([1 - root, root * (1 - r2), root * r2], axis=1)
        points = (bary[:, :, None] * corners[tri]).sum(axis=1)
        point_normals = normals[tri]
    else:
        points, point_normals = np.zeros((0, 3)), np.zeros((0, 3))
    contours = {k: v for k, v in template.contours.items()
                if not k.endswith(("_upper", "_lower")) or k.startswith(("lips", "eyebrow"))}
    front = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])     # seen from -Y: +X right, +Z up
    side = np.array([[0, -1.0, 0], [0, 0, 1.0], [-1.0, 0, 0]])     # seen from -X (face's right): -Y right
    panels = [_panel(points, point_normals, marks, view, centre, half, contours) for view in (front, side)]
    return np.concatenate(panels, axis=1)


def png_bytes(image: np.ndarray) -> bytes:
    """An (H, W, 3) uint8 image (top row first) as PNG file contents (zlib, no other dependency)."""
    import struct
    import zlib
    image = np.ascontiguousarray(image, np.uint8)
    h, w = image.shape[:2]
    raw = b"".join(b"\x00" + image[r].tobytes() for r in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
