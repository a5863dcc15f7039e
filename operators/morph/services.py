# SPDX-License-Identifier: GPL-3.0-or-later
"""The morphable-face services (thesis 3.2, 5.1) for operators, commands and other subsystems: morph face
objects, their edit state, the model they use, and the hand-over to the face rig ("Make Animatable").

A morph face object is a mesh on the model's topology with a per-vertex colour attribute (``FH Albedo``);
it stores which model it uses (``fh_morph_model``: ``default`` or a file) and its edit state
(``fh_morph_state``: the JSON of :meth:`EditFace.state`). The engine face is cached once per session and
rebuilt by replaying the stored state whenever it differs (Blender undo, another file)."""
from __future__ import annotations

import json
from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.foreign_files import read_text
from ...faces_hands_addon.morph.editing import EditFace, face_from_state
from ...faces_hands_addon.morph.heads import TOPOLOGY as HEAD_TOPOLOGY, albedo as head_albedo
from ...faces_hands_addon.morph.segments import hierarchy_order
from ..adapters.materials import enable_nodes
from ..adapters.meshes import mesh_from_arrays, object_from_mesh
from ...names import MORPH_CHARACTER, MORPH_EXAMPLES, MORPH_HISTORY, MORPH_MARKER, MORPH_MODEL, MORPH_STATE

__all__ = ["MORPH_MARKER", "DEFAULT", "model_for", "create_face_object", "face_of", "morph_object",
           "write_face", "apply", "sync_panel", "save_face", "load_face", "segment_colours", "make_animatable",
           "link_character", "write_character"]

MODEL_KEY, STATE_KEY, EXAMPLES_KEY, HISTORY_KEY = MORPH_MODEL, MORPH_STATE, MORPH_EXAMPLES, MORPH_HISTORY
ALBEDO = "FH Albedo"
MASK = "FH Segments"
DEFAULT = "default"
MASK_MODEL = "mask"
MAX_FACE_BYTES = 50_000_000      # a saved face is its edit history: kilobytes

_models: dict[str, object] = {}
_faces: dict[int, tuple[str, EditFace]] = {}


def model_for(source: str = DEFAULT):
    """The model of ``source`` (``default``: the whole heads on the character's topology; ``mask``: the
    synthetic 468-vertex face mask; or a model file), loaded once per session."""
    if source in _models:
        return _models[source]
    key = source if source in ("", DEFAULT, MASK_MODEL) else str(Path(bpy.path.abspath(source)).resolve())
    key = key or DEFAULT
    if key not in _models:
        if key == DEFAULT:
            from ...faces_hands_addon.morph.heads import head_model
            _models[key] = head_model()
        elif key == MASK_MODEL:
            from ...faces_hands_addon.morph.population import default_model
            _models[key] = default_model()
        else:
            from ...faces_hands_addon.morph.loaders import load_model
            _models[key] = load_model(key)
    return _models[key]


def remember_model(key: str, model) -> None:
    """Keep a model built in this session (e.g. from meshes) under ``key``."""
    _models[key] = model


def morph_object(obj):
    """The morph face object ``obj`` (or None)."""
    return obj if obj is not None and obj.get(MORPH_MARKER) else None


def _material(name: str):
    material = bpy.data.materials.get(name)
    if material is None:
        material = bpy.data.materials.new(name)
        enable_nodes(material)
        nodes = material.node_tree.nodes
        shader = nodes.get("Principled BSDF")
        attribute = nodes.new("ShaderNodeAttribute")
        attribute.attribute_name = ALBEDO
        if shader is not None:
            material.node_tree.links.new(attribute.outputs["Color"], shader.inputs["Base Color"])
            shader.inputs["Roughness"].default_value = 0.6
    return material


def create_face_object(context, source: str = DEFAULT, kind: str = "average", seed: int = 0, index: int = 0,
                       name: str = "FH Morph Face"):
    """A new morph face object (average, random with ``seed``, or database example ``index``)."""
    model = model_for(source)
    face = EditFace(model)
    face.create(kind, seed=seed, index=index)
    mesh = mesh_from_arrays(name, face.shape, model.triangles, model.uvs)
    obj = object_from_mesh(mesh, context.scene.collection, name)
    obj[MORPH_MARKER] = 1
    obj[MODEL_KEY] = source or DEFAULT
    obj[EXAMPLES_KEY] = json.dumps([[i, name, labels] for i, (name, labels)
                                    in enumerate(zip(model.example_names, model.example_labels))])
    mesh.color_attributes.new(ALBEDO, "FLOAT_COLOR", "POINT")
    mesh.color_attributes.new(MASK, "FLOAT_COLOR", "POINT")
    _show_colours(mesh, ALBEDO)
    mesh.materials.append(_material("FH Morph Skin"))
    previous = morph_object(context.view_layer.objects.active)
    if previous is not None and previous.get(MORPH_CHARACTER) and previous.get(MODEL_KEY) == obj[MODEL_KEY]:
        obj[MORPH_CHARACTER] = previous[MORPH_CHARACTER]      # a new face keeps reshaping the same character
    write_face(obj, face)
    sync_panel(obj, face)
    for other in context.view_layer.objects.selected:
        other.select_set(False)
    obj.select_set(True)
    context.view_layer.objects.active = obj
    return obj


def face_of(obj) -> EditFace:
    """The engine face of a morph face object (replayed from its stored state when needed)."""
    if morph_object(obj) is None:
        raise UserError("select a morph face (create one with 'New Face' in Morphable Face)")
    stored = obj.get(STATE_KEY, "")
    cached = _faces.get(obj.session_uid)
    if cached is not None and cached[0] == stored:
        return cached[1]
    face = face_from_state(model_for(obj.get(MODEL_KEY, DEFAULT)), stored)
    _faces[obj.session_uid] = (stored, face)
    return face


def write_face(obj, face: EditFace) -> None:
    """Vertices and albedo into the mesh (foreach_set, no loops) and the state onto the object."""
    mesh = obj.data
    if len(mesh.vertices) != face.model.vertex_count:
        raise UserError(f"'{obj.name}' has {len(mesh.vertices)} vertices; its model has {face.model.vertex_count}")
    mesh.attributes["position"].data.foreach_set("vector", np.ascontiguousarray(face.shape, np.float32).ravel())
    colour = face.colour
    if colour is None and face.model.info.get("topology") == HEAD_TOPOLOGY:
        colour = head_albedo(face.model)
    if colour is not None and ALBEDO in mesh.color_attributes:
        rgba = np.ones((len(colour), 4), np.float32)
        rgba[:, :3] = np.clip(colour, 0.0, 1.0)
        mesh.color_attributes[ALBEDO].data.foreach_set("color", rgba.ravel())
    mesh.update()
    write_character(obj, face)
    state = json.dumps(face.state(), sort_keys=True)
    obj[STATE_KEY] = state
    obj[HISTORY_KEY] = "\n".join(face.history_lines())
    _faces[obj.session_uid] = (state, face)


# ------------------------------------------------------------------------------------------ the character
HEAD_KEY = "FH Morph Head"
_character: dict[str, object] = {}


def _character_base_index() -> np.ndarray:
    if "base_index" not in _character:
        from ...faces_hands_addon.character.body import character_mesh
        _character["base_index"] = character_mesh().base_index
    return _character["base_index"]


def link_character(obj, body) -> None:
    """Let the morph face ``obj`` reshape the head of the character ``body`` (a mesh of the default
    character's topology): from now on every edit writes the head into the body's shape key
    :data:`HEAD_KEY` (value 1; the body's own shape stays its basis). Refused, the scene unchanged, for a
    face of another model or a body of another topology."""
    from ...faces_hands_addon.morph.heads import character_ids, check_head_model
    face = face_of(obj)
    check_head_model(face.model, f"model {face.model.name!r}")
    if body is None or body.type != "MESH" or body is obj:
        raise UserError("select the character's body as well as the morph head (the head active)")
    base = _character_base_index()
    if len(body.data.vertices) != len(base):
        raise UserError(f"'{body.name}' has {len(body.data.vertices)} vertices; the default character's body has "
                        f"{len(base)}: it is not the character's topology")
    character_ids(face.model, base)
    obj[MORPH_CHARACTER] = body.name
    write_character(obj, face)


def write_character(obj, face: EditFace) -> None:
    """The face's head into its linked character's shape key (nothing when none is linked or it is gone)."""
    body = bpy.data.objects.get(obj.get(MORPH_CHARACTER, "") or "")
    if body is None or body.type != "MESH":
        return
    from ...faces_hands_addon.morph.heads import character_ids
    base = _character_base_index()
    mesh = body.data
    if len(mesh.vertices) != len(base):
        raise UserError(f"'{body.name}' no longer has the character's {len(base)} vertices")
    key = (id(face.model), len(base))
    local = _character.get(key)
    if local is None:
        local = _character[key] = character_ids(face.model, base)
    if mesh.shape_keys is None:
        body.shape_key_add(name="Basis", from_mix=False)
    block = mesh.shape_keys.key_blocks.get(HEAD_KEY) or body.shape_key_add(name=HEAD_KEY, from_mix=False)
    coords = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.shape_keys.reference_key.data.foreach_get("co", coords)
    coords = coords.reshape(-1, 3)
    coords[local] = face.shape
    block.data.foreach_set("co", coords.ravel())
    block.value = 1.0
    mesh.update()


def selected_segments(obj) -> list[str]:
    return [item.name for item in obj.faces_hands_morph.segments if item.selected]


def apply(obj, action) -> EditFace:
    """Run ``action(face)`` on the object's face and write the result (all or nothing: a UserError leaves
    the object as it was)."""
    face = face_of(obj)
    backup = face.state()
    try:
        action(face)
    except UserError:
        _faces[obj.session_uid] = (obj.get(STATE_KEY, ""), face_from_state(face.model, backup, blender=face.blender))
        raise
    write_face(obj, face)
    return face


def sync_panel(obj, face: EditFace) -> None:
    """The object's slider and segment lists from the model, values from the face."""
    settings = obj.faces_hands_morph
    segments = selected_segments(obj) if len(settings.segments) else []
    settings["caricature"] = face.caricature_level("shape", segments)
    settings.sliders.clear()
    for name, attribute in face.model.attributes.items():
        item = settings.sliders.add()
        item.name, item.category = name, attribute.category
        item.has_colour = attribute.colour is not None
        item["shape"] = face.slider(name, "shape", segments)
        item["colour"] = face.slider(name, "colour", segments)
    if not len(settings.segments):
        parents = face.model.segment_parents
        order = hierarchy_order(parents) if parents else list(face.model.segments)
        for name in order:
            item = settings.segments.add()
            item.name = name
            depth, probe = 0, name
            while probe in parents:
                depth, probe = depth + 1, parents[probe]
            item.depth = depth


def segment_colours(obj) -> None:
    """Show the segments as colours (shades of the feature's colour; the selection bright, 5.1.2)."""
    face = face_of(obj)
    model, n = face.model, face.model.vertex_count
    palette = model.info.get("segment_colours", {})
    parents = model.segment_parents
    colours = np.full((n, 4), 0.35, np.float32)
    leaves = [s for s in model.segments if s not in set(parents.values()) and s != "face"]
    for number, leaf in enumerate(leaves):
        feature = leaf
        while parents.get(feature, "face") != "face":
            feature = parents[feature]
        base = np.asarray(palette.get(feature, (0.5, 0.5, 0.5)), np.float32)
        colours[model.segments[leaf], :3] = base * (0.55 + 0.45 * ((number % 3) / 2.0))
    selected = selected_segments(obj)
    if selected:
        from ...faces_hands_addon.morph.segments import selection_mask
        mask = selection_mask(model.segments, selected, n)
        if mask is not None:
            colours[~mask, :3] *= 0.35
    colours[:, 3] = 1.0
    obj.data.color_attributes[MASK].data.foreach_set("color", colours.ravel())
    obj.data.update()


def show_mask(obj, show: bool) -> None:
    if show:
        segment_colours(obj)
    _show_colours(obj.data, MASK if show else ALBEDO)
    obj.data.materials[0].node_tree.nodes["Attribute"].attribute_name = MASK if show else ALBEDO


def _show_colours(mesh, name: str) -> None:
    """Make ``name`` the colour attribute the viewport and Workbench renders show."""
    attributes = mesh.color_attributes
    attributes.active_color = attributes[name]
    attributes.render_color_index = list(attributes).index(attributes[name])


def save_face(obj, path: str) -> Path:
    """The face as JSON (model, history, constraints, coefficients; 5.1.10)."""
    from ..adapters.outputs import atomic_output, check_output_path
    out = check_output_path(bpy.path.abspath(path), (".json",))
    with atomic_output(out) as tmp:
        tmp.write_text(json.dumps(face_of(obj).state(), indent=1, sort_keys=True), encoding="utf-8")
    return out


def load_face(obj, path: str) -> EditFace:
    text = read_text(bpy.path.abspath(path) if path else path, "the saved face", MAX_FACE_BYTES)
    face = face_from_state(face_of(obj).model, text)
    write_face(obj, face)
    sync_panel(obj, face)
    return face


def make_animatable(context, obj, name: str | None = None):
    """Hand the morphed face to the face-rig builder: it shares the template's topology, so its 468 vertices
    are the landmarks (no registration); a copy of the mesh becomes the rig's skin."""
    face = face_of(obj)
    if face.model.info.get("topology") != "mediapipe_canonical_468":
        raise UserError("Make Animatable needs a face on the MediaPipe topology (the 'mask' model); a head of the "
                        "character's topology is animated through the character (build-character)")
    from ...faces_hands_addon.face.fitted import build_fitted_rig
    world = np.asarray(obj.matrix_world, np.float64)
    vertices = face.shape @ world[:3, :3].T + world[:3, 3]
    rig = build_fitted_rig(vertices, np.asarray(face.model.triangles), landmarks=vertices, seed=0)
    mesh = obj.data.copy()
    head = bpy.data.objects.new(name or f"{obj.name} Rig", mesh)
    for collection in obj.users_collection:
        collection.objects.link(head)
    head.matrix_world = obj.matrix_world
    for key in (MORPH_MARKER, MODEL_KEY, STATE_KEY, EXAMPLES_KEY, HISTORY_KEY):
        if key in head.keys():
            del head[key]
    from ..face.services import attach_fitted_rig
    return attach_fitted_rig(context, head, rig, world, head.name)
