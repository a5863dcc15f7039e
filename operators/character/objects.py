# SPDX-License-Identifier: GPL-3.0-or-later
"""The character as Blender objects: one collection holding the armature (the root, standard for game
engines and retargeting tools) and, parented to it, the body mesh (quads, UVs, materials, one vertex group
per deforming bone, an Armature modifier). The body mesh becomes the rig object once the character rig is
stored on it (``common.rig_store``): its shape keys are the face's, its controls the character's.
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Vector

from ...faces_hands_addon.anim.layers import weighted_driver
from ...faces_hands_addon.character.head import WIDE
from ..adapters import controls
from ..adapters.rig_store import PART_ROLE, store_rig
from . import materials

__all__ = ["ARMATURE_ROLE", "create_character_objects", "create_armature", "armature_of", "body_mesh",
           "head_drivers"]

ARMATURE_ROLE = "character_armature"
SUBDIVISION = "Subdivision"


def body_mesh(name: str, mesh) -> bpy.types.Mesh:
    """A Blender mesh of the engine's :class:`CharacterMesh` (quads, per-corner UVs, material slots)."""
    data = bpy.data.meshes.new(name)
    quads = np.ascontiguousarray(mesh.quads, dtype=np.int32)
    data.vertices.add(len(mesh.vertices))
    data.vertices.foreach_set("co", np.ascontiguousarray(mesh.vertices, dtype=np.float32).ravel())
    data.loops.add(quads.size)
    data.loops.foreach_set("vertex_index", quads.ravel())
    data.polygons.add(len(quads))
    data.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.int32))
    data.polygons.foreach_set("use_smooth", np.ones(len(quads), dtype=bool))
    data.polygons.foreach_set("material_index", np.ascontiguousarray(mesh.material_index, dtype=np.int32))
    layer = data.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", np.ascontiguousarray(mesh.corner_uvs, dtype=np.float32).ravel())
    data.update(calc_edges=True)
    data.validate(clean_customdata=False)
    return data


def create_armature(context, skeleton, name: str, collection):
    """An armature object of the engine's :class:`CharacterSkeleton` (edit bones: head, tail, roll, parent)."""
    data = bpy.data.armatures.new(f"{name} Armature")
    arm = bpy.data.objects.new(f"{name} Armature", data)
    collection.objects.link(arm)
    arm[PART_ROLE] = ARMATURE_ROLE
    data.display_type = "OCTAHEDRAL"
    view_layer = context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        for k, bone_name in enumerate(skeleton.names):
            bone = data.edit_bones.new(bone_name)
            bone.head, bone.tail = Vector(skeleton.heads[k]), Vector(skeleton.tails[k])
            bone.roll = float(skeleton.rolls[k])
            if skeleton.parents[k] >= 0:
                bone.parent = data.edit_bones[skeleton.names[skeleton.parents[k]]]
                bone.use_connect = bool(skeleton.connected[k])
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
        view_layer.objects.active = previous
    return arm


def _weights(obj, skeleton) -> None:
    """One vertex group per weighted bone (engine weights: at most a few influences, summing to 1)."""
    for bone, (ids, values) in skeleton.weights.items():
        group = obj.vertex_groups.new(name=bone)
        for index, value in zip(ids.tolist(), values.tolist()):
            group.add([index], value, "REPLACE")


def create_character_objects(context, rig, name: str = "FH Character"):
    """Collection, armature (root) and body mesh (its child, skinned, the rig object: controls, engine state,
    head drivers) of the character rig ``rig``; returns (armature, body)."""
    character = rig.character
    collection = bpy.data.collections.new(name)
    context.scene.collection.children.link(collection)
    arm = create_armature(context, character.skeleton, name, collection)
    chain = None
    if character.skeleton.name == "rigify":          # the meta-rig, generated into a Rigify control rig
        from ...faces_hands_addon.character.head import HEAD_CHAINS
        from .rigify import META_ROLE, generate_rigify
        arm[PART_ROLE] = META_ROLE
        arm = generate_rigify(context, arm, character.skeleton, name)
        arm[PART_ROLE] = ARMATURE_ROLE
        chain = HEAD_CHAINS["rigify"]
    body = bpy.data.objects.new(name, body_mesh(f"{name} Body", character.mesh))
    collection.objects.link(body)
    body.parent = arm
    for material in materials.character_materials():
        body.data.materials.append(material)
    _weights(body, character.skeleton)
    if character.mesh.brows is not None:
        paint = body.data.attributes.new(materials.BROW_ATTRIBUTE, "FLOAT", "POINT")
        paint.data.foreach_set("value", np.ascontiguousarray(character.mesh.brows, dtype=np.float32))
    modifier = body.modifiers.new("Armature", "ARMATURE")
    modifier.object = arm
    subdivision = body.modifiers.new(SUBDIVISION, "SUBSURF")
    subdivision.levels, subdivision.render_levels = 0, 1       # renders smooth, the viewport stays fast
    controls.ensure_controls(body, rig.control_specs())
    store_rig(body, rig)
    head_drivers(body, arm, rig, chain)
    return arm, body


def head_drivers(body, arm, rig, chain=None) -> None:
    """The neck and head bones' Euler angles driven by the mixed head controls (``character.head``); with
    ``chain``, that chain's bones of ``arm`` (a generated Rigify rig's controls) with their own rest frames."""
    from ...faces_hands_addon.character.head import bone_terms
    specs = rig.control_specs()
    drivers = []
    terms = rig.terms if chain is None else bone_terms(rig.character.skeleton, chain, {
        bone: np.array(arm.data.bones[bone].matrix_local)[:3, :3] for bone, _ in chain})
    for bone, axes in terms.items():
        pose_bone = arm.pose.bones[bone]
        pose_bone.rotation_mode = "XYZ"
        for index, terms in enumerate(axes):
            if not terms:
                continue
            used = [control for control, _ in terms]
            expression = weighted_driver(terms, specs, -WIDE, WIDE, controls.available_layers(body, used))
            drivers.append(controls.add_mixed_driver(pose_bone, "rotation_euler", body, expression, index))
    bpy.context.view_layer.update()
    for driver in drivers:                # evaluated while the rig was being set up; compiled again now
        driver.expression = driver.expression


def armature_of(body):
    """The armature that deforms ``body`` (its Armature modifier's object), or None."""
    for modifier in getattr(body, "modifiers", ()):
        if modifier.type == "ARMATURE" and modifier.object is not None:
            return modifier.object
    return None
