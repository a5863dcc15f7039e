# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rigs as Blender data: the objects of a rig, its stored engine state, and pushing poses.

A rig is one collection holding the **skin object** (the rig object: it carries the controls and the
engine state) and, parented to it, skull, jaw, eyes, teeth, tongue and a muscle-fibre display. The
engine ``FaceRig`` is stored in the skin object as the bytes of ``FaceRig.save`` (an ``.npz`` without
pickles) and rebuilt on demand, once per session (cached).
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile

import bpy
import numpy as np
from mathutils import Matrix

from ..faces_hands_addon.errors import UserError
from . import bl_controls
from .bl_mesh import mesh_from_arrays

RIG_MARKER = "fh_rig"
RIG_DATA = "fh_rig_data"
RIG_CONTROLS = "fh_rig_controls"   # JSON: [[name, region, kind], ...] for the panel (no engine needed)
HEAD_TO_LOCAL = "fh_head_to_local"  # 16 floats (row-major): rig output coordinates -> the skin's local space
SIM_KEY = "FH Simulation"
PART_ROLE = "fh_part"        # on every part object: "skull", "jaw", "eye_L", ..., "muscles"

_rig_cache: dict[int, tuple[str, object]] = {}


# ---------------------------------------------------------------------------- engine state
def rig_bytes(rig) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "rig.npz")
        rig.save(path)
        with open(path, "rb") as handle:
            return handle.read()


def store_rig(obj, rig) -> None:
    data = rig_bytes(rig)
    obj[RIG_DATA] = data
    obj[RIG_MARKER] = 1
    _rig_cache[obj.session_uid] = (hashlib.sha1(data).hexdigest(), rig)


def get_rig(obj):
    """The engine ``FaceRig`` of a rig object (rebuilt from its stored bytes once per session)."""
    from ..faces_hands_addon.face.rig import FaceRig
    if obj is None or not obj.get(RIG_MARKER) or RIG_DATA not in obj.keys():
        raise UserError("select a Faces & Hands face rig (build one with 'Build Face Rig')")
    data = bytes(obj[RIG_DATA])
    digest = hashlib.sha1(data).hexdigest()
    cached = _rig_cache.get(obj.session_uid)
    if cached is not None and cached[0] == digest:
        return cached[1]
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "rig.npz")
        with open(path, "wb") as handle:
            handle.write(data)
        rig = FaceRig.load(path)
    _rig_cache[obj.session_uid] = (digest, rig)
    return rig


def is_rig(obj) -> bool:
    return obj is not None and obj.type == "MESH" and bool(obj.get(RIG_MARKER))


def rig_of(obj):
    """The rig (skin) object for ``obj`` itself or one of its parts."""
    while obj is not None and not is_rig(obj):
        obj = obj.parent
    return obj


# ---------------------------------------------------------------------------- controls
def ensure_controls(obj, rig) -> None:
    """Every control in every layer (``fh.ctrl.*`` at its default, the other layers at 0), so drivers
    and F-curves can always refer to them."""
    for layer in bl_controls.LAYERS:
        for name, spec in rig.control_specs().items():
            default = spec.default if layer == "ctrl" else 0.0
            doc = spec.doc if layer == "ctrl" else f"{layer} layer of {name} (added to the control)"
            bl_controls.ensure_property(obj, name, layer, spec.minimum, spec.maximum, default, doc)
    obj[RIG_CONTROLS] = json.dumps([[name, spec.region, spec.kind] for name, spec in rig.control_specs().items()])


def control_ranges(rig) -> dict[str, tuple[float, float]]:
    return {name: (spec.minimum, spec.maximum) for name, spec in rig.control_specs().items()}


def read_controls(obj, rig) -> dict[str, float]:
    """Effective control values now (sum of layers, clamped), as animated at the current frame."""
    return bl_controls.effective_values(obj, control_ranges(rig))


def reset_controls(obj, rig) -> None:
    for name, spec in rig.control_specs().items():
        key = bl_controls.prop_name(name, "ctrl")
        if key in obj.keys():
            obj[key] = float(spec.default)


# ---------------------------------------------------------------------------- materials
def _material(name: str, colour, roughness=0.5, subsurface=0.0):
    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
        if bpy.app.version < (5, 0, 0):
            mat.use_nodes = True
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
    ensure_controls(skin_obj, rig)
    store_rig(skin_obj, rig)
    return skin_obj


def parts(obj) -> dict[str, bpy.types.Object]:
    return {child[PART_ROLE]: child for child in obj.children if PART_ROLE in child.keys()}


# ---------------------------------------------------------------------------- pushing a pose
def head_to_local(obj, rig) -> np.ndarray:
    """4x4 from the rig's output coordinates to ``obj``'s local coordinates: identity for the default
    head, ``inv(M0)`` for a rig fitted to a mesh in world space (see ``bl_fit``)."""
    stored = obj.get(HEAD_TO_LOCAL)
    if stored is not None and len(stored) == 16:
        return np.array(stored, dtype=np.float64).reshape(4, 4)
    return np.eye(4)


def rig_to_world(obj, rig, points) -> np.ndarray:
    """Points in the rig's output coordinates -> world coordinates now (the object may have moved)."""
    matrix = np.asarray(obj.matrix_world, dtype=np.float64) @ head_to_local(obj, rig)
    return np.asarray(points, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]


def skin_to_local(obj, rig, positions) -> np.ndarray:
    """Skin positions from head space into the skin object's local space, float32 for foreach_set."""
    matrix = head_to_local(obj, rig)
    positions = np.asarray(positions, dtype=np.float64)
    if np.abs(matrix - np.eye(4)).max() < 1e-12:
        return np.ascontiguousarray(positions, dtype=np.float32)
    return np.ascontiguousarray(positions @ matrix[:3, :3].T + matrix[:3, 3], dtype=np.float32)


def simulation_key(obj):
    """The dedicated shape key the live simulation writes (created with a Basis if needed)."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.data.shape_keys.key_blocks.get(SIM_KEY)
    if key is None:
        key = obj.shape_key_add(name=SIM_KEY, from_mix=False)
    key.value = 1.0
    return key


def push_pose(obj, rig, positions=None) -> None:
    """Write skin positions into the simulation key and move eyes, jaw, teeth, tongue and muscles."""
    key = simulation_key(obj)
    positions = rig.positions if positions is None else positions
    key.points.foreach_set("co", skin_to_local(obj, rig, positions).ravel())
    obj.data.update()
    transforms = rig.rigid_transforms()
    for role, part in parts(obj).items():
        if role in transforms:
            part.matrix_basis = Matrix(np.asarray(transforms[role], dtype=float).tolist())
        elif role == "muscles":
            vertices, _edges, contraction = muscle_display_arrays(rig)
            if len(vertices) == len(part.data.vertices):
                part.data.vertices.foreach_set("co", vertices.astype(np.float32).ravel())
                part.data.color_attributes["contraction"].data.foreach_set(
                    "color", _contraction_colours(contraction).ravel())
                part.data.update()


def set_wrinkle_drivers(obj, rig) -> None:
    """Expressive wrinkles (3.1.2): bump strength per region driven by its muscles' contractions."""
    from ..faces_hands_addon.face.rig import WRINKLE_DRIVERS
    from . import bl_wrinkles
    bl_wrinkles.setup_wrinkle_material(obj, rig.wrinkle_masks(), WRINKLE_DRIVERS)
