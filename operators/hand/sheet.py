# SPDX-License-Identifier: GPL-3.0-or-later
"""Labelled contact sheets of a hand rig: one small Workbench render per pose (the hand settled from rest with
the pose's contractions, 6.2.1), composed into one PNG; seen from the palm, the back, the thumb or little
finger's side or three quarters; and the grip poses with and without their geometric muscles' bulge (Fig.
6.18) by one camera. Used by ``faces_hands render-hand``, the demo, ``bench/hand_bulges.py`` and the tests
that look at what the hand does."""
from __future__ import annotations

import contextlib
import math
import shutil
import tempfile
from pathlib import Path
from typing import Callable

import bpy
import numpy as np

from ...faces_hands_addon.hand import motion
from ..adapters import render
from ..adapters.poses import push_pose
from ..adapters.rig_store import get_rig, parts, to_world
from .objects import ARMATURE, push_hand_pose

__all__ = ["VIEWS", "GRIP_VIEWS", "SHAPE_MATCAP", "pose_cells", "bulge_cells", "render_hand_sheet", "view_azimuth",
           "frame_hand", "cell_pose", "sheet_scene", "bulge_pair", "render_grip_sheet"]

#: the Workbench matcap of sheets that show surface shape (muscle bulges): clay lit from the camera's upper
#: left, so a swelling of a few millimetres turns light on one flank and dark on the other
SHAPE_MATCAP = "clay_studio.exr"

#: degrees the sheet camera looks down
ELEVATION = 5.0

#: label height as a share of the cell's height
LABEL_SIZE = 0.05

#: camera azimuths (degrees about Z) for the right hand, whose palm faces +X and thumb -Y; "side" looks at the
#: thumb side, "ulnar" at the little finger's side (the hypothenar eminence in profile)
VIEWS = {"palm": 90.0, "back": -90.0, "side": 0.0, "three-quarter": 45.0, "ulnar": 180.0}

#: the grip poses of the bulge sheet and the view that faces each one's swelling: the hypothenar eminence from
#: the little finger's side, the first dorsal interosseus from the back, both from the palm in the spread
GRIP_VIEWS = {"fist": "ulnar", "point": "ulnar", "thumbs_up": "ulnar", "pinch": "back", "spread": "palm"}


def view_azimuth(view: str, side: str) -> float:
    azimuth = VIEWS[view]
    return -azimuth if side == "left" else azimuth


def pose_cells(rig, names=None) -> list[tuple[str, list, bool]]:
    """(label, contractions stage by stage, hold joints) for the named poses (default: every preset pose),
    simulated (a staged pose's squeeze after its first stage has settled, :func:`.motion.pose_stages`)."""
    return [(n.replace("_", " "), motion.pose_stages(n, rig.muscle_names), False)
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


def frame_hand(scene, obj, skins, view: str, side: str, label=None, margin: float = 1.05) -> None:
    """Point the sheet camera at the hand ``skins`` (rig output coordinates, one or more (N, 3) arrays) from
    ``view``; ``label`` (a text object) goes under the hand, towards the camera, sized to the frame."""
    azimuth = view_azimuth(view, side)
    world = np.concatenate([to_world(obj, s) for s in skins])
    low, high = world.min(axis=0) - 0.04, world.max(axis=0) + 0.02
    camera = render.frame_camera(scene, [], azimuth_deg=azimuth, elevation_deg=ELEVATION, margin=margin,
                                 bounds=(low, high))
    if label is not None:               # at the bottom of the frame, in front of the hand
        resolution = scene.render.resolution_x, scene.render.resolution_y
        height = camera.data.ortho_scale * min(1.0, resolution[1] / resolution[0])
        centre = (low + high) / 2
        direction = np.array([math.sin(math.radians(azimuth)), -math.cos(math.radians(azimuth)), 0.0])
        # the camera looks down by ELEVATION: a point 0.12 m nearer shows that much lower, times its sine
        up = (-height / 2 + 0.5 * LABEL_SIZE * height + 0.12 * math.sin(math.radians(ELEVATION))) \
            / math.cos(math.radians(ELEVATION))
        label.location = tuple(centre + direction * 0.12 + np.array([0.0, 0.0, up]))
        label.rotation_euler = (math.pi / 2, 0.0, math.radians(azimuth))
        label.data.size = LABEL_SIZE * height


def cell_pose(rig, values, hold: bool, settle_time: float = 2.5):
    """The hand of one cell: the pose's contractions (a dict, or a list of stages) simulated from rest (6.2.1),
    or with ``hold`` the joints kept straight while the muscles bulge."""
    stages = values if isinstance(values, list) else [values]
    if hold:
        rig.reset()
        rig.set_controls(stages[-1])
        return rig.pose_joints(np.zeros(rig.skeleton.dof_count), settle_time)
    return rig.settled_stages(stages, settle_time)


@contextlib.contextmanager
def sheet_scene(context, obj, visible):
    """Only ``visible`` render; yields a label object and a temporary folder; afterwards the rig is back at
    rest and the scene as it was."""
    scene = context.scene
    rig = get_rig(obj, "hand")
    hidden_before = {o.name: o.hide_render for o in scene.objects}
    for other in scene.objects:
        other.hide_render = other not in visible
    label = _label(scene.collection, "", (0.0, 0.0, 0.0), 0.018, 0.0)
    tmp = Path(tempfile.mkdtemp(prefix="fh-hand-sheet-"))
    try:
        yield label, tmp
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


def render_hand_sheet(context, obj, cells, out_path, view: str = "palm", columns: int = 4, cell_size=(240, 300),
                      progress: Callable[[float, str], None] | None = None, settle_time: float = 2.5,
                      show_bones: bool = False, framing: str = "rest", matcap: str | None = None) -> Path:
    """Render one cell per (label, contractions, hold joints) and compose them into ``out_path`` (PNG).
    ``framing``: "rest" frames every cell alike on the hand at rest, "pose" frames each cell on its own pose
    (a fist fills its cell); ``matcap``: a Workbench matcap instead of the studio light."""
    rig = get_rig(obj, "hand")
    scene = context.scene
    by_role = parts(obj)
    visible = [obj] + ([o for o in scene.objects if o.parent == by_role.get(ARMATURE)] if show_bones else [])
    tiles = []
    with sheet_scene(context, obj, visible) as (label, tmp):
        render.setup_workbench(scene, cell_size, matcap)
        frame_hand(scene, obj, [rig.rest_positions], view, rig.side, label)
        for index, (text, values, hold) in enumerate(cells):
            if progress:
                progress(index / max(len(cells), 1), f"rendering {text}")
            pose = cell_pose(rig, values, hold, settle_time)
            if framing == "pose":
                frame_hand(scene, obj, [pose.positions["skin"]], view, rig.side, label)
            push_pose(obj, pose)
            push_hand_pose(obj, rig)
            label.data.body = text
            tile = tmp / f"cell_{index:04d}.png"
            render.render_objects(scene, visible + [label], tile, size=cell_size, reframe=False, matcap=matcap)
            tiles.append(render.read_png(tile))
        render.write_png(render.compose_sheet(tiles, columns), Path(out_path))
    if progress:
        progress(1.0, f"hand contact sheet with {len(tiles)} cells")
    return Path(out_path)


def bulge_pair(context, obj, name: str, view: str, size, folder, label=None, settle_time: float = 2.5):
    """The grip pose ``name`` simulated from rest (6.2.1), then, at the joint angles it reached, rendered with
    its geometric muscles bulging and with their twins at 0 (Fig. 6.18) by one camera framed on both, with
    :data:`SHAPE_MATCAP`. Call inside :func:`sheet_scene`. Returns the skin's outward lift per node (m) and
    the two renders, bulging first, as (H, W, 4) arrays (the PNGs are in ``folder``)."""
    rig = get_rig(obj, "hand")
    scene = context.scene
    cell_pose(rig, motion.pose_stages(name, rig.muscle_names), False, settle_time)
    lift, on, off = rig.bulge_lift(rig.joint_angles, settle_time)
    render.setup_workbench(scene, size, SHAPE_MATCAP)
    frame_hand(scene, obj, [on.positions["skin"], off.positions["skin"]], view, rig.side, label)
    images = []
    for tag, pose in (("on", on), ("off", off)):
        if label is not None:
            label.data.body = name.replace("_", " ") + ("" if tag == "on" else ", no bulge")
        push_pose(obj, pose)
        push_hand_pose(obj, rig, pose)
        path = Path(folder) / f"{name}_{view}_{tag}.png"
        render.render_objects(scene, [obj] + ([label] if label is not None else []), path, size=size,
                              reframe=False, matcap=SHAPE_MATCAP)
        images.append(render.read_png(path))
    return lift, images[0], images[1]


def render_grip_sheet(context, obj, out_path, views: dict[str, str] | None = None, cell_size=(360, 450),
                      progress: Callable[[float, str], None] | None = None) -> Path:
    """The grip poses with and without their muscle bulges, side by side (two poses a row, each from the view
    of :data:`GRIP_VIEWS` that faces its swelling), composed into ``out_path`` (PNG)."""
    views = views or GRIP_VIEWS
    tiles = []
    with sheet_scene(context, obj, [obj]) as (label, tmp):
        for index, (name, view) in enumerate(views.items()):
            if progress:
                progress(index / len(views), f"rendering {name} with and without its bulge")
            tiles += bulge_pair(context, obj, name, view, cell_size, tmp, label)[1:]
        render.write_png(render.compose_sheet(tiles, 4), Path(out_path))
    return Path(out_path)
