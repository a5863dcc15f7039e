# SPDX-License-Identifier: GPL-3.0-or-later
"""Heads from photographs in Blender (thesis 3.2.4-3.2.5): the engine's result made into objects -- the head
mesh with its photo texture, the face rig fitted to it (speech, behaviour and emotions work on it at once),
a camera that sees the head as the photo did with the photo as its background -- and the state the photo work
needs later (cameras, illumination) kept on the head as JSON."""
from __future__ import annotations

import json

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.photo.camera import Camera, focal_to_35mm
from ...faces_hands_addon.photo.head_model import HeadModel
from ...names import PHOTO_CAMERA, PHOTO_HEAD
from ..adapters.materials import enable_nodes
from ..adapters.meshes import mesh_from_arrays
from .images import image_from_pixels

__all__ = ["head_model", "head_objects", "photo_camera", "photo_state"]

_models: dict[str, HeadModel] = {}


def head_model(source: str = "default") -> HeadModel:
    """The photo view of the morphable model ``source`` (``default``: the synthetic face mask, the model with
    MediaPipe's landmark vertices; or a model file), once per session."""
    if source not in _models:
        from ..morph.services import MASK_MODEL, model_for
        _models[source] = HeadModel.from_morphable(model_for(MASK_MODEL if source in ("", "default") else source))
    return _models[source]


def _texture_material(name: str, image) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    enable_nodes(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    shader = nodes.get("Principled BSDF")
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.location = (-400, 250)
    if shader is not None:
        links.new(texture.outputs["Color"], shader.inputs["Base Color"])
        shader.inputs["Roughness"].default_value = 0.55
    return material


def photo_camera(context, camera: Camera, photo_image, name: str):
    """A Blender camera that sees the head (at the origin) as ``camera`` saw it, with the photo as its
    background; it becomes the scene's camera (and the render size the photo's) when the scene has none."""
    data = bpy.data.cameras.new(name)
    data.sensor_fit = "AUTO"
    data.sensor_width = 36.0
    data.lens = camera.lens_mm(36.0)
    data.clip_start, data.clip_end = 0.01, 100.0
    if photo_image is not None:
        background = data.background_images.new()
        background.image = photo_image
        background.alpha = 1.0
        background.display_depth = "BACK"
        data.show_background_images = True
    obj = bpy.data.objects.new(name, data)
    obj.matrix_world = Matrix(camera.blender_matrix().tolist())
    obj[PHOTO_CAMERA] = 1
    context.scene.collection.objects.link(obj)
    if context.scene.camera is None:
        context.scene.camera = obj
        context.scene.render.resolution_x, context.scene.render.resolution_y = camera.width, camera.height
        context.scene.render.resolution_percentage = 100
    return obj


def photo_state(result, names: list[str]) -> dict:
    """What the photo work keeps on the head (JSON): photos, cameras, illumination, the fit's report."""
    cameras = result.shape.cameras
    return {"format": "faces_hands.photo_head", "version": 1, "model": result.model.name, "photos": names,
            "cameras": [c.state() for c in cameras],
            "focal_35mm": [round(focal_to_35mm(c.focal, c.width, c.height), 2) for c in cameras],
            "lighting": [np.round(a.lighting.coefficients, 8).tolist() for a in result.appearance],
            "landmark_residual_px": [round(float(np.median(r)), 4) for r in result.shape.residuals],
            "notes": list(result.notes)}


def _eye_colours(rig_obj, result, photo_pixels, skin, triangles, name: str) -> None:
    """The eyeballs' colours from the photo (``photo.into_photo.part_colours``) as a colour attribute their
    own material shows, so the head looks with the person's eyes in Blender and in exported files."""
    from ...faces_hands_addon.photo.appearance import srgb_to_linear
    from ...faces_hands_addon.photo.into_photo import part_colours
    from ..adapters.rig_store import parts
    colours = part_colours(result, srgb_to_linear(photo_pixels), skin, triangles)
    material = bpy.data.materials.new(f"{name} Eyes")
    enable_nodes(material)
    nodes = material.node_tree.nodes
    attribute = nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "FH Photo"
    shader = nodes.get("Principled BSDF")
    if shader is not None:
        material.node_tree.links.new(attribute.outputs["Color"], shader.inputs["Base Color"])
        shader.inputs["Roughness"].default_value = 0.15
    for role, part in parts(rig_obj).items():
        if role not in ("eye_L", "eye_R") or len(part.data.vertices) != len(colours[role]):
            continue
        layer = part.data.color_attributes.new("FH Photo", "FLOAT_COLOR", "POINT")
        rgba = np.ones((len(colours[role]), 4), np.float32)
        rgba[:, :3] = colours[role]
        layer.data.foreach_set("color", rgba.ravel())
        part.data.materials.clear()
        part.data.materials.append(material)


def head_objects(context, result, photo_pixels: np.ndarray, names: list[str], name: str = "FH Photo Head"):
    """Blender objects of an engine result (module docstring); returns the head (rig) object."""
    mesh_map = result.mesh
    if mesh_map is None or result.rig is None:
        raise UserError("the head has no face rig yet; build it with the rig stage")
    vertices = mesh_map.vertices(result.vertices)
    mesh = mesh_from_arrays(name, vertices, mesh_map.triangles, mesh_map.uvs)
    texture = image_from_pixels(f"{name} Texture", result.texture.srgb)
    mesh.materials.append(_texture_material(f"{name} Skin", texture))
    head = bpy.data.objects.new(name, mesh)
    from ..face.services import attach_fitted_rig
    rig_obj = attach_fitted_rig(context, head, result.rig, np.eye(4), name)
    _eye_colours(rig_obj, result, photo_pixels, vertices, mesh_map.triangles, name)
    photo = image_from_pixels(f"{name} Photo", photo_pixels)
    photo_camera(context, result.shape.cameras[0], photo, f"{name} Camera")
    rig_obj[PHOTO_HEAD] = json.dumps(photo_state(result, names), sort_keys=True)
    return rig_obj
