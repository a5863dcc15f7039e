# SPDX-License-Identifier: GPL-3.0-or-later
"""Eyes, teeth and tongue (thesis 3.1.2 "Eyes, Teeth, Tongue": "modeled as rigid geometric objects ...
generated procedurally and added to the model", placed from landmarks).

Everything is built in head coordinates (metres, Z up, face along -Y, +X = character's left) in its rest
pose; the rig moves each part by a 4x4 matrix per frame (eyes: gaze; upper teeth: skull; lower teeth and
tongue: jaw, the tongue also by its own parameters).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PartMesh", "cornea_bulge", "eyeball_mesh", "teeth_meshes", "tongue_mesh", "tongue_in_arch", "lingual_outline",
           "arch_surface"]

# Mesiodistal crown widths (mm), central incisor to second molar; a typical adult dentition.
UPPER_WIDTHS = (8.5, 6.5, 7.5, 7.0, 6.5, 10.0, 9.0)
LOWER_WIDTHS = (5.0, 5.5, 7.0, 7.0, 7.0, 11.0, 10.5)
CROWN_HEIGHT = (10.0, 9.0, 10.0, 8.0, 7.5, 7.0, 6.5)     # mm, incisors tallest
CROWN_DEPTH = (7.0, 6.5, 8.0, 9.0, 9.0, 10.5, 10.0)      # labio-lingual, mm


@dataclass
class PartMesh:
    """A rigid part: rest vertices (N,3), triangles (M,3) and a per-face material label
    (``labels`` names them, e.g. eyes: sclera/iris/pupil; teeth: tooth/gum)."""
    name: str
    vertices: np.ndarray
    faces: np.ndarray
    face_material: np.ndarray
    labels: tuple[str, ...]


def _uv_sphere(rings: int, segments: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit sphere with its poles on -Y/+Y (so the front pole looks along -Y), deterministic."""
    verts = [[0.0, -1.0, 0.0]]
    for i in range(1, rings):
        polar = np.pi * i / rings
        for j in range(segments):
            az = 2 * np.pi * j / segments
            verts.append([np.sin(polar) * np.cos(az), -np.cos(polar), np.sin(polar) * np.sin(az)])
    verts.append([0.0, 1.0, 0.0])
    faces = []
    for j in range(segments):
        faces.append([0, 1 + (j + 1) % segments, 1 + j])
    for i in range(rings - 2):
        a0, b0 = 1 + i * segments, 1 + (i + 1) * segments
        for j in range(segments):
            j1 = (j + 1) % segments
            faces.append([a0 + j, a0 + j1, b0 + j])
            faces.append([a0 + j1, b0 + j1, b0 + j])
    last = len(verts) - 1
    base = 1 + (rings - 2) * segments
    for j in range(segments):
        faces.append([base + j, base + (j + 1) % segments, last])
    return np.array(verts), np.array(faces, np.int64)


CORNEA_BULGE = 0.035      # the cornea stands this fraction of the eyeball radius proud at the gaze axis
CORNEA_DEG = 32.0         # ... over this angle from the gaze axis


def cornea_bulge(angle_deg: np.ndarray) -> np.ndarray:
    """Extra radius (fraction of the eyeball radius) of the eyeball surface ``angle_deg`` from its gaze
    axis: the cornea's bulge over the iris, 0 beyond :data:`CORNEA_DEG`."""
    angle = np.asarray(angle_deg, np.float64)
    return np.where(angle < CORNEA_DEG, CORNEA_BULGE * np.cos(np.radians(angle) * 90 / CORNEA_DEG) ** 2, 0.0)


def eyeball_mesh(centre: np.ndarray, radius: float, name: str, rings: int = 24, segments: int = 32) -> PartMesh:
    """Eyeball looking along -Y with a cornea that bulges a little over the iris; materials by the angle
    from the gaze axis (pupil < 9 deg, iris < 28 deg: an iris ~11.5 mm across on a 12 mm eye)."""
    unit, faces = _uv_sphere(rings, segments)
    angle = np.degrees(np.arccos(np.clip(-unit[:, 1], -1, 1)))
    bulge = cornea_bulge(angle)
    verts = centre + unit * (radius * (1 + bulge))[:, None]
    face_angle = angle[faces].mean(axis=1)
    material = np.where(face_angle < 9, 2, np.where(face_angle < 28, 1, 0))
    return PartMesh(name, verts, faces, material.astype(np.int64), ("sclera", "iris", "pupil"))


def _box_tooth(width: float, depth: float, height: float, down: bool) -> tuple[np.ndarray, np.ndarray]:
    """A rounded crown: a coarse sphere squashed into a box-like shape (superellipsoid, exponent 4)."""
    unit, faces = _uv_sphere(8, 12)
    shaped = np.sign(unit) * np.abs(unit) ** 0.5
    shaped *= np.array([width, depth, height]) / 2
    shaped[:, 2] += -height / 2 if down else height / 2
    return shaped, faces


def teeth_meshes(incisal_point: np.ndarray, arch_half_width: float, arch_depth: float,
                 lower_incisal_point: np.ndarray, scale: float = 1.0) -> tuple[PartMesh, PartMesh]:
    """Upper and lower dental arches. ``incisal_point`` is the middle of the upper central incisors' cutting
    edge (labial side); the arch is a parabola reaching ``arch_half_width`` (m) at the second molars,
    ``arch_depth`` behind the incisors. Upper crowns hang down from the gum line, lower crowns stand up."""
    parts = []
    for upper, widths, anchor in ((True, UPPER_WIDTHS, incisal_point), (False, LOWER_WIDTHS, lower_incisal_point)):
        verts, faces, material = [], [], []
        half = arch_half_width * (1.0 if upper else 0.93)
        depth = arch_depth * (1.0 if upper else 0.95)
        # arc-length positions of the crowns along the parabola y = depth (x/half)^2
        xs = np.linspace(0, half, 400)
        ys = depth * (xs / half) ** 2
        arc = np.r_[0, np.cumsum(np.hypot(np.diff(xs), np.diff(ys)))]
        position = 0.0
        for k, w_mm in enumerate(widths):
            w = w_mm / 1000 * scale
            centre_arc = position + w / 2
            position += w
            x = np.interp(centre_arc, arc, xs)
            y = np.interp(centre_arc, arc, ys)
            slope = 2 * depth * x / half ** 2
            norm = np.hypot(1.0, slope)
            d = CROWN_DEPTH[k] / 1000 * scale * (1.0 if upper else 0.9)
            h = CROWN_HEIGHT[k] / 1000 * scale * (1.0 if upper else 0.95)
            shape, f = _box_tooth(w * 0.92, d, h, down=not upper)   # crowns grow away from the cutting edge
            for side in (1.0, -1.0):
                along = np.array([side, slope, 0.0]) / norm               # across the crown
                inward = np.array([-side * slope, 1.0, 0.0]) / norm        # labial -> lingual
                basis = np.stack([along, inward, np.array([0.0, 0.0, 1.0])], 1)
                centre = anchor + np.array([side * x, y, 0.0]) + inward * d / 2
                placed = shape @ basis.T + centre
                offset = sum(len(v) for v in verts)
                faces.append((f if side > 0 else f[:, ::-1]) + offset)    # the mirrored frame flips winding
                verts.append(placed)
                material.append(np.zeros(len(f), np.int64))
        v = np.vstack(verts)
        parts.append(PartMesh("teeth_upper" if upper else "teeth_lower", v, np.vstack(faces),
                              np.concatenate(material), ("tooth",)))
    return parts[0], parts[1]


def _arch_points(half: float, depth: float, widths: np.ndarray, samples: int = 400):
    """Points along one side (x >= 0) of the parabolic arch ``y = depth (x/half)^2`` of :func:`teeth_meshes`
    (relative to its incisal point): x, y, slope and the index of the crown there (``widths`` in m, laid
    out by arc length from the midline)."""
    xs = np.linspace(0, half, samples)
    ys = depth * (xs / half) ** 2
    arc = np.r_[0, np.cumsum(np.hypot(np.diff(xs), np.diff(ys)))]
    ends = np.cumsum(widths)
    tooth = np.minimum(np.searchsorted(ends, arc), len(widths) - 1)
    return xs, ys, 2 * depth * xs / half ** 2, tooth


def lingual_outline(lower_incisal_point: np.ndarray, arch_half_width: float, arch_depth: float,
                    scale: float = 1.0, clearance: float = 0.0015) -> tuple[np.ndarray, np.ndarray]:
    """The free space inside the lower dental arch of :func:`teeth_meshes`, seen from above: for depths
    ``y`` (head coordinates, increasing backwards) the half-width ``x`` (m) that stays ``clearance`` behind
    the crowns' lingual faces. In front of the central incisors' lingual face the half-width is 0."""
    half, depth = arch_half_width * 0.93, arch_depth * 0.95
    xs, ys, slope, tooth = _arch_points(half, depth, np.array(LOWER_WIDTHS) / 1000 * scale)
    crown = np.array(CROWN_DEPTH)[tooth] / 1000 * scale * 0.9 + clearance
    norm = np.hypot(1.0, slope)
    x = xs - slope * crown / norm                       # labial face moved inward (lingual) by the crown
    y = ys + crown / norm
    keep = x >= 0
    y, x = np.maximum.accumulate(y[keep]), x[keep]                  # depth monotone for np.interp
    x = np.minimum.accumulate(x[::-1])[::-1]           # and the width: never wider than any point behind
    return lower_incisal_point[1] + y, x


def tongue_mesh(tip: np.ndarray, length: float, width: float, thickness: float, rings: int = 14,
                segments: int = 20, inside: tuple[np.ndarray, np.ndarray] | None = None) -> PartMesh:
    """A rigid tongue: a half-ellipsoid (flat underside) whose tip is at ``tip`` and which extends
    ``length`` backwards (+Y), with a shallow median groove on top. ``inside`` = (depths, half-widths) of
    the space it must fit in seen from above (:func:`lingual_outline`): every cross-section is narrowed,
    keeping its shape, to the half-width allowed at its depth (behind the outline the last value holds)."""
    unit, faces = _uv_sphere(rings, segments)
    shaped = unit.copy()
    shaped[:, 2] = np.where(shaped[:, 2] < 0, shaped[:, 2] * 0.25, shaped[:, 2])     # flatter underside
    groove = 0.12 * np.exp(-(shaped[:, 0] / 0.25) ** 2) * (shaped[:, 2] > 0.3)
    shaped[:, 2] -= groove
    verts = shaped * np.array([width / 2, length / 2, thickness / 2])
    verts += tip + np.array([0.0, length / 2, 0.0])
    if inside is not None:
        depths, allowed = inside
        section = width / 2 * np.sqrt(np.clip(1.0 - unit[:, 1] ** 2, 0.0, 1.0))     # ellipsoid half-width
        limit = np.interp(verts[:, 1], depths, allowed, left=0.0)
        narrow = np.where(section > limit, limit / np.maximum(section, 1e-9), 1.0)
        verts[:, 0] *= narrow
        top = verts[:, 2] > tip[2]                      # a narrowed blade is also flatter (no ridge)
        verts[top, 2] = tip[2] + (verts[top, 2] - tip[2]) * (0.5 + 0.5 * narrow[top])
    return PartMesh("tongue", verts, faces, np.zeros(len(faces), np.int64), ("tongue",))


def tongue_in_arch(lower_incisal_point: np.ndarray, arch_half_width: float, arch_depth: float,
                   scale: float = 1.0, clearance: float = 0.0015) -> tuple[PartMesh, np.ndarray]:
    """The tongue at rest on the floor of the mouth (3.1.2 "Eyes, Teeth, Tongue": generated procedurally):
    inside the lower dental arch (``clearance`` behind every crown's lingual face), its tip behind the
    central incisors and 3 mm below their cutting edge, its back 46 mm further. Returns the mesh and the
    pivot of ``tongue_tip_up``, 26 mm behind the tip (see :func:`.kinematics.tongue_matrix`)."""
    depths, allowed = lingual_outline(lower_incisal_point, arch_half_width, arch_depth, scale, clearance)
    tip = np.array([lower_incisal_point[0], depths[0], lower_incisal_point[2] - 0.003 * scale])
    mesh = tongue_mesh(tip, 0.046 * scale, 0.044 * scale, 0.015 * scale, inside=(depths, allowed))
    pivot = tip + np.array([0.0, 0.026, -0.001]) * scale
    return mesh, pivot


def arch_surface(incisal_point: np.ndarray, arch_half_width: float, arch_depth: float, upper: bool,
                 samples: int = 41, heights: int = 7, reach: float = 0.013) -> tuple[np.ndarray, np.ndarray]:
    """Sample points (P, 3) and outward normals (P, 3) of the labial face of a dental arch (the parabola of
    :func:`teeth_meshes`), from the cutting edge up to the gums (upper) or down (lower): what the lips
    must stay in front of."""
    half = arch_half_width * (1.0 if upper else 0.93)
    depth = arch_depth * (1.0 if upper else 0.95)
    xs = np.linspace(-half, half, samples)
    ys = depth * (xs / half) ** 2
    normal = np.stack([2 * depth * xs / half ** 2, -np.ones_like(xs), np.zeros_like(xs)], 1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    zs = np.linspace(-0.001, reach, heights) * (1.0 if upper else -1.0)
    points = incisal_point + np.stack([np.repeat(xs, heights), np.repeat(ys, heights), np.tile(zs, samples)], 1)
    return points, np.repeat(normal, heights, axis=0)
