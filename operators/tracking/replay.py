# SPDX-License-Identifier: GPL-3.0-or-later
"""The pitch replay in Blender (thesis 6.3.4, Figs. 6.32-6.34): the marked ball spinning along the reference
trajectory with its local axes, the measured positions and the reference trajectory as curves, the
personalised hand in slow motion, and cameras that match the calibrated ones with their photos as
backgrounds. Everything goes into one collection, ``FH Pitch Replay``."""
from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.tracking import meshes as tm
from ...faces_hands_addon.tracking.replay import plan_replay
from ..adapters.blendfile import save_blend
from ..adapters.outputs import atomic_output
from ..hand import services as hand_services
from .scene import camera_object, mesh_object, place_camera

__all__ = ["build_replay", "save_replay", "COLLECTION", "SLOWDOWN"]

COLLECTION = "FH Pitch Replay"
SLOWDOWN = 20.0
_AXIS_RGB = ((0.9, 0.1, 0.1), (0.1, 0.8, 0.1), (0.1, 0.2, 0.95))


def _material(name: str, rgb) -> bpy.types.Material:
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.diffuse_color = (*rgb, 1.0)
    return mat


def _curve(name: str, points: np.ndarray, rgb, collection, bevel: float, segments: list | None = None):
    data = bpy.data.curves.new(name, "CURVE")
    data.dimensions = "3D"
    data.bevel_depth = bevel
    for segment in segments or [points]:
        spline = data.splines.new("POLY")
        spline.points.add(len(segment) - 1)
        spline.points.foreach_set("co", np.column_stack([segment, np.ones(len(segment))]).astype(np.float32).ravel())
    data.materials.append(_material(f"{name} Colour", rgb))
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    return obj


def _key_transform(obj, frames, locations, rotations) -> None:
    obj.rotation_mode = "QUATERNION"
    for f, loc, quat in zip(frames, locations, rotations):
        obj.location, obj.rotation_quaternion = tuple(loc), tuple(quat)
        obj.keyframe_insert("location", frame=int(f))
        obj.keyframe_insert("rotation_quaternion", frame=int(f))


def _ball(plan, model, collection):
    mesh = tm.ball_mesh(model)
    ball = mesh_object("FH Pitch Ball", mesh.vertices, mesh.faces, mesh.colours, collection)
    for axis, rgb in enumerate(_AXIS_RGB):          # the ball's local axes (Fig. 6.32)
        direction = np.eye(3)[axis]
        stick = tm.icosphere(1.0, rgb, 1)
        vertices = stick.vertices * np.where(direction > 0, 0.045, 0.0035) + direction * 0.045
        arrow = mesh_object(f"FH Pitch Ball Axis {'XYZ'[axis]}", vertices, stick.faces, stick.colours, collection)
        arrow.parent = ball
    _key_transform(ball, plan.frames, plan.ball_locations, plan.ball_rotations)
    return ball


def _cameras(calibration, photos: dict, collection) -> list:
    out = []
    for name, camera in calibration.cameras.items():
        obj = camera_object(f"FH Camera {name}", collection)
        place_camera(obj, camera)
        path = photos.get(name)
        if path is not None:
            image = bpy.data.images.load(str(path), check_existing=True)
            background = obj.data.background_images.new()
            background.image = image
            background.alpha = 0.8
            obj.data.show_background_images = True
        out.append(obj)
    return out


def build_replay(context, result, calibration, photo_files: dict, rig, model) -> dict:
    """Objects of the replay in the current scene; returns them by role."""
    if result.reference is None and not result.hands:
        raise UserError("nothing to replay: neither the ball's flight nor a hand pose was reconstructed")
    scene = context.scene
    collection = bpy.data.collections.new(COLLECTION)
    scene.collection.children.link(collection)
    fps = scene.render.fps / scene.render.fps_base
    plan = plan_replay(result, fps, SLOWDOWN, scene.frame_start)
    objects = {"cameras": _cameras(calibration, photo_files, collection)}
    if len(plan.frames):
        objects["ball"] = _ball(plan, model, collection)
        objects["reference"] = _curve("FH Reference Trajectory", plan.reference_curve, (1.0, 0.85, 0.1), collection,
                                      0.006)
        parts = [p for p in (result.front, result.back) if len(p) > 1]
        objects["measured"] = _curve("FH Measured Positions", plan.measured, (0.9, 0.15, 0.6), collection, 0.004,
                                     parts)
    if len(plan.hand_frames) and rig is not None:
        hand = hand_services.add_hand_object(context, rig, "FH Pitcher Hand")
        _key_transform(hand, plan.hand_frames, plan.hand_locations, plan.hand_rotations)
        hand_services.key_joint_angles(hand, rig, plan.hand_frames, plan.hand_angles, "FH Pitcher Hand Motion")
        objects["hand"] = hand
    scene.frame_end = max(plan.last_frame, scene.frame_start + 1)
    scene["fh_pitch_slowdown"] = SLOWDOWN
    return objects


def save_replay(context, out: Path) -> Path:
    """The replay as .blend or .glb (glTF: the animated ball, curves as meshes are not exported; cameras are)."""
    if out.suffix.lower() == ".blend":
        save_blend(out)
        return out
    with atomic_output(out) as tmp:
        bpy.ops.export_scene.gltf(filepath=str(tmp), export_format="GLB", export_animations=True,
                                  export_cameras=True, export_apply=False)
    return out
