# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's armature as plain arrays: an MPFB2 skeleton (:func:`.mpfb2.read_skeleton`) placed on the
character's mesh, its bones' rest frames computed as Blender computes an edit bone's (head, tail, roll ->
matrix), the skin weights on the character's vertices (at most ``max_influences`` per vertex, renormalised),
and pose helpers: a rotation about world axes -> a pose bone's local rotation.

Rest frames (``rest``: 4x4 in armature space, columns = the bone's X, Y (head -> tail), Z axes, translation =
head) follow Blender's ``vec_roll_to_mat3``: the shortest rotation taking +Y to the bone's direction, then
``roll`` about it. A pose bone's ``matrix_basis`` ``B`` poses the bone as ``rest @ B`` relative to its parent
(the parent's posed frame times the rest offset), which is what :func:`local_rotation` inverts.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError
from . import mpfb2
from .body import CharacterMesh, PARTS

__all__ = ["CharacterSkeleton", "bone_matrix", "roll_aligning", "build_skeleton", "local_rotation",
           "axis_angle_matrix", "HEAD_ORGAN_BONES", "MAX_INFLUENCES"]

MAX_INFLUENCES = 4                  # glTF's one joint set; FBX and Blender take more, engines often 4
#: the bone that carries the character's own eyes, teeth and tongue rigidly (the face rig moves them on)
HEAD_ORGAN_BONES = {"game_engine": "head", "default": "head", "rigify": "DEF-spine.006", "mixamo": "mixamorig:Head"}
SAFE_THETA = 1e-5
MASK_PREFIX = "mhmask-"             # MPFB2 keeps modifier masks in weight files: not bones
DEF_PREFIX = "DEF-"                 # a generated Rigify rig's deforming bones


def axis_angle_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """3x3 right-handed rotation by ``angle`` (radians) about the unit ``axis``."""
    x, y, z = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    c, s = np.cos(angle), np.sin(angle)
    t = 1.0 - c
    return np.array([[c + x * x * t, x * y * t - z * s, x * z * t + y * s],
                     [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
                     [z * x * t - y * s, z * y * t + x * s, c + z * z * t]])


def bone_matrix(head: np.ndarray, tail: np.ndarray, roll: float) -> np.ndarray:
    """A bone's rest orientation (3x3, columns X, Y, Z) from head, tail and roll, as Blender computes it."""
    direction = np.asarray(tail, np.float64) - np.asarray(head, np.float64)
    length = np.linalg.norm(direction)
    if not length > 0:
        raise UserError("a bone's head and tail coincide; the skeleton does not fit the mesh")
    x, y, z = direction / length
    theta = 1.0 + y
    if theta > SAFE_THETA:
        base = np.array([[1 - x * x / theta, x, -x * z / theta], [-x, y, -z], [-x * z / theta, z, 1 - z * z / theta]])
    else:                                          # pointing along -Y
        base = np.diag([-1.0, -1.0, 1.0])
    return axis_angle_matrix(direction / length, roll) @ base


def roll_aligning(head: np.ndarray, tail: np.ndarray, axis: str, world: np.ndarray) -> float:
    """The roll that turns the bone's ``axis`` ("X" or "Z") as close to the ``world`` direction as its
    direction allows (MPFB2's ``ALIGN_Z_WORLD_Z`` / ``ALIGN_X_WORLD_X`` roll strategies)."""
    base = bone_matrix(head, tail, 0.0)
    along = base[:, 1]
    target = np.asarray(world, np.float64) - along * float(np.dot(world, along))
    if np.linalg.norm(target) < 1e-9:
        return 0.0
    start = base[:, 0 if axis == "X" else 2]
    return float(np.arctan2(np.dot(np.cross(start, target), along), np.dot(start, target)))


@dataclass
class CharacterSkeleton:
    """An armature in the character's coordinates (module docstring)."""
    name: str
    names: list[str]
    parents: np.ndarray             # (B,) int64, -1 for roots; parents come first
    heads: np.ndarray               # (B, 3)
    tails: np.ndarray               # (B, 3)
    rolls: np.ndarray               # (B,)
    connected: np.ndarray           # (B,) bool
    rest: np.ndarray                # (B, 4, 4) armature space
    weights: dict = field(default_factory=dict)   # bone -> (vertex ids (k,), weights (k,)) of the character
    extra: dict = field(default_factory=dict)     # bone -> MPFB2's other entries (Rigify type, constraints...)
    meta: dict = field(default_factory=dict)      # the rig file's other entries (Rigify collections...)

    def index(self, bone: str) -> int:
        try:
            return self.names.index(bone)
        except ValueError:
            raise UserError(f"the {self.name} skeleton has no bone {bone!r}") from None

    def local_rest(self, bone: int) -> np.ndarray:
        """The rest frame relative to the parent's rest frame (4x4)."""
        parent = self.parents[bone]
        return self.rest[bone] if parent < 0 else np.linalg.inv(self.rest[parent]) @ self.rest[bone]

    def posed(self, basis: dict[str, np.ndarray]) -> np.ndarray:
        """Armature-space posed frames (B, 4, 4) for pose-bone ``matrix_basis`` values (others at rest)."""
        out = np.empty_like(self.rest)
        for bone, parent in enumerate(self.parents):
            local = self.local_rest(bone) @ basis.get(self.names[bone], np.eye(4))
            out[bone] = local if parent < 0 else out[parent] @ local
        return out


def local_rotation(rest: np.ndarray, parent_delta: np.ndarray, world_delta: np.ndarray) -> np.ndarray:
    """The pose bone's ``matrix_basis`` rotation (3x3) that gives the bone the armature-space rotation
    ``world_delta`` (about its head, relative to rest) when its parent already turned by ``parent_delta``."""
    frame = np.asarray(rest, np.float64)[:3, :3]
    return frame.T @ np.asarray(parent_delta).T @ np.asarray(world_delta) @ frame


def _limited(weights: dict, vertex_count: int, max_influences: int):
    """Per-vertex at most ``max_influences`` bones (the largest), renormalised to sum 1."""
    names = list(weights)
    rows, cols, vals = [], [], []
    for column, (ids, values) in enumerate(weights.values()):
        rows.append(ids)
        cols.append(np.full(len(ids), column))
        vals.append(values)
    rows, cols, vals = (np.concatenate(a) if a else np.zeros(0) for a in (rows, cols, vals))
    order = np.lexsort((-vals, rows))                # per vertex, largest weight first
    rows, cols, vals = rows[order].astype(np.int64), cols[order].astype(np.int64), vals[order]
    rank = np.arange(len(rows)) - np.searchsorted(rows, rows)
    keep = (rank < max_influences) & (vals > 0)
    rows, cols, vals = rows[keep], cols[keep], vals[keep]
    total = np.bincount(rows, vals, vertex_count)
    missing = int(np.count_nonzero(total <= 0))
    if missing:
        raise UserError(f"{missing} vertices of the character have no skin weight; the weight file does not "
                        "fit the mesh")
    vals = vals / total[rows]
    out = {}
    for column, name in enumerate(names):
        select = cols == column
        if np.any(select):
            out[name] = (rows[select], vals[select])
    return out


def build_skeleton(name: str, mesh: CharacterMesh, base_vertices: np.ndarray | None = None,
                   max_influences: int = MAX_INFLUENCES) -> CharacterSkeleton:
    """MPFB2 skeleton ``name`` placed on the character (``base_vertices``: the base mesh as reshaped, MakeHuman
    units) with its skin weights on ``mesh``'s vertices. The character's own eyes, teeth and tongue are
    weighted fully to the head bone (the face rig moves them relative to it)."""
    spec = mpfb2.read_skeleton(name, base_vertices)
    names = spec.names
    heads = mesh.point_to_character(np.array([b.head for b in spec.bones]))
    tails = mesh.point_to_character(np.array([b.tail for b in spec.bones]))
    rolls = np.array([b.roll for b in spec.bones])
    for k, bone in enumerate(spec.bones):
        if bone.roll_strategy in ("ALIGN_Z_WORLD_Z", "ALIGN_X_WORLD_X"):
            axis = bone.roll_strategy[6]
            rolls[k] = roll_aligning(heads[k], tails[k], axis, np.eye(3)["XYZ".index(axis)])
    parents = np.array([names.index(b.parent) if b.parent else -1 for b in spec.bones], np.int64)
    rest = np.tile(np.eye(4), (len(names), 1, 1))
    for k in range(len(names)):
        rest[k, :3, :3] = bone_matrix(heads[k], tails[k], rolls[k])
        rest[k, :3, 3] = heads[k]
    weights = {}
    if name in mpfb2.weight_names():
        # a Rigify meta-rig's weights are for the bones generation makes: DEF-<meta bone> and its extra bones
        deforming = set(names) | {DEF_PREFIX + n for n in names} | set(spec.meta.get("extra_bones", []))
        weights = _character_weights(name, mesh, deforming, max_influences)
    return CharacterSkeleton(name, names, parents, heads, tails, rolls, np.array([b.use_connect for b in spec.bones]),
                             rest, weights, {b.name: {"rigify": b.rigify, **b.extra} for b in spec.bones}, spec.meta)


def _character_weights(name: str, mesh: CharacterMesh, names: set[str], max_influences: int) -> dict:
    organs = np.concatenate([mesh.parts[role] for role in PARTS if role != "body"])
    is_organ = np.zeros(len(mesh.vertices), bool)
    is_organ[organs] = True
    table = {}
    for bone, (ids, values) in mpfb2.read_weights(name).items():
        if bone.startswith(MASK_PREFIX):
            continue
        if name == "rigify" and not bone.startswith(DEF_PREFIX):
            bone = DEF_PREFIX + bone          # Rigify weights name meta-rig bones; the generated rig deforms DEF-
        if bone not in names:
            raise UserError(f"the {name} weights name the bone {bone!r}, which its skeleton lacks; the rig and "
                            "weight files do not belong together")
        kept, local = mesh.local_ids(ids)
        values = values[kept]
        body = ~is_organ[local]
        if np.any(body):
            table[bone] = (local[body], values[body])
    organ_bone = HEAD_ORGAN_BONES[name]
    ids, values = table.get(organ_bone, (np.zeros(0, np.int64), np.zeros(0)))
    table[organ_bone] = (np.concatenate([ids, organs]), np.concatenate([values, np.ones(len(organs))]))
    return _limited(table, len(mesh.vertices), max_influences)
