# SPDX-License-Identifier: GPL-3.0-or-later
"""Labelled contact sheets of a face rig: one small Workbench render per pose, composed into one PNG.

Each cell is the *simulated* face (settled from rest with the cell's controls, 3.1.2), pushed into the
rig's simulation key, rendered with a text label under the head. Used by ``faces_hands render --sheet``
and the demo, and by the tests that look at what the rig does.
"""
from __future__ import annotations

import math
import shutil
import tempfile
from pathlib import Path
from typing import Callable

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ...faces_hands_addon.anim.layers import BASE_LAYER, LAYERS
from ..adapters import render
from ..adapters.poses import push_pose
from ..adapters.rig_store import get_rig, output_to_local, parts, to_world
from .objects import update_muscle_display

Cell = tuple[str, dict]

#: contact-sheet camera azimuths (degrees about Z; the face looks along -Y, the side view looks at the
#: character's left cheek): lip protrusion can only be judged from the side
VIEWS = {"front": 0.0, "three-quarter": 45.0, "side": 90.0}


def expression_cells(rig, include=("neutral", "muscles", "direct", "arkit", "visemes")) -> list[Cell]:
    """Neutral, each muscle at full contraction, each direct parameter at full value, ARKit and visemes."""
    from ...faces_hands_addon.face.expressions import load_expressions
    specs = rig.control_specs()
    cells: list[Cell] = []
    if "neutral" in include:
        cells.append(("neutral", {}))
    if "muscles" in include:
        cells += [(name, {name: 1.0}) for name, spec in specs.items() if spec.kind == "muscle"]
    if "direct" in include:
        for name, spec in specs.items():
            if spec.kind == "direct":
                cells.append((name, {name: spec.maximum}))
                if spec.minimum < 0:
                    cells.append((f"{name} -1", {name: spec.minimum}))
    for set_name in ("arkit", "visemes"):
        if set_name in include:
            cells += list(load_expressions(set_name).items())
    return cells


def cell_layers(controls: dict) -> tuple[dict, dict]:
    """(layer values, head pose) of a cell: a plain control dict is the artist's layer (with ``head.*``
    keys for the head); a take's cell names its layers (``speech``, ``behavior``, ``emotion``) and ``head``.
    The rig mixes the layers (``anim.layers.mix``: unknown names refused, values clamped once, there)."""
    if controls and all((k in LAYERS or k == "head") and isinstance(v, dict) for k, v in controls.items()):
        return {k: dict(v) for k, v in controls.items() if k in LAYERS}, dict(controls.get("head", {}))
    return ({BASE_LAYER: {k: v for k, v in controls.items() if "." not in k}},
            {k: v for k, v in controls.items() if "." in k})


def _show(obj, rig, pose) -> None:
    push_pose(obj, pose)
    update_muscle_display(obj, rig)


def head_frame(obj, rig) -> tuple[np.ndarray, float, np.ndarray]:
    """Where the rig's head space (face along -Y, top +Z; 3.1.2's template frame) is in the scene: the 4x4
    from head space to world (object matrix, the fit's mesh frame, ``head_to_mesh``), its uniform scale
    and its rotation. A head imported from an OBJ or FBX carries a turn in its object matrix and another
    in its own axes; the sheet's camera looks at the face through both."""
    head_to_mesh = np.asarray(getattr(rig, "head_to_mesh", np.eye(4)), np.float64)
    matrix = np.asarray(obj.matrix_world, np.float64) @ output_to_local(obj) @ head_to_mesh
    linear = matrix[:3, :3]
    scale = float(abs(np.linalg.det(linear)) ** (1.0 / 3.0)) or 1.0
    u, _, vt = np.linalg.svd(linear / scale)              # the nearest rotation (an object scaled unevenly)
    turn = u @ vt
    if np.linalg.det(turn) < 0:                           # mirrored: keep a proper rotation for the camera
        turn = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    return matrix, scale, turn


def _into_world(placed, head_to_world: np.ndarray, scale: float, turn: np.ndarray) -> None:
    """Move an object placed in head space (location, rotation) to the same place relative to the head."""
    location = head_to_world[:3, :3] @ np.asarray(placed.location, np.float64) + head_to_world[:3, 3]
    rotation = turn @ np.asarray(placed.rotation_euler.to_matrix(), np.float64)
    matrix = Matrix.Translation(Vector(location)) @ Matrix(rotation.tolist()).to_4x4()
    if placed.type != "CAMERA":                           # a camera's size is its ortho scale
        matrix = matrix @ Matrix.Diagonal((scale, scale, scale, 1.0))
    placed.matrix_world = matrix


def _label_object(collection, text: str, location, size: float, azimuth: float = 0.0):
    curve = bpy.data.curves.new("FH Sheet Label", "FONT")
    curve.body = text
    curve.size = size
    curve.align_x = "CENTER"
    label = bpy.data.objects.new("FH Sheet Label", curve)
    collection.objects.link(label)
    label.location = location
    label.rotation_euler = (math.pi / 2, 0.0, azimuth)  # readable from the camera
    material = bpy.data.materials.get("FH Sheet Label") or bpy.data.materials.new("FH Sheet Label")
    material.diffuse_color = (0.05, 0.05, 0.05, 1.0)
    curve.materials.append(material)
    return label


def render_sheet(context, obj, cells: list[Cell], out_path, cell_size=(220, 250), columns: int = 8,
                 progress: Callable[[float, str], None] | None = None, settle_time: float = 1.2,
                 view: str = "front", pose_cell: Callable[[object, dict], None] | None = None) -> Path:
    """Render one cell per (label, controls) and compose them row by row into ``out_path`` (PNG), seen
    from ``view`` (a key of :data:`VIEWS`). Names with a dot (``head.pitch``) are not face controls: they
    go to ``pose_cell(obj, controls)`` (which poses the object for the cell; called with ``{}`` at the
    end to put it back)."""
    rig = get_rig(obj)
    scene = context.scene
    visible = [obj] + [p for role, p in parts(obj).items()
                       if role not in ("skull", "jaw", "muscles")]
    hidden_before = {o.name: o.hide_render for o in scene.objects}
    for other in scene.objects:
        other.hide_render = other not in visible
    focus = getattr(rig, "focus_vertices", None)        # a character: frame its head, not the whole body
    head_to_world, scale, turn = head_frame(obj, rig)
    rest = np.asarray(rig.rest_positions if focus is None else rig.rest_positions[focus], np.float64)
    world = to_world(obj, rest)
    head = (world - head_to_world[:3, 3]) @ turn / scale     # laid out in head space (face -Y, top +Z)
    low, high = head.min(axis=0), head.max(axis=0)
    height = float(high[2] - low[2])
    azimuth = math.radians(VIEWS[view])
    centre = (low + high) / 2
    front = np.array([0.0, low[1] - 0.02 - centre[1]])  # the label stands in front of the head, facing the camera
    turned = np.array([[math.cos(azimuth), -math.sin(azimuth)], [math.sin(azimuth), math.cos(azimuth)]]) @ front
    label = _label_object(scene.collection, "", (centre[0] + turned[0], centre[1] + turned[1],
                                                 low[2] - 0.30 * height), 0.085 * height, azimuth)
    tmp_dir = Path(tempfile.mkdtemp(prefix="fh-sheet-"))
    tiles = []
    label.data.body = "neutral"
    render.setup_workbench(scene, cell_size)
    margin_below = 0.36 * height  # room for an open jaw and the label under the chin
    render.frame_camera(scene, visible, azimuth_deg=VIEWS[view], margin=1.08,
                           bounds=(low - np.array([0.0, 0.0, margin_below]), high))
    for placed in (scene.camera, label):                 # head space -> where the head is in the scene
        _into_world(placed, head_to_world, scale, turn)
    scene.camera.data.ortho_scale *= scale
    scene.camera.data.clip_end *= scale
    try:
        for index, (name, controls) in enumerate(cells):
            if progress:
                progress(index / max(len(cells), 1), f"rendering {name}")
            layers, head = cell_layers(controls)
            _show(obj, rig, rig.settled(layers, settle_time))
            if pose_cell is not None:
                pose_cell(obj, head)
            label.data.body = name
            tile = tmp_dir / f"cell_{index:04d}.png"
            render.render_objects(scene, visible + [label], tile, size=cell_size, reframe=False)
            tiles.append(render.read_png(tile))
        out_path = Path(out_path)
        render.write_png(render.compose_sheet(tiles, columns), out_path)
        if progress:
            progress(1.0, f"contact sheet with {len(tiles)} cells")
    finally:
        if pose_cell is not None:
            pose_cell(obj, {})
        rig.reset()
        _show(obj, rig, rig.rest_pose())
        curve = label.data
        bpy.data.objects.remove(label)
        bpy.data.curves.remove(curve)
        for other in scene.objects:
            other.hide_render = hidden_before.get(other.name, False)
        shutil.rmtree(tmp_dir, ignore_errors=True)
    return out_path
