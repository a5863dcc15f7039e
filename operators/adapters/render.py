# SPDX-License-Identifier: GPL-3.0-or-later
"""Small headless renders (Workbench) for previews, contact sheets and tests, and PNG files as arrays."""
from __future__ import annotations

import contextlib
import math
import os
import sys
from pathlib import Path

import bpy
import numpy as np


def _bounds(objects) -> tuple[np.ndarray, np.ndarray]:
    corners = []
    for obj in objects:
        matrix = np.array(obj.matrix_world)
        local = np.array([list(c) for c in obj.bound_box] or [[0, 0, 0]], dtype=float)
        corners.append(local @ matrix[:3, :3].T + matrix[:3, 3])
    points = np.concatenate(corners)
    return points.min(axis=0), points.max(axis=0)


def setup_workbench(scene: bpy.types.Scene, size=(480, 480), matcap: str | None = None) -> None:
    """Workbench at ``size`` pixels, studio light (or the built-in ``matcap``, e.g. "basic_grey.exr": its
    shading follows the surface normal as seen from the camera, so small swellings read)."""
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    shading = scene.display.shading
    shading.light = "MATCAP" if matcap else "STUDIO"
    if matcap:
        shading.studio_light = matcap
    shading.color_type = "VERTEX"   # painted colour attributes; objects without one show their material
    shading.show_specular_highlight = True
    scene.display_settings.display_device = "sRGB"
    scene.view_settings.view_transform = "Standard"


def frame_camera(scene: bpy.types.Scene, objects, azimuth_deg: float = 0.0, elevation_deg: float = 5.0,
                 margin: float = 1.15, bounds=None) -> bpy.types.Object:
    """Place an orthographic camera looking at ``objects`` (or explicit world ``bounds`` = (low, high))
    from the front (-Y), turned by azimuth."""
    low, high = (np.asarray(b, dtype=float) for b in bounds) if bounds is not None else _bounds(objects)
    centre = (low + high) / 2
    extent = float(np.max(high - low)) * margin
    camera_data = bpy.data.cameras.get("FH Preview Camera") or bpy.data.cameras.new("FH Preview Camera")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = extent
    camera = bpy.data.objects.get("FH Preview Camera") or bpy.data.objects.new("FH Preview Camera", camera_data)
    if camera.name not in scene.collection.objects:
        scene.collection.objects.link(camera)
    azimuth, elevation = math.radians(azimuth_deg), math.radians(elevation_deg)
    direction = np.array([math.sin(azimuth) * math.cos(elevation), -math.cos(azimuth) * math.cos(elevation),
                          math.sin(elevation)])
    camera.location = tuple(centre + direction * extent * 3)
    camera.rotation_euler = (math.pi / 2 - elevation, 0.0, azimuth)
    camera_data.clip_end = extent * 10
    scene.camera = camera
    return camera


def render_objects(scene, objects, filepath: str | Path, size=(480, 480), azimuth_deg: float = 0.0,
                   reframe: bool = True, matcap: str | None = None) -> Path:
    """Render ``objects`` with Workbench to a PNG; ``reframe=False`` keeps the current camera."""
    setup_workbench(scene, size, matcap)
    if reframe or scene.camera is None:
        frame_camera(scene, objects, azimuth_deg=azimuth_deg)
    scene.render.filepath = str(filepath)
    with quiet_stdout():
        bpy.ops.render.render(write_still=True)
    return Path(filepath)


@contextlib.contextmanager
def quiet_stdout():
    """Keep Blender's per-render 'Saved: ...' lines off stdout (the CLI's output is its report)."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def read_png(path: Path) -> np.ndarray:
    """A PNG as an (H, W, 4) float32 array (bottom row first, as Blender stores images)."""
    image = bpy.data.images.load(str(path))
    try:
        width, height = image.size
        pixels = np.empty(width * height * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(height, width, 4)
    finally:
        bpy.data.images.remove(image)


def compose_sheet(tiles: list[np.ndarray], columns: int) -> np.ndarray:
    """Equal-sized tiles (bottom row first, as :func:`read_png` gives them) laid out row by row from the top
    left, ``columns`` per row, on a white background: one (H, W, 4) image for :func:`write_png`."""
    rows = -(-len(tiles) // columns)
    tile_h, tile_w = tiles[0].shape[:2]
    sheet = np.ones((rows * tile_h, columns * tile_w, 4), dtype=np.float32)
    for index, tile in enumerate(tiles):
        row, col = divmod(index, columns)
        top = (rows - 1 - row) * tile_h  # Blender images start at the bottom row
        sheet[top:top + tile_h, col * tile_w:(col + 1) * tile_w] = tile
    return sheet


def write_png(array: np.ndarray, path: Path) -> None:
    """Write an (H, W, 4) float array (bottom row first) as a PNG."""
    height, width = array.shape[:2]
    image = bpy.data.images.new("FH Sheet", width=width, height=height, alpha=True)
    try:
        image.pixels.foreach_set(np.ascontiguousarray(array, dtype=np.float32).ravel())
        image.filepath_raw = str(path)
        image.file_format = "PNG"
        image.save()
    finally:
        bpy.data.images.remove(image)
