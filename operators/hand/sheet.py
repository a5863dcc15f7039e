# SPDX-License-Identifier: GPL-3.0-or-later
"""Labelled contact sheets of a hand rig: one small Workbench render per pose (the hand settled from rest with
the pose's contractions, 6.2.1), composed into one PNG; seen from the palm, the back, the thumb side or three
quarters. Used by ``faces_hands render-hand``, the demo and the tests that look at what the hand does."""
from __future__ import annotations

import math
import shutil
import tempfile
from pathlib import Path
from typing import Callable

import bpy
import numpy as np

from ...faces_hands_addon.anim.layers import BASE_LAYER
from ...faces_hands_addon.hand import motion
from ..common import render
from ..common.poses import push_pose
from ..common.rig_store import get_rig, parts, to_world
from .objects import ARMATURE, push_hand_pose

__all__ = ["VIEWS", "pose_cells", "bulge_cells", "render_hand_sheet", "view_azimuth"]

#: camera azimuths (degrees about Z) for the right hand, whose palm faces +X and thumb -Y
VIEWS = {"palm": 90.0, "back": -90.0, "side": 0.0, "three-quarter": 45.0}


def view_azimuth(view: str, side: str) -> float:
    azimuth = VIEWS[view]
    return -azimuth if side == "left" else azimuth


def pose_cells(rig, names=None) -> list[tuple[str, dict, bool]]:
    """(label, contractions, hold joints) for the named poses (default: every preset pose), simulated."""
    return [(n.replace("_", " "), motion.pose_contractions(n, rig.muscle_names), False)
            for n in (names or motion.pose_names())]


def bulge_cells(rig) -> list[tuple[str, dict, bool]]:
    """Fig. 6.18: the hand at rest, then every geometric muscle's twin fully contracted with the joints held
    straight (only the bulge shows), then all nine together."""
    twins = [rig.muscle_names[i] for i in rig.geometric.pseudo]
    cells = [("rest", {}, True)]
    cells += [(name.replace("_", " "), {twin: 1.0}, True) for name, twin in zip(rig.geometric.names, twins)]
    cells.append(("all nine", {twin: 1.0 for twin in twins}, True))
    return cells


def _label(collection, text: str, location, size: float, azimuth: float):
    curve = bpy.data.curves.new("FH Hand Label", "FONT")
    curve.body, curve.size, curve.align_x = text, size, "CENTER"
    label = bpy.data.objects.new("FH Hand Label", curve)
    collection.objects.link(label)
    label.location = location
    label.rotation_euler = (math.pi / 2, 0.0, math.radians(azimuth))
    material = bpy.data.materials.get("FH Sheet Label") or bpy.data.materials.new("FH Sheet Label")
    material.diffuse_color = (0.05, 0.05, 0.05, 1.0)
    curve.materials.append(material)
    return label


def render_hand_sheet(context, obj, cells, out_path, view: str = "palm", columns: int = 4, cell_size=(240, 300),
                      progress: Callable[[float, str], None] | None = None, settle_time: float = 2.5,
                      show_bones: bool = False) -> Path:
    """Render one cell per (label, contractions, hold joints) and compose them into ``out_path`` (PNG)."""
    rig = get_rig(obj, "hand")
    scene = context.scene
    azimuth = view_azimuth(view, rig.side)
    by_role = parts(obj)
    visible = [obj] + ([o for o in scene.objects if o.parent == by_role.get(ARMATURE)] if show_bones else [])
    hidden_before = {o.name: o.hide_render for o in scene.objects}
    for other in scene.objects:
        other.hide_render = other not in visible
    world = to_world(obj, rig.rest_positions)
    low, high = world.min(axis=0) - 0.04, world.max(axis=0) + 0.02
    centre = (low + high) / 2
    direction = np.array([math.sin(math.radians(azimuth)), -math.cos(math.radians(azimuth)), 0.0])
    label = _label(scene.collection, "", tuple(centre + direction * 0.12 + np.array([0, 0, low[2] - centre[2] + 0.012])),
                   0.018, azimuth)
    tmp = Path(tempfile.mkdtemp(prefix="fh-hand-sheet-"))
    tiles = []
    render.setup_workbench(scene, cell_size)
    render.frame_camera(scene, visible, azimuth_deg=azimuth, elevation_deg=5.0, margin=1.05, bounds=(low, high))
    try:
        for index, (text, values, hold) in enumerate(cells):
            if progress:
                progress(index / max(len(cells), 1), f"rendering {text}")
            if hold:
                rig.reset()
                rig.set_controls(values)
                pose = rig.pose_joints(np.zeros(rig.skeleton.dof_count), settle_time)
            else:
                pose = rig.settled({BASE_LAYER: values}, settle_time)
            push_pose(obj, pose)
            push_hand_pose(obj, rig)
            label.data.body = text
            tile = tmp / f"cell_{index:04d}.png"
            render.render_objects(scene, visible + [label], tile, size=cell_size, reframe=False)
            tiles.append(render.read_png(tile))
        render.write_png(render.compose_sheet(tiles, columns), Path(out_path))
        if progress:
            progress(1.0, f"hand contact sheet with {len(tiles)} cells")
    finally:
        rig.reset()
        push_pose(obj, rig.pose())
        push_hand_pose(obj, rig)
        curve = label.data
        bpy.data.objects.remove(label)
        bpy.data.curves.remove(curve)
        for other in scene.objects:
            other.hide_render = hidden_before.get(other.name, False)
        shutil.rmtree(tmp, ignore_errors=True)
    return Path(out_path)
