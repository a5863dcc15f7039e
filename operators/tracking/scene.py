# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender side of the pitch tracker's pictures: meshes from the engine's arrays (vertex colours), cameras that
match the engine's calibrated pinhole cameras, and flat-shaded Workbench renders read back as arrays."""
from __future__ import annotations

import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from ..adapters.render import quiet_stdout, read_png

__all__ = ["setup_render", "mesh_object", "place_camera", "render_array", "camera_object", "remove_objects",
           "CV_TO_BLENDER", "srgb_to_linear"]

CV_TO_BLENDER = np.diag([1.0, -1.0, -1.0])    # camera axes: x right, y down, z forward -> Blender's -z forward


def setup_render(scene, size: tuple[int, int], samples: str = "16") -> None:
    """Workbench, flat light, vertex colours, black world, no colour transform beyond sRGB."""
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = int(size[0]), int(size[1])
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.film_transparent = False
    scene.display.render_aa = samples
    shading = scene.display.shading
    shading.light = "FLAT"
    shading.color_type = "VERTEX"
    shading.background_type = "WORLD"
    shading.show_specular_highlight = False
    shading.show_object_outline = False
    shading.show_cavity = False
    shading.show_shadows = False
    world = scene.world or bpy.data.worlds.new("FH Black")
    scene.world = world
    world.color = (0.0, 0.0, 0.0)
    scene.display_settings.display_device = "sRGB"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0


def srgb_to_linear(colours: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(colours, np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def mesh_object(name: str, vertices: np.ndarray, faces, colours: np.ndarray | None, collection) -> bpy.types.Object:
    """An object with a mesh of ``vertices`` and ``faces`` and per-vertex ``colours``: display (sRGB) values,
    stored linear so that a flat render shows exactly them (the engine's colour classes are hues of the
    photo)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(vertices, np.float64).tolist(), [], [tuple(int(i) for i in f) for f in faces])
    if colours is not None:
        attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
        rgba = np.column_stack([srgb_to_linear(colours), np.ones(len(colours))]).astype(np.float32)
        attribute.data.foreach_set("color", rgba.ravel())
        mesh.color_attributes.active_color = attribute
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    return obj


def camera_object(name: str, collection) -> bpy.types.Object:
    data = bpy.data.cameras.new(name)
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    return obj


def place_camera(obj, camera) -> None:
    """Make a Blender camera object image exactly like the engine's pinhole ``camera`` (undistorted): focal
    length and principal point through sensor width and lens shift, pose from R and t."""
    data = obj.data
    w, h = camera.size
    data.type = "PERSP"
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = 36.0
    data.lens = camera.fx * 36.0 / w
    largest = max(w, h)
    data.shift_x = -(camera.cx - w / 2.0) / largest
    data.shift_y = (camera.cy - h / 2.0) / largest
    data.clip_start, data.clip_end = 0.05, 100.0
    rotation = camera.R.T @ CV_TO_BLENDER
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation, camera.centre
    obj.matrix_world = Matrix(m.tolist())


def render_array(scene, camera_obj, size: tuple[int, int]) -> np.ndarray:
    """Render the scene through ``camera_obj``; (H, W, 3) float array, top row first."""
    scene.camera = camera_obj
    setup_size = (scene.render.resolution_x, scene.render.resolution_y)
    if setup_size != tuple(size):
        scene.render.resolution_x, scene.render.resolution_y = int(size[0]), int(size[1])
    with tempfile.TemporaryDirectory(prefix="fh-render-") as folder:
        path = Path(folder) / "render.png"
        scene.render.filepath = str(path)
        with quiet_stdout():
            bpy.ops.render.render(write_still=True)
        pixels = read_png(path)
    return np.ascontiguousarray(pixels[::-1, :, :3])


def remove_objects(objects) -> None:
    for obj in list(objects):
        data = obj.data
        bpy.data.objects.remove(obj, do_unlink=True)
        if data is not None and data.users == 0:
            if isinstance(data, bpy.types.Mesh):
                bpy.data.meshes.remove(data)
            elif isinstance(data, bpy.types.Camera):
                bpy.data.cameras.remove(data)
