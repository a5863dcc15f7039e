# SPDX-License-Identifier: GPL-3.0-or-later
"""Render a synthetic pitch recording in Blender (the engine's :mod:`...faces_hands_addon.tracking.synth`
plans it): calibration photos (checkerboards, the 3D calibration object), then one multi-exposure photo per
camera: every strobe flash's ball (and, for the hand cameras, hand with its glove) lit by that strobe, summed
on black, then lens distortion and sensor noise.

Summing exposures: exposures whose pictures do not overlap in a camera are rendered together (on black the sum
of separate renders equals one render of all of them); overlapping ones go into separate renders that are
added, so a black hand in one exposure never hides a marker of another.
"""
from __future__ import annotations

import bpy
import numpy as np

from ...faces_hands_addon.tracking import meshes as tm
from ...faces_hands_addon.tracking.ball_model import ball_model
from ...faces_hands_addon.tracking.calibrate import board_points
from ...faces_hands_addon.tracking.synth import board_poses, object_points, photo_from_render
from .scene import camera_object, mesh_object, place_camera, remove_objects, render_array, setup_render, srgb_to_linear

__all__ = ["render_groups", "render_calibration", "render_photos", "Piece", "render_video"]

OBJECT_RGB = {"red": (1, 0, 0), "orange": (1, 0.5, 0), "yellow": (1, 1, 0), "green": (0, 1, 0),
              "cyan": (0, 1, 1), "blue": (0, 0, 1), "magenta": (1, 0, 1), "white": (1, 1, 1)}


class Piece:
    """One exposure's geometry: meshes (vertices, faces, colours) and a bounding sphere for overlap tests."""

    def __init__(self, parts: list, centre: np.ndarray, radius: float):
        self.parts, self.centre, self.radius = parts, centre, radius


def render_groups(scene, camera, pieces: list[Piece], name: str, exposures: bool = True) -> np.ndarray:
    """The sum of the exposures ``pieces`` as ``camera`` sees them (pinhole, top row first); with
    ``exposures=False`` the pieces are one scene in one exposure (they hide each other)."""
    groups: list[list[int]] = []
    boxes = []
    for k, piece in enumerate(pieces):
        depth = float(camera.depth(piece.centre[None])[0])
        if depth <= 0.1:
            continue
        centre = camera.project(piece.centre[None], distorted=False)[0]
        boxes.append((k, centre, camera.fx * piece.radius / depth))
    for k, centre, radius in boxes:
        if not exposures and groups:
            groups[0].append((k, centre, radius))
            continue
        for group in groups:
            if all(np.linalg.norm(centre - c) > radius + r + 4 for j, c, r in group):
                group.append((k, centre, radius))
                break
        else:
            groups.append([(k, centre, radius)])
    cam_obj = camera_object(f"FH Synth {name}", scene.collection)
    place_camera(cam_obj, camera)
    setup_render(scene, camera.size, "8")
    total = np.zeros((camera.size[1], camera.size[0], 3), np.float32)
    try:
        for group in groups:
            objects = [mesh_object(f"FH Synth part {k}.{p}", v, f, c, scene.collection)
                       for k, _, _ in group for p, (v, f, c) in enumerate(pieces[k].parts)]
            try:
                total += render_array(scene, cam_obj, camera.size)
            finally:
                remove_objects(objects)
    finally:
        remove_objects([cam_obj])
    return np.clip(total, 0.0, 1.0)


def render_calibration(scene, cameras: dict, setup: dict, rng) -> dict[str, dict]:
    """Checkerboard photos and a photo of the 3D calibration object for every camera: name -> {"boards":
    [images], "object": image}."""
    spec = setup["calibration"]
    inner, square = tuple(spec["board"]["inner"]), float(spec["board"]["square"])
    board = tm.board_mesh(inner, square)
    out = {}
    for name, camera in cameras.items():
        boards = []
        for pose in board_poses(camera, inner, square):
            moved = board.transformed(pose[:3, :3], pose[:3, 3])
            piece = Piece([(moved.vertices, moved.faces, moved.colours)], pose[:3, 3], 1.0)
            boards.append(photo_from_render(render_groups(scene, camera, [piece], name), camera, rng,
                                            setup["noise_sigma"]))
        placement = next(o for o in spec["objects"].values() if name in o["cameras"])
        pieces = []
        colours = spec["colours"] * 2
        for point, colour in zip(object_points(placement["centre"], placement["size"]), colours):
            sphere = tm.icosphere(spec["sphere_radius"], OBJECT_RGB[colour], 3)
            pieces.append(Piece([(sphere.vertices + point, sphere.faces, sphere.colours)], point,
                                spec["sphere_radius"]))
        image = render_groups(scene, camera, pieces, name, exposures=False)
        out[name] = {"boards": boards, "object": photo_from_render(image, camera, rng, setup["noise_sigma"])}
    return out


def ball_piece(mesh, orientation, position, light, ambient, radius) -> Piece:
    shaded = tm.shade(mesh.transformed(orientation, position), light, ambient)
    return Piece([(shaded.vertices, shaded.faces, shaded.colours)], position, radius)


def render_photos(scene, cameras: dict, setup: dict, truth: dict, hand_pieces: list[Piece], rng) -> dict:
    """The multi-exposure photo of every camera (module docstring): name -> image."""
    model = ball_model()
    mesh = tm.ball_mesh(model)
    strobes = setup["strobes"]
    out = {}
    for role in ("front", "back"):
        light = np.asarray(strobes[role]["position"], float)
        pieces = [ball_piece(mesh, R, p, light, strobes[role]["ambient"], model.radius)
                  for p, R in zip(truth[f"{role}_positions"], truth[f"{role}_orientations"])]
        for name in setup["pairs"][role]:
            out[name] = render_groups(scene, cameras[name], pieces, name)
    for role in ("hand_left", "hand_right"):
        for name in setup["pairs"][role]:
            out[name] = render_groups(scene, cameras[name], hand_pieces, name)
    return {name: photo_from_render(image, cameras[name], rng, setup["noise_sigma"]) for name, image in out.items()}


def render_video(scene, camera, frames: list[list[Piece]], background: float, rng, sigma: float) -> list[np.ndarray]:
    """Frames of an ordinary video (studio light on vertex colours, a dark room), one render per frame."""
    cam_obj = camera_object("FH Synth video", scene.collection)
    place_camera(cam_obj, camera)
    out = []
    try:
        for pieces in frames:
            setup_render(scene, camera.size, "8")
            scene.display.shading.light = "STUDIO"
            scene.world.color = tuple(float(v) for v in srgb_to_linear([background] * 3))
            objects = [mesh_object(f"FH Synth frame {k}", v, f, c, scene.collection)
                       for k, piece in enumerate(pieces) for v, f, c in piece.parts]
            try:
                image = render_array(scene, cam_obj, camera.size)
            finally:
                remove_objects(objects)
            out.append(photo_from_render(image, camera, rng, sigma))
    finally:
        remove_objects([cam_obj])
    return out
