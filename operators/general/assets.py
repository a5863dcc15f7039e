# SPDX-License-Identifier: GPL-3.0-or-later
"""Default assets as Blender objects."""
from __future__ import annotations

import bpy

from ..adapters.meshes import mesh_from_arrays, object_from_mesh


def add_default_head_assets(scene: bpy.types.Scene) -> bpy.types.Collection:
    from ...faces_hands_addon import assets

    face = assets.canonical_face()
    collection = bpy.data.collections.new("FH Default Assets")
    scene.collection.children.link(collection)
    object_from_mesh(mesh_from_arrays("FH Canonical Face", face.vertices, face.faces,
                                      getattr(face, "uvs", None)), collection)
    for name, mesh in (("FH Skull", assets.skull()), ("FH Jaw", assets.jaw())):
        object_from_mesh(mesh_from_arrays(name, mesh.vertices, mesh.faces), collection)
    return collection
