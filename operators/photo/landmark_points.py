# SPDX-License-Identifier: GPL-3.0-or-later
"""Landmarks placed or corrected by hand over the photo, as the thesis' tool let the user click feature
points (3.2.5): the photo is a camera's background, the 478 landmarks are the vertices of one mesh lying in
that camera's view (one millimetre per pixel), joined along MediaPipe's contours (eyes, brows, lips, nose,
face outline) so they read as a face. In Edit Mode the artist drags them onto the photo, then makes the head
from them. Where the detector found the face, the points start where it put them; otherwise at the model's
average face in the middle of the picture."""
from __future__ import annotations

import json
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.photo.camera import Camera, FRONT, focal_from_35mm
from ...names import PHOTO_CAMERA, PHOTO_LANDMARKS
from .images import image_from_pixels

__all__ = ["add_landmark_points", "landmarks_of", "find_points", "DEPTH"]

DEPTH = "fh_depth"                 # per-vertex float attribute: MediaPipe's relative depth (pixels)
PIXEL = 0.001                      # metres per pixel on the picture plane


def _contour_edges() -> np.ndarray:
    from ...faces_hands_addon.assets import face_contours
    contours = face_contours()
    edges = []
    for name, line in contours.lines.items():
        line = np.asarray(line)
        pairs = list(zip(line[:-1], line[1:]))
        if contours.closed.get(name):
            pairs.append((line[-1], line[0]))
        edges += pairs
    for ring in contours.refined_only.values():
        ring = np.asarray(ring)
        edges += list(zip(ring, np.roll(ring, -1)))
    return np.unique(np.sort(np.asarray(edges, np.int64), axis=1), axis=0)


def default_points(model, width: int, height: int) -> np.ndarray:
    """(478, 3) landmarks of the model's average face looking at the camera, in the middle of the picture,
    almost half its width wide (a start for placing them by hand)."""
    focal = focal_from_35mm(50.0, width, height)
    mean = model.mean[model.landmarks]
    face_width = float(np.linalg.norm(mean[454] - mean[234]))
    distance = focal * face_width / (0.45 * min(width, height))
    camera = Camera(width, height, focal, FRONT.copy(), np.array([0.0, 0.0, distance]) - FRONT @ mean.mean(axis=0))
    pixels, depth = camera.project(mean)
    points = np.zeros((478, 3))
    points[:468, :2] = pixels
    points[:468, 2] = (depth - depth.mean()) * focal / depth.mean()
    eyes = ((33, 133, 159, 145), (362, 263, 386, 374))
    for start, ids in zip((468, 473), eyes):
        centre = points[list(ids)].mean(axis=0)
        radius = 0.18 * np.linalg.norm(points[ids[0], :2] - points[ids[1], :2])
        points[start] = centre
        for k, angle in enumerate((0.0, 0.5 * np.pi, np.pi, 1.5 * np.pi)):
            points[start + 1 + k] = centre + radius * np.array([np.cos(angle), -np.sin(angle), 0.0])
    return points


def add_landmark_points(context, photo, points: np.ndarray, source: str, name: str = "FH Photo Landmarks"):
    """The photo camera (ortho, the photo as background) and the landmark mesh; returns the mesh object."""
    height, width = photo.pixels.shape[:2]
    data = bpy.data.cameras.new(f"{name} Camera")
    data.type = "ORTHO"
    data.ortho_scale = max(width, height) * PIXEL
    data.clip_start, data.clip_end = 0.01, 10.0
    background = data.background_images.new()
    background.image = image_from_pixels(f"{name} Photo", photo.pixels)
    background.alpha = 1.0
    data.show_background_images = True
    camera = bpy.data.objects.new(f"{name} Camera", data)
    camera.matrix_world = Matrix(((1, 0, 0, 0), (0, 0, -1, -1.0), (0, 1, 0, 0), (0, 0, 0, 1)))
    camera[PHOTO_CAMERA] = 1
    context.scene.collection.objects.link(camera)
    positions = np.column_stack([(points[:, 0] - width / 2.0) * PIXEL, np.zeros(len(points)),
                                 (height / 2.0 - points[:, 1]) * PIXEL])
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(positions.tolist(), _contour_edges().tolist(), [])
    depth = mesh.attributes.new(DEPTH, "FLOAT", "POINT")
    depth.data.foreach_set("value", np.asarray(points[:, 2], np.float32))
    obj = bpy.data.objects.new(name, mesh)
    obj[PHOTO_LANDMARKS] = json.dumps({"photo": source, "width": width, "height": height,
                                       "focal_35mm": float(photo.focal_35mm), "camera": camera.name})
    context.scene.collection.objects.link(obj)
    obj.show_in_front = True
    context.scene.camera = camera
    context.scene.render.resolution_x, context.scene.render.resolution_y = width, height
    context.scene.render.resolution_percentage = 100
    return obj


def find_points(context):
    """The active landmark mesh (or the only one)."""
    active = context.active_object
    if active is not None and active.get(PHOTO_LANDMARKS):
        return active
    found = [o for o in context.scene.objects if o.get(PHOTO_LANDMARKS)]
    if len(found) != 1:
        raise UserError("select the photo's landmark points (Edit Photo Landmarks makes them)" if not found else
                        "several landmark meshes are in the scene; select the one to use")
    return found[0]


def landmarks_of(obj) -> tuple[np.ndarray, dict]:
    """(478, 3) pixel landmarks of a landmark mesh (its vertices as the artist left them) and its record."""
    record = json.loads(obj[PHOTO_LANDMARKS])
    mesh = obj.data
    if len(mesh.vertices) != 478:
        raise UserError(f"'{obj.name}' has {len(mesh.vertices)} points; the landmark mesh needs its 478 (move "
                        "points, do not delete or add them; undo, or make the points again)")
    if obj.mode == "EDIT":
        obj.update_from_editmode()
    co = np.empty(478 * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    world = np.asarray(obj.matrix_world, np.float64)
    co = co.reshape(478, 3).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    width, height = int(record["width"]), int(record["height"])
    depth = np.zeros(478, np.float32)
    if DEPTH in mesh.attributes:
        mesh.attributes[DEPTH].data.foreach_get("value", depth)
    points = np.column_stack([co[:, 0] / PIXEL + width / 2.0, height / 2.0 - co[:, 2] / PIXEL, depth])
    return points, record


def photo_path(record: dict) -> Path:
    path = Path(bpy.path.abspath(record.get("photo", "")))
    if not path.is_file():
        raise UserError(f"the photo of these landmarks ({path}) is no longer there; make the points again")
    return path
