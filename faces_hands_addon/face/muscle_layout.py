# SPDX-License-Identifier: GPL-3.0-or-later
"""Muscle grids (thesis 3.1.2 "Building Muscles"): laid out once on the template, stored in terms of template
surface positions, turned into fibres under the skin.

``presets/face/muscles.json`` holds every muscle as a *coarse grid*: rows of control points, each point a
weighted combination of MediaPipe canonical-face vertices written as text (``"61"``,
``"0.5*61 + 0.5*186"``), so the layout transfers to any head the canonical face is registered onto.
Building follows the thesis: "The initial grid is made regular by adding control points" (bilinear
refinement), "projected onto the face mesh and placed slightly underneath the surface, taking into account
skin and average muscle thickness" with a refinement "so that the grid does not cut through the skin and
... fulfils the distance constraints" (depth clamped between the skin and the bone), fibres run "along the
columns of the muscle grid", and "the control points are assigned row by row to either skull or jaw
depending on the bone the majority of the closest skin vertices are associated with".

Grid convention: ``grid[row][column]``; a fibre is a column. Linear muscles: row 0 is the fixed origin on
bone, the last row the insertion. Sphincters: rows run along the ring (``closed`` for a full ring).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..core.errors import UserError
from ..core import geometry
from ..core.presets import PresetFormat, parse_preset, read_preset_text, register_format, resolve

__all__ = ["PointExpr", "MuscleSpec", "ConnectionSpec", "parse_point", "load_muscle_specs", "parse_muscle_specs", "PlacedMuscle",
           "place_muscle", "FORMAT"]

FORMAT = register_format(PresetFormat("faces_hands.face_muscles", 1, required=("muscles",),
                                     shape={"about": str, "muscles": [{}], "connections": [{}]}))
_TERM = re.compile(r"^\s*(?:([0-9]*\.?[0-9]+)\s*\*\s*)?([0-9]+)\s*$")


@dataclass(frozen=True)
class PointExpr:
    """A surface point as a weighted sum of canonical vertices (weights are normalised)."""
    indices: tuple[int, ...]
    weights: tuple[float, ...]

    def evaluate(self, vertices: np.ndarray) -> np.ndarray:
        return np.asarray(self.weights) @ vertices[list(self.indices)]

    def mirrored(self, mirror: np.ndarray) -> "PointExpr":
        return PointExpr(tuple(int(mirror[i]) for i in self.indices), self.weights)


def parse_point(text: str | int) -> PointExpr:
    """``"61"`` or ``"0.5*61 + 0.5*186"`` -> :class:`PointExpr` (no eval; a tiny parser)."""
    if isinstance(text, int):
        return PointExpr((text,), (1.0,))
    indices, weights = [], []
    for term in str(text).split("+"):
        match = _TERM.match(term)
        if not match:
            raise UserError(f"muscle point {text!r}: write vertex ids with optional weights, e.g. '0.5*61 + 0.5*186'")
        weights.append(float(match.group(1) or 1.0))
        indices.append(int(match.group(2)))
    total = sum(weights)
    if total <= 0:
        raise UserError(f"muscle point {text!r}: weights must add up to more than 0")
    return PointExpr(tuple(indices), tuple(w / total for w in weights))


@dataclass
class MuscleSpec:
    """One muscle as written in muscles.json (lengths in metres after loading)."""
    name: str
    kind: str                                 # "linear" | "sphincter"
    grid: list[list[PointExpr]]
    closed: bool = False
    refine: tuple[int, int] = (2, 1)          # subdivisions per coarse cell (rows, columns)
    thickness: float = 0.004
    skin_depth: float = 0.0025                # skin + fat over the muscle's top
    max_shortening: float = 0.25              # linear: fraction of the length at contraction 1
    bulge: float = 0.6                        # thickening at full contraction, fraction of the thickness
    influence: float = 0.007                  # zone of influence beyond the muscle sheet
    centre: PointExpr | None = None           # sphincter centre of contraction
    squeeze: tuple[float, float] = (0.2, 0.3)  # sphincter: (horizontal, vertical) shrink of the inner fibre
    taper: float = 0.0                        # sphincter: outer fibres shrink (inner/outer)^taper as much
    protrusion: tuple[float, float] = (0.0, 0.0)   # orbicularis oris: (forward, backward) travel, m
    red_lip_columns: int = 0                  # orbicularis oris: coarse columns out to the vermilion border,
    #                                           which travel as the innermost fibre (see .muscles)
    rounding: tuple[float, float] = (0.0, 0.0)  # orbicularis oris, contracted and protruded: (extra sideways
    #                                           shrink, lateral closure) of the inner fibre (see .muscles)
    rounding_taper: float = 0.0               # outer fibres shrink sideways (inner/outer)^rounding_taper as much
    group: str = ""                           # "oris" for the two halves of the orbicularis oris
    middle_screen: float | None = None        # sphincter: screening of its middle rows (.muscles._screening)


@dataclass
class ConnectionSpec:
    """Control points of several muscles that stay together (weighted-centre rule, 3.1.2 "Muscle
    Deformation"): ``members`` = (muscle name, coarse (row, column) pairs). A ``kind="push"`` entry instead
    moves every point of the ``targets`` muscles by the members' mean displacement, ``gain`` faded to 0 at
    ``reach`` m, along ``axes`` of head space only (e.g. "x") (:meth:`.muscles.MuscleSystem._push`)."""
    name: str
    members: list[tuple[str, list[tuple[int, int]]]] = field(default_factory=list)
    kind: str = "keep"
    targets: tuple[str, ...] = ()
    gain: float = 1.0
    reach: float = 0.02
    axes: str = "xyz"


def _coarse_cells(spec_text: str, shape: tuple[int, int]) -> list[tuple[int, int]]:
    """``"[-1, :]"`` / ``"[1:3, 2]"`` / ``""`` (all) -> coarse (row, column) pairs."""
    rows, cols = shape
    text = spec_text.strip()
    if not text:
        return [(r, c) for r in range(rows) for c in range(cols)]
    match = re.fullmatch(r"\[\s*([^,\]]*)\s*,\s*([^\]]*)\s*\]", text)
    if not match:
        raise UserError(f"connection member {text!r}: use [rows, columns] with ints or slices, e.g. [-1, :]")

    def pick(part: str, size: int) -> list[int]:
        part = part.strip()
        if ":" in part:
            a, b = (p.strip() for p in part.split(":", 1))
            return list(range(size))[slice(int(a) if a else None, int(b) if b else None)]
        return [list(range(size))[int(part)]]
    return [(r, c) for r in pick(match.group(1), rows) for c in pick(match.group(2), cols)]


def load_muscle_specs(mirror: np.ndarray, path: Path | None = None) -> tuple[list[MuscleSpec], list[ConnectionSpec]]:
    """Muscles and connections from muscles.json; ``"mirror": true`` entries (named ``*_R``) also yield
    their ``*_L`` twin through the canonical face's left/right vertex map."""
    path = Path(path) if path else resolve("face/muscles.json")
    return parse_muscle_specs(read_preset_text(path), mirror, str(path), legacy=False)


def parse_muscle_specs(text: str, mirror: np.ndarray, path: str = "muscles.json", legacy: bool = True
                       ) -> tuple[list[MuscleSpec], list[ConnectionSpec]]:
    """Muscles and connections from the JSON text of a muscle layout (see :func:`load_muscle_specs`);
    ``legacy`` accepts the header-less text stored in rigs saved before presets had headers."""
    doc = parse_preset(text, path, FORMAT.name, legacy=legacy)
    specs: list[MuscleSpec] = []
    mm = 0.001
    for entry in doc.get("muscles", []):
        try:
            grid = [[parse_point(p) for p in row] for row in entry["grid"]]
            spec = MuscleSpec(
                name=entry["name"], kind=entry["kind"], grid=grid, closed=bool(entry.get("closed", False)),
                refine=tuple(entry.get("refine", (2, 1))), thickness=entry.get("thickness_mm", 4.0) * mm,
                skin_depth=entry.get("skin_depth_mm", 2.5) * mm,
                max_shortening=float(entry.get("max_shortening", 0.25)), bulge=float(entry.get("bulge", 0.6)),
                influence=entry.get("influence_mm", 7.0) * mm,
                centre=parse_point(entry["centre"]) if "centre" in entry else None,
                squeeze=tuple(entry.get("squeeze", (0.2, 0.3))), taper=float(entry.get("taper", 0.0)),
                protrusion=tuple(v * mm for v in entry.get("protrusion_mm", (0.0, 0.0))),
                red_lip_columns=int(entry.get("red_lip_columns", 0)),
                rounding=tuple(entry.get("rounding", (0.0, 0.0))),
                rounding_taper=float(entry.get("rounding_taper", 0.0)),
                group=entry.get("group", ""),
                middle_screen=float(entry["middle_screen"]) if "middle_screen" in entry else None)
        except (KeyError, TypeError, ValueError) as exc:
            raise UserError(f"{path}: muscle {entry.get('name', '?')!r} is malformed ({exc})") from None
        if spec.kind not in ("linear", "sphincter") or len(grid) < 2 or any(len(r) != len(grid[0]) for r in grid):
            raise UserError(f"{path}: muscle {spec.name!r} needs kind linear/sphincter and a rectangular grid")
        specs.append(spec)
        if entry.get("mirror"):
            if not spec.name.endswith("_R"):
                raise UserError(f"{path}: mirrored muscle {spec.name!r} must be named *_R")
            twin = replace(spec, name=spec.name[:-2] + "_L", grid=[[p.mirrored(mirror) for p in row] for row in grid],
                           centre=spec.centre.mirrored(mirror) if spec.centre else None)
            specs.append(twin)
    by_name = {s.name: s for s in specs}
    connections = []
    for entry in doc.get("connections", []):
        for mirrored in ((False, True) if entry.get("mirror") else (False,)):
            members = []
            for member in entry["members"]:
                name, _, cells = member.partition("[")
                name = name.strip()
                cells = "[" + cells if cells else ""
                target = name[:-2] + "_L" if mirrored and name.endswith("_R") else name
                if target not in by_name:
                    raise UserError(f"{path}: connection {entry['name']!r} names unknown muscle {target!r}")
                spec = by_name[target]
                shape = (len(spec.grid), len(spec.grid[0]))
                pairs = _coarse_cells(cells, shape)
                if mirrored and not name.endswith("_R"):
                    pairs = [(shape[0] - 1 - r, c) for r, c in pairs]   # a symmetric muscle: mirror rows
                members.append((target, pairs))
            label = entry["name"][:-2] + "_L" if mirrored and entry["name"].endswith("_R") else entry["name"]
            kind = entry.get("kind", "keep")
            targets, axes = tuple(entry.get("targets", ())), str(entry.get("axes", "xyz"))
            if (kind not in ("keep", "push") or (kind == "push" and not all(t in by_name for t in targets))
                    or not axes or set(axes) - set("xyz")):
                raise UserError(f"{path}: connection {entry['name']!r}: kind is keep or push; a push names "
                                "existing target muscles and axes out of x, y, z")
            connections.append(ConnectionSpec(label, members, kind, targets, float(entry.get("gain", 1.0)),
                                              entry.get("reach_mm", 20.0) * mm, axes))
    return specs, connections


@dataclass
class PlacedMuscle:
    """A muscle grid refined, projected and placed under the skin, in head coordinates."""
    spec: MuscleSpec
    points: np.ndarray            # (R, C, 3) fine grid at rest, under the skin
    normals: np.ndarray           # (R, C, 3) outward (towards the skin)
    skin_points: np.ndarray       # (R, C, 3) the projections on the skin
    row_bone: np.ndarray          # (R,) 0 skull, 1 jaw
    coarse_to_fine: tuple[int, int]

    @property
    def shape(self) -> tuple[int, int]:
        return self.points.shape[0], self.points.shape[1]


def _refine_grid(coarse: np.ndarray, refine: tuple[int, int], closed: bool) -> np.ndarray:
    """Bilinear refinement of a (R, C, 3) grid; closed grids wrap along the rows."""
    sr, sc = max(1, int(refine[0])), max(1, int(refine[1]))
    if closed:
        coarse = np.concatenate([coarse, coarse[:1]], axis=0)
    rows, cols = coarse.shape[:2]
    r = np.linspace(0, rows - 1, (rows - 1) * sr + 1)
    c = np.linspace(0, cols - 1, (cols - 1) * sc + 1)
    r0 = np.minimum(np.floor(r).astype(int), rows - 2)
    c0 = np.minimum(np.floor(c).astype(int), max(cols - 2, 0))
    fr, fc = r - r0, c - c0
    if cols == 1:
        out = coarse[r0, 0] * (1 - fr)[:, None] + coarse[r0 + 1, 0] * fr[:, None]
        out = out[:, None, :]
    else:
        a = coarse[r0][:, c0]
        b = coarse[r0 + 1][:, c0]
        cc = coarse[r0][:, c0 + 1]
        d = coarse[r0 + 1][:, c0 + 1]
        fr_, fc_ = fr[:, None, None], fc[None, :, None]
        out = a * (1 - fr_) * (1 - fc_) + b * fr_ * (1 - fc_) + cc * (1 - fr_) * fc_ + d * fr_ * fc_
    return out[:-1] if closed else out


def _sheet_normals(points: np.ndarray, skin_normals: np.ndarray) -> np.ndarray:
    """Normals (R, C, 3) of the grid surface itself (row x column tangents), on the skin's side: at an open
    lip margin the skin turns into the mouth, but the lip ring still faces forward."""
    along_rows = np.gradient(points, axis=0)
    along_cols = np.gradient(points, axis=1)
    n = np.cross(along_rows, along_cols)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    flip = np.sign(np.sum(n * skin_normals, axis=-1, keepdims=True).sum(axis=(0, 1), keepdims=True))
    return n * np.where(flip == 0, 1.0, flip)


def place_muscle(spec: MuscleSpec, canonical: np.ndarray, skin_vertices: np.ndarray, skin_faces: np.ndarray,
                 skin_normals: np.ndarray, bone_depth: np.ndarray, node_on_jaw: np.ndarray,
                 open_lips: bool = False) -> PlacedMuscle:
    """Refine, project onto the skin and sink the grid to its depth (see the module docstring).

    ``bone_depth[i]`` is the skin-to-bone distance under node i; the muscle's centre sits at
    ``skin_depth + thickness/2`` but never closer than ``thickness/2 + 0.5 mm`` to the bone and never
    shallower than 1 mm (so it neither cuts through the skin nor into the bone).
    """
    coarse = np.array([[p.evaluate(canonical) for p in row] for row in spec.grid])
    fine = _refine_grid(coarse, spec.refine, spec.closed)
    flat = fine.reshape(-1, 3)
    projected, face, bary, _ = geometry.closest_points(skin_vertices, skin_faces, flat)
    corners = skin_faces[face]
    normal = np.einsum("ij,ijk->ik", bary, skin_normals[corners])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    if spec.group == "oris" and open_lips:
        normal = _sheet_normals(projected.reshape(*fine.shape[:2], 3),
                                normal.reshape(*fine.shape[:2], 3)).reshape(-1, 3)
    under = np.einsum("ij,ij->i", bary, bone_depth[corners])
    wanted = spec.skin_depth + spec.thickness / 2
    depth = np.clip(np.minimum(wanted, under - spec.thickness / 2 - 0.0005), 0.001, None)
    points = projected - normal * depth[:, None]
    shape = fine.shape[:2]
    _, nearest = cKDTree(skin_vertices).query(projected, k=6)
    votes = node_on_jaw[nearest].mean(axis=1).reshape(shape)
    row_bone = (votes.mean(axis=1) > 0.5).astype(np.int64)
    if spec.group == "oris":
        # each half of the orbicularis oris belongs to its own lip's bone as a whole (upper: skull, lower: jaw),
        # like the skin it moves; the corners' vote is ambiguous and a jaw-carried upper corner would lift
        # the (skull-carried) upper lip skin when the jaw opens
        row_bone[:] = int(votes.mean() > 0.5)
    return PlacedMuscle(spec, points.reshape(*shape, 3), normal.reshape(*shape, 3), projected.reshape(*shape, 3),
                        row_bone, (max(1, int(spec.refine[0])), max(1, int(spec.refine[1]))))
