# SPDX-License-Identifier: GPL-3.0-or-later
"""The default character's body from the MPFB2 data (:mod:`.mpfb2`): the base mesh without its helper
geometry (tights, skirt, hair, genital and lash helpers, joint cubes), keeping the body and the base mesh's
own eyes, teeth and tongue, in this project's convention (metres, Z up, face along -Y, +X the character's
left) with the soles on the ground (Z = 0) and the body centred on X = 0.

Every vertex keeps the id it has in the base mesh (``base_index``), so MPFB2's targets, skin weights and
mirror table apply through it (:meth:`CharacterMesh.from_base`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError
from . import mpfb2

__all__ = ["PARTS", "MATERIALS", "CharacterMesh", "character_mesh", "HEAD_FRACTION"]

#: role -> the base mesh's face groups it is made of (the character's own eyes, teeth and tongue)
PARTS = {
    "body": ("body",),
    "eye_L": ("helper-l-eye",),
    "eye_R": ("helper-r-eye",),
    "teeth_upper": ("helper-upper-teeth",),
    "teeth_lower": ("helper-lower-teeth",),
    "tongue": ("helper-tongue",),
}
#: material slots, and the part each role's faces use
MATERIALS = ("skin", "eye", "teeth", "tongue")
PART_MATERIAL = {"body": "skin", "eye_L": "eye", "eye_R": "eye", "teeth_upper": "teeth", "teeth_lower": "teeth",
                 "tongue": "tongue"}
HEAD_FRACTION = 0.84        # the head and neck: above this fraction of the body's height (the face fit's input)


@dataclass
class CharacterMesh:
    """The character's mesh (module docstring): quads, per-corner UVs, one material index per face."""
    vertices: np.ndarray          # (n, 3) float64, metres, Z up, face along -Y
    quads: np.ndarray             # (F, 4) int64 ids into ``vertices``
    corner_uvs: np.ndarray        # (F, 4, 2) float32
    material_index: np.ndarray    # (F,) int64 into :data:`MATERIALS`
    base_index: np.ndarray        # (n,) int64: each vertex's id in the MPFB2 base mesh
    parts: dict = field(default_factory=dict)   # role -> vertex ids (:data:`PARTS`)
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))  # added after :func:`mpfb2.to_fh`
    brows: np.ndarray | None = None             # (n,) eyebrow paint in [0, 1] (``character.fitting.brow_paint``)

    @property
    def triangles(self) -> np.ndarray:
        """The quads split along their 0-2 diagonal (M, 3) int64."""
        q = self.quads
        return np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1).reshape(-1, 3)

    def from_base(self, points: np.ndarray) -> np.ndarray:
        """Base-mesh points (19158, 3) in MakeHuman units -> this mesh's vertices (n, 3) in its coordinates
        (e.g. the base mesh with targets applied)."""
        return mpfb2.to_fh(np.asarray(points)[self.base_index]) + self.offset

    def point_to_character(self, points: np.ndarray) -> np.ndarray:
        """Any MakeHuman-space points (k, 3) -> the character's coordinates."""
        return mpfb2.to_fh(points) + self.offset

    def local_ids(self, base_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(kept, local): which of ``base_ids`` are vertices of this mesh, and their local ids."""
        lookup = np.full(mpfb2.VERTEX_COUNT, -1, np.int64)
        lookup[self.base_index] = np.arange(len(self.base_index))
        local = lookup[np.asarray(base_ids, np.int64)]
        kept = local >= 0
        return kept, local[kept]

    def head_vertices(self) -> np.ndarray:
        """Ids of the head and neck (above :data:`HEAD_FRACTION` of the height) plus the eyes, teeth and
        tongue: the part the face rig is fitted to."""
        body = self.parts["body"]
        low, high = self.vertices[body, 2].min(), self.vertices[body, 2].max()
        above = body[self.vertices[body, 2] > low + HEAD_FRACTION * (high - low)]
        organs = [self.parts[r] for r in PARTS if r != "body"]
        return np.unique(np.concatenate([above, *organs]))


def character_mesh(base_vertices: np.ndarray | None = None) -> CharacterMesh:
    """The character's mesh from the base mesh (or from ``base_vertices`` (19158, 3), the base mesh reshaped
    by targets, MakeHuman units): the faces of :data:`PARTS`, unused vertices dropped, converted and grounded."""
    mesh = mpfb2.base_mesh()
    source = mesh.vertices if base_vertices is None else np.asarray(base_vertices, np.float64)
    if source.shape != mesh.vertices.shape or not np.all(np.isfinite(source)):
        raise UserError(f"the character is built on {mpfb2.VERTEX_COUNT} finite base-mesh vertices")
    face_ids, face_material, face_role = [], [], []
    for role, groups in PARTS.items():
        ids = mesh.faces_in(*groups)
        if not len(ids):
            raise UserError(f"the MPFB2 base mesh has no faces in {groups}; run `make assets` again")
        face_ids.append(ids)
        face_material.append(np.full(len(ids), MATERIALS.index(PART_MATERIAL[role])))
        face_role.append(np.full(len(ids), list(PARTS).index(role)))
    face_ids = np.concatenate(face_ids)
    quads_base = mesh.quads[face_ids]
    base_index = np.unique(quads_base)
    lookup = np.full(mpfb2.VERTEX_COUNT, -1, np.int64)
    lookup[base_index] = np.arange(len(base_index))
    vertices = mpfb2.to_fh(source[base_index])
    role_of_face = np.concatenate(face_role)
    quads = lookup[quads_base]
    parts = {role: np.unique(quads[role_of_face == k]) for k, role in enumerate(PARTS)}
    body = vertices[parts["body"]]
    offset = np.array([-0.5 * (body[:, 0].min() + body[:, 0].max()), 0.0, -body[:, 2].min()])
    corner_uvs = mesh.uvs[mesh.quad_uvs[face_ids]].astype(np.float32)
    return CharacterMesh(vertices + offset, quads, corner_uvs, np.concatenate(face_material), base_index, parts,
                         offset)
