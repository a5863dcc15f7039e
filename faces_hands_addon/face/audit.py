# SPDX-License-Identifier: GPL-3.0-or-later
"""Measured shape audit of a face rig: settle a named expression (ARKit, viseme, emotion) and
measure it in millimetres in head space (metres, Z up, face along -Y, +X = the character's left), on the
simulation nodes, so the default head and a rig fitted to an artist's mesh are measured the same way.

Measures (:func:`measure`): lid gap per eye and iris points visible in an orthographic front view (3.1.2
"Eyes, Teeth, Tongue": the lids are skin); inner / middle / outer brow rise; lip-corner displacement and
mouth width; lip gap and lip protrusion at the midline; interincisal opening; the upper and lower incisor
height visible from the front; the lower lip's distance to the upper incisal edge (/f v/); cheek bulge; each
eye's gaze angles; inverted triangles (normal turned > 90 degrees from rest) on the outer skin and, apart, inside the
lips and behind the lids; lip nodes inside the teeth;
and the 95th percentile of left/right asymmetry of the displacement field. The targets that the audit
checks these against are in :mod:`.audit_targets` (sources in ``bench/shape_targets.md``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..core import geometry
from .expressions import expression_controls
from .skin import hidden_nodes

__all__ = ["Probe", "measure", "settle_expression", "MM"]

MM = 1000.0
FORWARD = np.array([0.0, -1.0, 0.0])


def _ends(nodes: np.ndarray, rest: np.ndarray, count: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` nodes of a contour nearest to and farthest from the midline."""
    order = np.argsort(np.abs(rest[nodes, 0]), kind="stable")
    return nodes[order[:count]], nodes[order[-count:]]


def _midline(nodes: np.ndarray, rest: np.ndarray) -> int:
    return int(nodes[np.argmin(np.abs(rest[nodes, 0]))])


def _incisor_columns(points: np.ndarray, upper: bool, step: float = 0.0005, height: float = 0.0095):
    """Vertical lines on the labial face of the central incisors (|x| <= 4 mm), every ``step`` m from the
    cutting edge towards the gum, slightly in front of the tooth (so the tooth never hides itself)."""
    columns = []
    for x in np.unique(np.round(points[np.abs(points[:, 0]) <= 0.0045, 0], 6)):
        column = points[np.isclose(points[:, 0], x, atol=1e-6)]
        edge = column[np.argmin(column[:, 2])] if upper else column[np.argmax(column[:, 2])]
        zs = np.arange(0.0005, height, step) * (1.0 if upper else -1.0)
        line = np.repeat(edge[None], len(zs), 0)
        line[:, 2] += zs
        line[:, 1] -= 0.0003
        columns.append(line)
    return np.stack(columns)              # (C, H, 3)


def visible_from_front(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray, eps: float = 0.0002):
    """Which ``points`` no triangle of (``vertices``, ``faces``) hides from an orthographic camera far
    along -Y (the front view of a contact sheet)."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    tri = vertices[faces]
    lo, hi = points.min(0) - 1e-4, points.max(0) + 1e-4
    keep = ((tri[:, :, 0].max(1) >= lo[0]) & (tri[:, :, 0].min(1) <= hi[0]) & (tri[:, :, 2].max(1) >= lo[2])
            & (tri[:, :, 2].min(1) <= hi[2]) & (tri[:, :, 1].min(1) < hi[1]))
    tri = tri[keep]
    if not len(tri):
        return np.ones(len(points), bool)
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    det = e1[:, 0] * e2[:, 2] - e1[:, 2] * e2[:, 0]
    ok = np.abs(det) > 1e-14
    a, e1, e2, det = a[ok], e1[ok], e2[ok], det[ok]
    out = np.ones(len(points), bool)
    for begin in range(0, len(points), 256):
        p = points[begin:begin + 256]
        dx = p[:, None, 0] - a[None, :, 0]
        dz = p[:, None, 2] - a[None, :, 2]
        u = (dx * e2[None, :, 2] - dz * e2[None, :, 0]) / det[None]
        v = (e1[None, :, 0] * dz - e1[None, :, 2] * dx) / det[None]
        inside = (u >= 0) & (v >= 0) & (u + v <= 1)
        y = a[None, :, 1] + u * e1[None, :, 1] + v * e2[None, :, 1]
        out[begin:begin + 256] = ~np.any(inside & (y < p[:, None, 1] - eps), axis=1)
    return out


@dataclass
class Probe:
    """What the audit reads off a rig once: contour nodes, the rest geometry, the eyes' iris samples,
    the central incisors' labial lines, the cheek patches and the left/right mirror of every node."""
    rig: object

    def __post_init__(self) -> None:
        t = self.rig.template
        skin = t.skin
        self.rest = np.asarray(skin.vertices, np.float64)
        self.faces = np.asarray(skin.faces, np.int64)
        c = skin.contours
        self.lids = {s: (np.asarray(c[f"eye_{s}_upper"]), np.asarray(c[f"eye_{s}_lower"])) for s in "LR"}
        self.brows = {s: np.asarray(c[f"eyebrow_{s}_upper"]) for s in "LR"}
        outer = np.concatenate([c["lips_outer_upper"], c["lips_outer_lower"]])
        self.corner = {"L": int(outer[np.argmax(self.rest[outer, 0])]),
                       "R": int(outer[np.argmin(self.rest[outer, 0])])}
        self.inner_up, self.inner_low = (_midline(np.asarray(c[k]), self.rest)
                                         for k in ("lips_inner_upper", "lips_inner_lower"))
        self.outer_up, self.outer_low = (_midline(np.asarray(c[k]), self.rest)
                                         for k in ("lips_outer_upper", "lips_outer_lower"))
        self.lip_nodes = np.flatnonzero(skin.group("upper_lip") | skin.group("lower_lip"))
        self.lower_lip = np.flatnonzero(skin.group("lower_lip"))
        self.eye_centres = {s: np.asarray(t.organs.eye_centres[s], np.float64) for s in "LR"}
        parts = t.organs.parts
        self.iris = {}
        for s in "LR":
            eye = parts[f"eye_{s}"]
            iris_vertices = np.unique(eye.faces[eye.face_material >= 1])
            self.iris[s] = np.asarray(eye.vertices, np.float64)[iris_vertices]
        self.upper_cols = _incisor_columns(t.organs.arches["upper"][0], True)
        self.lower_cols = _incisor_columns(t.organs.arches["lower"][0], False)
        self.upper_edge = self.upper_cols[:, 0].mean(0) - np.array([0.0, -0.0003, 0.0005])
        self.lower_edge = self.lower_cols[:, 0].mean(0) - np.array([0.0, -0.0003, -0.0005])
        self.teeth = {k: (np.asarray(parts[k].vertices, np.float64), np.asarray(parts[k].faces))
                      for k in ("teeth_upper", "teeth_lower")}
        self.tongue = np.asarray(parts["tongue"].vertices, np.float64)
        normals = np.asarray(t.skin.normals, np.float64)
        tree = cKDTree(self.rest)
        self.cheek = {}
        for s, sign in (("L", 1.0), ("R", -1.0)):
            centre = self.rest[self.corner[s]] + np.array([sign * 0.022, 0.012, 0.010])
            seed = self.rest[tree.query(centre)[1]]
            self.cheek[s] = np.asarray(tree.query_ball_point(seed, 0.010), np.int64)
        self.normals = normals
        lip = self.rest[self.outer_up]
        self.nose = {}
        for s, sign in (("L", 1.0), ("R", -1.0)):
            x, z = self.rest[:, 0] * sign, self.rest[:, 2] - lip[2]
            self.nose[s] = np.flatnonzero((x > 0.006) & (x < 0.024) & (z > 0.008) & (z < 0.026)
                                          & (self.rest[:, 1] < lip[1] + 0.012) & skin.group("surface"))
        mirrored = self.rest * np.array([-1.0, 1.0, 1.0])
        d, idx = tree.query(mirrored)
        self.mirror = np.where(d <= 0.003, idx, -1)
        self.rest_normals = _face_normals(self.rest, self.faces)
        hidden = hidden_nodes(skin)
        self.outside = ~np.any(hidden[self.faces], axis=1)      # triangles a camera can see


def _face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-18)


def _head_transforms(rig) -> dict[str, np.ndarray]:
    """Rigid parts' 4x4 matrices in head space, whatever coordinates the rig reports them in."""
    to_mesh = np.asarray(rig.head_to_mesh, np.float64)
    to_head = np.linalg.inv(to_mesh)
    return {k: to_head @ np.asarray(m, np.float64) @ to_mesh for k, m in rig.rigid_transforms().items()}


def _apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def _lid_gap(p: Probe, pos: np.ndarray, side: str) -> float:
    """Largest vertical opening between the upper and lower lid margins over the middle 60 % of the eye."""
    upper, lower = p.lids[side]
    xs_all = p.rest[np.concatenate([upper, lower]), 0]
    lo, hi = xs_all.min(), xs_all.max()
    xs = np.linspace(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo), 25)
    ou, ol = np.argsort(pos[upper, 0]), np.argsort(pos[lower, 0])
    zu = np.interp(xs, pos[upper[ou], 0], pos[upper[ou], 2])
    zl = np.interp(xs, pos[lower[ol], 0], pos[lower[ol], 2])
    return float(max(0.0, np.max(zu - zl)) * MM)


def _gaze(matrix: np.ndarray) -> tuple[float, float]:
    f = matrix[:3, :3] @ FORWARD
    return float(np.degrees(np.arctan2(f[0], -f[1]))), float(np.degrees(np.arctan2(f[2], -f[1])))


def _shown(cols: np.ndarray, pos: np.ndarray, faces: np.ndarray, step: float = 0.5) -> float:
    """Tallest visible stretch (mm) of the incisor lines: visible samples times the sample spacing."""
    shape = cols.shape
    vis = visible_from_front(cols.reshape(-1, 3), pos, faces).reshape(shape[:2])
    return float(vis.sum(axis=1).max() * step)


def measure(p: Probe, pos: np.ndarray, base: np.ndarray | None = None) -> dict[str, float]:
    """Every audit figure (mm, degrees, counts) of skin positions ``pos`` (head space, (N, 3)) with the
    rig's current controls; displacements relative to ``base`` (the settled neutral; rest if None)."""
    rig = p.rig
    base = p.rest if base is None else base
    T = _head_transforms(rig)
    m: dict[str, float] = {}
    d = (pos - base) * MM
    for s in "LR":
        m[f"gap_{s}"] = _lid_gap(p, pos, s)
        iris = _apply(T[f"eye_{s}"], p.iris[s])
        front = (iris - _apply(T[f"eye_{s}"], p.eye_centres[s][None])[0]) @ FORWARD > 0.2 * np.linalg.norm(
            iris - p.eye_centres[s], axis=1)
        m[f"iris_{s}"] = float(visible_from_front(iris[front], pos, p.faces).sum())
        m[f"yaw_{s}"], m[f"pitch_{s}"] = _gaze(T[f"eye_{s}"])
        inner, outer = _ends(p.brows[s], p.rest)
        m[f"brow_in_{s}"] = float(d[inner, 2].mean())
        m[f"brow_out_{s}"] = float(d[outer, 2].mean())
        m[f"brow_mid_{s}"] = float(np.median(d[p.brows[s], 2]))
        sign = 1.0 if s == "L" else -1.0
        m[f"corner_up_{s}"] = float(d[p.corner[s], 2])
        m[f"corner_out_{s}"] = float(sign * d[p.corner[s], 0])
        m[f"corner_{s}"] = float(np.linalg.norm(d[p.corner[s]]))
        m[f"cheek_{s}"] = float(np.einsum("ij,ij->i", d[p.cheek[s]], p.normals[p.cheek[s]]).mean())
        m[f"nose_up_{s}"] = float(d[p.nose[s], 2].max()) if len(p.nose[s]) else 0.0
        lid_low = p.lids[s][1]
        m[f"lowlid_up_{s}"] = float(d[lid_low, 2].max())
    m["width"] = float(np.linalg.norm(pos[p.corner["L"]] - pos[p.corner["R"]]) * MM)
    m["lip_gap"] = float(max(0.0, pos[p.inner_up, 2] - pos[p.inner_low, 2]) * MM)
    m["upper_lip_up"] = float(d[p.outer_up, 2])
    m["lower_lip_up"] = float(d[p.outer_low, 2])
    m["upper_back"], m["lower_back"] = float(d[p.outer_up, 1]), float(d[p.outer_low, 1])
    m["protrusion"] = float(-(d[p.outer_up, 1] + d[p.outer_low, 1]) / 2)
    jaw = T["teeth_lower"]
    lower_edge = _apply(jaw, p.lower_edge[None])[0]
    m["incisal"] = float((p.upper_edge[2] - lower_edge[2]) * MM)
    m["jaw_x"], m["jaw_y"] = (float(v) for v in (lower_edge - p.lower_edge)[:2] * MM)
    m["upper_show"] = _shown(p.upper_cols, pos, p.faces)
    m["lower_show"] = _shown(np.einsum("ij,chj->chi", jaw[:3, :3], p.lower_cols) + jaw[:3, 3], pos, p.faces)
    m["ff_dist"] = float(np.min(np.linalg.norm(pos[p.lower_lip] - p.upper_edge, axis=1)) * MM)
    tongue = _apply(T["tongue"], p.tongue)
    m["tongue_out"] = float((pos[p.outer_low, 1] - tongue[:, 1].min()) * MM)
    m["tongue_front"] = float((p.upper_edge[1] - tongue[:, 1].min()) * MM)
    normals = _face_normals(pos, p.faces)
    flipped = np.einsum("ij,ij->i", normals, p.rest_normals) < 0
    m["inverted"] = float(np.sum(flipped & p.outside))          # on the outer skin: visible folds
    m["inverted_inside"] = float(np.sum(flipped & ~p.outside))  # inside the lips and behind the lids
    teeth_in = 0.0
    for key, (verts, faces) in p.teeth.items():
        posed = _apply(T[key], verts)
        teeth_in += float(np.sum(geometry.winding_number(posed, faces, pos[p.lip_nodes]) > 0.5))
    m["lip_in_teeth"] = teeth_in
    both = p.mirror >= 0
    mirrored = d[p.mirror[both]] * np.array([-1.0, 1.0, 1.0])
    m["asym95"] = float(np.percentile(np.linalg.norm(d[both] - mirrored, axis=1), 95))
    m["move99"] = float(np.percentile(np.linalg.norm(d, axis=1), 99))
    m["_disp"] = d                           # kept for the pair symmetry of one-sided shapes (not a figure)
    return m


def settle_expression(rig, expression: dict[str, float]) -> np.ndarray:
    """Settle the rig from rest with ``expression`` (other controls at their defaults); head-space
    positions of the simulation nodes (N, 3)."""
    rig.reset()
    rig.set_controls(expression_controls(expression, rig.control_specs()))
    rig.relax()
    return np.asarray(rig.face.network.positions.T, np.float64).copy()


def pair_asymmetry(p: Probe, left: np.ndarray, right: np.ndarray) -> float:
    """95th percentile (mm) of the difference between a left shape's displacement and the mirror image of
    the right one's (``left``/``right``: displacements in mm, (N, 3))."""
    both = p.mirror >= 0
    mirrored = right[p.mirror[both]] * np.array([-1.0, 1.0, 1.0])
    return float(np.percentile(np.linalg.norm(left[both] - mirrored, axis=1), 95))

