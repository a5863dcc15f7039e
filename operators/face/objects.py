# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rigs as Blender objects: one collection holding the skin object (the rig object: controls and
engine state, ``adapters.rig_store``) and, parented to it, skull, jaw, eyes, teeth, tongue and a muscle-fibre
display coloured by contraction; materials; the wrinkle shading.
"""
from __future__ import annotations

import bpy
import numpy as np

from ..adapters import controls
from ..adapters.materials import enable_nodes
from ..adapters.meshes import mesh_from_arrays
from ..adapters.rig_store import PART_ROLE, parts, store_rig
from ...faces_hands_addon.face.appearance import skin_colours

__all__ = ["EXPORT_ROLES", "create_rig_objects", "update_muscle_display", "set_wrinkle_drivers",
           "muscle_display_arrays"]

#: the parts a game engine gets with the skin (skull, jaw and the muscle display are helpers)
EXPORT_ROLES = ("eye_L", "eye_R", "teeth_upper", "teeth_lower", "tongue")


# ---------------------------------------------------------------------------- materials
def _material(name: str, colour, roughness=0.5, subsurface=0.0):
    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
        enable_nodes(mat)
        bsdf = mat.node_tree.nodes.get("Principled BSDF")
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
            bsdf.inputs["Roughness"].default_value = roughness
            if subsurface and "Subsurface Weight" in bsdf.inputs:
                bsdf.inputs["Subsurface Weight"].default_value = subsurface
        mat.diffuse_color = (*colour, 1.0)
    return mat


PART_COLOURS = {
    "skin": ((0.80, 0.58, 0.47), 0.45, 0.2), "bone": ((0.85, 0.82, 0.72), 0.6, 0.0),
    "sclera": ((0.93, 0.92, 0.90), 0.2, 0.0), "iris": ((0.25, 0.38, 0.55), 0.3, 0.0),
    "pupil": ((0.02, 0.02, 0.02), 0.2, 0.0), "tooth": ((0.92, 0.90, 0.82), 0.3, 0.0),
    "gum": ((0.75, 0.35, 0.38), 0.4, 0.0), "tongue": ((0.78, 0.36, 0.38), 0.5, 0.1),
}


PAINT_ATTRIBUTE = "FH Skin Paint"


def _painted_skin_material():
    """The default head's skin: base colour from the per-node paint (brows, lips), exported as glTF COLOR_0."""
    mat = bpy.data.materials.get("FH Painted Skin")
    if mat is None:
        mat = _material("FH Painted Skin", *PART_COLOURS["skin"])
        nodes = mat.node_tree.nodes
        shader = nodes.get("Principled BSDF")
        attribute = nodes.new("ShaderNodeAttribute")
        attribute.attribute_name = PAINT_ATTRIBUTE
        if shader is not None:
            mat.node_tree.links.new(attribute.outputs["Color"], shader.inputs["Base Color"])
    return mat


def _paint_skin(obj, rig) -> bool:
    """Brows and lips painted onto a generated skin (``face.appearance``); False when the rig's skin nodes
    are not this mesh's vertices (nothing is changed then)."""
    skin = getattr(getattr(rig, "template", None), "skin", None)
    mesh = obj.data
    if skin is None or len(skin.vertices) != len(mesh.vertices):
        return False
    rgba = np.ones((len(mesh.vertices), 4), np.float32)
    rgba[:, :3] = skin_colours(skin)
    attribute = mesh.color_attributes.new(PAINT_ATTRIBUTE, "FLOAT_COLOR", "POINT")
    attribute.data.foreach_set("color", rgba.ravel())
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = list(mesh.color_attributes).index(attribute)
    mesh.materials.append(_painted_skin_material())
    return True


def _assign_materials(obj, labels, face_material) -> None:
    for label in labels:
        colour, rough, sss = PART_COLOURS.get(label, ((0.7, 0.7, 0.7), 0.5, 0.0))
        obj.data.materials.append(_material(f"FH {label.title()}", colour, rough, sss))
    if len(labels) > 1:
        obj.data.polygons.foreach_set("material_index", np.asarray(face_material, dtype=np.int32))


# ---------------------------------------------------------------------------- building objects
def _new_part(name, role, vertices, faces, collection, parent, labels=("bone",), face_material=None):
    mesh = mesh_from_arrays(name, vertices, faces)
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    obj.parent = parent
    obj[PART_ROLE] = role
    _assign_materials(obj, labels, face_material if face_material is not None else np.zeros(len(faces)))
    return obj


def muscle_display_arrays(rig):
    """Vertices, edges and per-vertex contraction of all muscle fibres, for one edges-only mesh."""
    vertices, edges, contraction = [], [], []
    offset = 0
    for _name, line, value in rig.muscle_fibres():
        count = len(line)
        vertices.append(line)
        edges.append(np.column_stack([np.arange(count - 1), np.arange(1, count)]) + offset)
        contraction.append(np.full(count, value, dtype=np.float32))
        offset += count
    if not vertices:
        return np.zeros((0, 3), np.float32), np.zeros((0, 2), np.int32), np.zeros(0, np.float32)
    return np.concatenate(vertices), np.concatenate(edges).astype(np.int32), np.concatenate(contraction)


def _contraction_colours(contraction: np.ndarray) -> np.ndarray:
    """Relaxed muscles dark red, fully contracted bright yellow (RGBA per vertex)."""
    c = np.clip(contraction, 0.0, 1.0)[:, None]
    relaxed, contracted = np.array([0.45, 0.05, 0.05, 1.0]), np.array([1.0, 0.85, 0.1, 1.0])
    return (relaxed * (1 - c) + contracted * c).astype(np.float32)


def _muscle_object(rig, name, collection, parent):
    vertices, edges, contraction = muscle_display_arrays(rig)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.tolist(), edges.tolist(), [])
    colours = mesh.color_attributes.new("contraction", "FLOAT_COLOR", "POINT")
    colours.data.foreach_set("color", _contraction_colours(contraction).ravel())
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    obj.parent = parent
    obj[PART_ROLE] = "muscles"
    obj.show_in_front = True
    return obj


def create_rig_objects(context, rig, name: str = "FH Head", skin_obj=None):
    """Make the collection and objects of a new rig; returns the skin (rig) object."""
    collection = bpy.data.collections.new(name)
    context.scene.collection.children.link(collection)
    if skin_obj is None:
        mesh = mesh_from_arrays(f"{name} Skin", rig.rest_positions, rig.faces,
                                getattr(rig, "skin_uvs", None))
        skin_obj = bpy.data.objects.new(name, mesh)
        collection.objects.link(skin_obj)
        if not _paint_skin(skin_obj, rig):
            _assign_materials(skin_obj, ("skin",), np.zeros(len(rig.faces)))
    else:
        collection.objects.link(skin_obj)
    for bone, (vertices, faces) in rig.bone_meshes().items():
        part = _new_part(f"{name} {bone.title()}", bone, vertices, faces, collection, skin_obj)
        part.hide_render = True
        part.display_type = "WIRE"
        part.hide_set(True)
    for key, part_mesh in rig.part_meshes().items():
        _new_part(f"{name} {key.replace('_', ' ').title()}", key, part_mesh.vertices, part_mesh.faces,
                  collection, skin_obj, part_mesh.labels, part_mesh.face_material)
    muscles = _muscle_object(rig, f"{name} Muscles", collection, skin_obj)
    muscles.hide_render = True
    controls.ensure_controls(skin_obj, rig.control_specs())
    store_rig(skin_obj, rig)
    return skin_obj


def update_muscle_display(obj, rig) -> None:
    """Move the muscle-fibre display to the rig's current muscle state (a live-preview hook)."""
    part = parts(obj).get("muscles")
    if part is None:
        return
    points, contraction = rig.muscle_display()
    if not len(points) or len(points) != len(part.data.vertices):
        return
    part.data.vertices.foreach_set("co", points.ravel())
    key = (part.session_uid, part.data.as_pointer())
    if not np.array_equal(_SHOWN_CONTRACTION.get(key), contraction):     # colours only when a muscle changed
        part.data.color_attributes["contraction"].data.foreach_set("color", _contraction_colours(contraction).ravel())
        _SHOWN_CONTRACTION[key] = contraction
    part.data.update()


#: (muscle display object, its mesh) -> the contractions its colours show (the live tick skips unchanged ones)
_SHOWN_CONTRACTION: dict[tuple[int, int], np.ndarray] = {}


def set_wrinkle_drivers(obj, rig) -> None:
    """Expressive wrinkles (3.1.2): bump strength per region driven by its muscles' mixed contractions."""
    from ...faces_hands_addon.face.rig import WRINKLE_DRIVERS
    from .wrinkles import setup_wrinkle_material
    setup_wrinkle_material(obj, rig.wrinkle_masks(), WRINKLE_DRIVERS, rig.control_specs())
