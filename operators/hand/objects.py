# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand rigs as Blender objects (thesis 6.2.1): one collection holding the skin (the rig object: controls and
engine state, ``adapters.rig_store``), parented to it an armature whose bones are named like the WebXR hand
joints and carry the 29 bone meshes, with Limit Rotation constraints from Table 6.4, and a display of the
geometric muscles. The skin is deformed by the armature (linear blend skinning with the asset's weights);
the live simulation writes the rest-space skin that skinning turns into the simulated one.

Bone axes: Y along the bone, X the flexion axis, Z = minus the frame's abduction axis; pose bones use the Euler
order YZX, so ``rotation_euler = (flexion, s_r rotation, -s_a abduction)`` is exactly the engine's joint
rotation (``s`` the DOF's axis sign, :class:`...faces_hands_addon.hand.skeleton.Dof`).
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.hand.bake import bone_basis, unskinned
from ..adapters import controls
from ..adapters.armature import build_armature, deform_with, set_vertex_groups
from ..adapters.materials import enable_nodes
from ..adapters.meshes import mesh_from_arrays
from ..adapters.poses import simulation_key
from ..adapters.rig_store import PART_ROLE, parts, store_rig

__all__ = ["ARMATURE", "MUSCLES", "EXPORT_ROLES", "create_hand_objects", "armature_of", "rest_bone_matrices",
           "pose_armature", "push_hand_pose", "EULER_ORDER", "pose_bone_rotations", "set_corner_uvs"]

ARMATURE = "armature"
MUSCLES = "muscles"
EXPORT_ROLES = (ARMATURE,)
EULER_ORDER = "YZX"
_COLOURS = {"skin": (0.82, 0.62, 0.52), "bone": (0.88, 0.85, 0.76), "muscle": (0.75, 0.22, 0.2)}


def _material(name: str, colour):
    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
        mat.diffuse_color = (*colour, 1.0)
        enable_nodes(mat)
        bsdf = mat.node_tree.nodes.get("Principled BSDF") if mat.node_tree else None
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    return mat


def set_corner_uvs(mesh, corner_uvs: np.ndarray) -> None:
    """Per face-corner UVs (M, 3, 2) on a triangle mesh."""
    layer = mesh.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", np.ascontiguousarray(corner_uvs, dtype=np.float32).ravel())


def _armature(context, rig, name: str, collection, parent):
    arm = build_armature(context, f"{name} Armature", rig.bones(), collection, parent)
    arm[PART_ROLE] = ARMATURE
    arm.show_in_front = True
    arm.data.display_type = "OCTAHEDRAL"
    _limits(arm, rig)
    return arm


def _limits(arm, rig) -> None:
    """Limit Rotation constraints from Table 6.4 (local space, Euler YZX: x flexion, y rotation, z -abduction)."""
    sk = rig.skeleton
    for b, name in enumerate(sk.names):
        pose_bone = arm.pose.bones[name]
        pose_bone.rotation_mode = EULER_ORDER
        limit = pose_bone.constraints.new("LIMIT_ROTATION")
        limit.name = "Table 6.4"
        limit.owner_space = "LOCAL"
        limit.euler_order = EULER_ORDER
        limit.use_limit_x = limit.use_limit_y = limit.use_limit_z = True
        ranges = {"flexion": (0.0, 0.0), "abduction": (0.0, 0.0), "rotation": (0.0, 0.0)}
        for d in sk.dofs:          # the bone turns by sign * angle about the frame axis (see .skeleton)
            if d.bone == b:
                scale = -d.sign if d.kind == "abduction" else d.sign     # bone Z is minus the frame's y
                ranges[d.kind] = tuple(sorted((scale * d.lower, scale * d.upper)))
        limit.min_x, limit.max_x = ranges["flexion"]
        limit.min_y, limit.max_y = ranges["rotation"]
        limit.min_z, limit.max_z = ranges["abduction"]
        if rig.side == "left":       # the mirror image turns rotations about Y and Z the other way
            limit.min_y, limit.max_y = -limit.max_y, -limit.min_y
            limit.min_z, limit.max_z = -limit.max_z, -limit.min_z


def _bone_meshes(rig, arm, collection, name: str) -> None:
    material = _material("FH Bone", _COLOURS["bone"])
    for bone_name, (vertices, faces) in rig.bone_meshes().items():
        bone = arm.data.bones[bone_name]
        mesh = mesh_from_arrays(f"{name} {bone_name}", vertices, faces)
        mesh.materials.append(material)
        obj = bpy.data.objects.new(f"{name} Bone {bone_name}", mesh)
        collection.objects.link(obj)
        obj.parent = arm
        obj.parent_type = "BONE"
        obj.parent_bone = bone_name
        at_tail = Matrix(bone.matrix_local) @ Matrix.Translation((0.0, bone.length, 0.0))
        obj.matrix_parent_inverse = at_tail.inverted()
        obj[PART_ROLE] = f"bone.{bone_name}"


def _muscle_display(rig, name, collection, parent):
    rest = rig.rest_pose().positions["muscles"]
    mesh = mesh_from_arrays(f"{name} Muscles", rest, rig.muscle_quads())
    mesh.materials.append(_material("FH Hand Muscle", _COLOURS["muscle"]))
    obj = bpy.data.objects.new(f"{name} Muscles", mesh)
    collection.objects.link(obj)
    obj.parent = parent
    obj[PART_ROLE] = MUSCLES
    obj.hide_render = True
    obj.display_type = "WIRE"
    return obj


def create_hand_objects(context, rig, name: str = "FH Hand"):
    """Collection, skin (rig object), armature with bone meshes and limits, muscle display; returns the skin."""
    collection = bpy.data.collections.new(name)
    context.scene.collection.children.link(collection)
    mesh = mesh_from_arrays(f"{name} Skin", rig.rest_positions, rig.faces)
    set_corner_uvs(mesh, rig.corner_uvs)
    mesh.materials.append(_material("FH Hand Skin", _COLOURS["skin"]))
    skin = bpy.data.objects.new(name, mesh)
    collection.objects.link(skin)
    arm = _armature(context, rig, name, collection, skin)
    _bone_meshes(rig, arm, collection, name)
    set_vertex_groups(skin, rig.skeleton.names, rig.skin_weights())
    deform_with(skin, arm)
    _muscle_display(rig, name, collection, skin)
    controls.ensure_controls(skin, rig.control_specs())
    store_rig(skin, rig)
    return skin


def armature_of(obj):
    return parts(obj).get(ARMATURE)


def rest_bone_matrices(arm, names) -> np.ndarray:
    return np.array([np.array(arm.data.bones[n].matrix_local) for n in names])


def pose_armature(arm, rig, transforms_by_bone: dict) -> None:
    """Set every pose bone so the armature shows the engine's rest -> pose transforms."""
    names = rig.skeleton.names
    transforms = np.array([transforms_by_bone[n] for n in names])
    basis = bone_basis(rest_bone_matrices(arm, names), rig.skeleton.parent, transforms)
    for name, matrix in zip(names, basis):
        pose_bone = arm.pose.bones[name]
        pose_bone.rotation_euler = Matrix(matrix.tolist()).to_euler(EULER_ORDER)
        pose_bone.location = (0.0, 0.0, 0.0)


def push_hand_pose(obj, rig, pose=None) -> None:
    """Live-preview hook: pose the armature and write the rest-space simulated skin (so skinning reproduces
    the simulation) into the skin's simulation key; ``pose``: one the rig returned earlier (default: now)."""
    arm = armature_of(obj)
    if arm is None:
        return
    pose = rig.pose() if pose is None else pose
    pose_armature(arm, rig, pose.transforms)
    transforms = np.array([pose.transforms[n] for n in rig.skeleton.names])
    rest_space = unskinned(rig, pose.positions["skin"].astype(np.float64), transforms)
    key = simulation_key(obj)
    key.points.foreach_set("co", np.ascontiguousarray(rest_space, dtype=np.float32).ravel())
    obj.data.update()


def pose_bone_rotations(arm, rig) -> dict[str, np.ndarray]:
    """Each bone's local rotation (3x3, armature axes, relative to its parent at rest) as the artist posed it."""
    out = {}
    mirror = np.diag([-1.0, 1.0, 1.0]) if rig.side == "left" else np.eye(3)
    for name in rig.skeleton.names:
        bone = arm.data.bones[name]
        rest = np.array(bone.matrix_local)[:3, :3]
        basis = np.array(arm.pose.bones[name].matrix_basis)[:3, :3]
        out[name] = mirror @ (rest @ basis @ rest.T) @ mirror
    return out
