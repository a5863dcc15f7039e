# SPDX-License-Identifier: GPL-3.0-or-later
"""Labelled contact sheets of morphed faces: one Workbench render per face (skin colour from the albedo
attribute), composed into one PNG. Used by ``faces_hands morph --sheet``, the demo and the tests."""
from __future__ import annotations

import math
import shutil
import tempfile
from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.morph.editing import EditFace
from ..adapters import render
from . import services

#: a cell: (label, list of (method name, args, kwargs) applied to a fresh average face)
Cell = tuple[str, list]

VIEWS = {"front": 0.0, "three-quarter": 35.0, "side": 90.0}


def _label(scene, text: str, location, size: float):
    curve = bpy.data.curves.new("FH Morph Label", "FONT")
    curve.body, curve.size, curve.align_x = text, size, "CENTER"
    label = bpy.data.objects.new("FH Morph Label", curve)
    scene.collection.objects.link(label)
    label.location, label.rotation_euler = location, (math.pi / 2, 0.0, 0.0)
    label.color = (0.05, 0.05, 0.05, 1.0)
    return label


def face_for(model, steps) -> EditFace:
    face = EditFace(model)
    for method, args, kwargs in steps:
        getattr(face, method)(*args, **kwargs)
    return face


def _render_tiles(context, obj, cells: list[Cell], cell_size, progress=None, view: str = "front",
                  labelled: bool = True) -> list[np.ndarray]:
    """One Workbench render (per-vertex colour shading) per cell on ``obj``'s model; ``obj`` shows its own
    face again afterwards and the scene's render settings are restored."""
    scene = context.scene
    own = services.face_of(obj)
    hidden = {o.name: o.hide_render for o in scene.objects}
    saved = (scene.render.engine, scene.render.resolution_x, scene.render.resolution_y, scene.render.filepath,
             scene.camera)
    for other in scene.objects:
        other.hide_render = other is not obj
    world = np.asarray(obj.matrix_world)
    points = own.model.mean_vertices() @ world[:3, :3].T + world[:3, 3]
    low, high = points.min(axis=0), points.max(axis=0)
    height = float(high[2] - low[2])
    depth = low[1] - 0.02 if view == "front" else (low[1] + high[1]) / 2
    label = _label(scene, "", ((low[0] + high[0]) / 2, depth, low[2] - 0.16 * height), 0.075 * height)
    label.rotation_euler[2] = math.radians(VIEWS[view])          # faces the camera of the view
    tmp_dir = Path(tempfile.mkdtemp(prefix="fh-morph-sheet-"))
    below = 0.22 * height if labelled else 0.02 * height
    tiles = []
    try:
        render.setup_workbench(scene, cell_size)
        scene.display.shading.color_type = "VERTEX"
        render.frame_camera(scene, [obj], azimuth_deg=VIEWS[view], elevation_deg=3.0, margin=1.12,
                            bounds=(low - np.array([0.01, 0.0, below]), high + np.array([0.01, 0, 0])))
        for index, (name, steps) in enumerate(cells):
            if progress:
                progress(index / max(len(cells), 1), f"rendering {name}")
            services.write_face(obj, face_for(own.model, steps))
            label.data.body = name if labelled else ""
            tile = tmp_dir / f"cell_{index:04d}.png"
            scene.render.filepath = str(tile)
            with render.quiet_stdout():
                bpy.ops.render.render(write_still=True)     # keeps the per-vertex colour shading set above
            tiles.append(render.read_png(tile))
    finally:
        services.write_face(obj, own)
        curve = label.data
        bpy.data.objects.remove(label)
        bpy.data.curves.remove(curve)
        for other in scene.objects:
            other.hide_render = hidden.get(other.name, False)
        (scene.render.engine, scene.render.resolution_x, scene.render.resolution_y, scene.render.filepath,
         scene.camera) = saved
        shutil.rmtree(tmp_dir, ignore_errors=True)
    return tiles


def render_sheet(context, obj, cells: list[Cell], out_path, cell_size=(260, 300), columns: int = 6,
                 progress=None, view: str = "front") -> Path:
    """Render one cell per (label, steps) on ``obj``'s model and compose them row by row into ``out_path``."""
    tiles = _render_tiles(context, obj, cells, cell_size, progress, view)
    render.write_png(render.compose_sheet(tiles, columns), Path(out_path))
    return Path(out_path)


def render_thumbnails(context, obj, indices, size: int = 96) -> list:
    """Thumbnails of database examples for the browser (5.1.5): images ``FH Example NNN``, packed into the
    file so they survive saving; existing ones are replaced."""
    cells = [(str(i), [("create", ("example",), {"index": int(i)})]) for i in indices]
    tiles = _render_tiles(context, obj, cells, (size, size), labelled=False)
    images = []
    for index, tile in zip(indices, tiles):
        name = f"FH Example {int(index):03d}"
        old = bpy.data.images.get(name)
        if old is not None:
            bpy.data.images.remove(old)
        image = bpy.data.images.new(name, width=size, height=size, alpha=True)
        image.pixels.foreach_set(np.ascontiguousarray(tile, np.float32).ravel())
        image.pack()
        image.preview_ensure()
        images.append(image)
    return images


MASCULINE, BROWS = "masculine-feminine", "eyebrows-eyes distance"
BROW_RIDGE = "flat-prominent brow ridge"      # the head model's stand-in for the brows of Fig. 3.8


def fig_3_8_cells(masculine: float = -1.5, brows: float = 1.5, second: str = BROWS) -> list[Cell]:
    """The Fig. 3.8 experiment: masculine; a second attribute (higher eyebrows); both added; both with
    masculinity constrained."""
    short = "brows" if second == BROWS else second.split()[-1]
    return [("average", []),
            (f"masculine {masculine:+.1f}", [("set_attribute", (MASCULINE, masculine), {})]),
            (f"{short} {brows:+.1f}", [("set_attribute", (second, brows), {})]),
            (f"masc., then {short}", [("set_attribute", (MASCULINE, masculine), {}),
                                      ("set_attribute", (second, brows), {})]),
            (f"masc. kept, {short}", [("set_attribute", (MASCULINE, masculine), {}), ("constrain", (MASCULINE,), {}),
                                      ("set_attribute", (second, brows), {})])]


def demo_cells(model) -> list[Cell]:
    """Average, +-2 on a few attributes, a caricature of a random face, and the Fig. 3.8 experiment (with the
    brow ridge where the model has no eyebrow attribute)."""
    cells: list[Cell] = [("average", [])]
    for name in ("masculine-feminine", "slender-obese", "narrow-wide", "dark-light skin", "younger-older"):
        if name in model.attributes:
            part = "colour" if name == "dark-light skin" else "both"
            for value in (-2.0, 2.0):
                cells.append((f"{name} {value:+.0f}", [("set_attribute", (name, value, part), {})]))
    cells.append(("random (seed 3)", [("create", ("random", 3), {})]))
    cells.append(("its caricature x2", [("create", ("random", 3), {}), ("caricature", (2.0,), {})]))
    if MASCULINE not in model.attributes:
        return cells
    second = BROWS if BROWS in model.attributes else BROW_RIDGE
    if second not in model.attributes:
        return cells
    return cells + fig_3_8_cells(second=second)[1:]


def people_cells(model, count: int = 12) -> list[Cell]:
    """``count`` random people of the model (seeds 1..count)."""
    return [(f"random {seed}", [("create", ("random", seed), {})]) for seed in range(1, count + 1)]


def attribute_cells(model, values=(-2.0, 0.0, 2.0)) -> list[Cell]:
    """Every attribute of the model at each of ``values`` (shape), on the average face, by Table 5.2
    category."""
    order = list(model.info.get("categories", [])) or sorted({a.category for a in model.attributes.values()})
    names = sorted(model.attributes, key=lambda n: (order.index(model.attributes[n].category)
                                                    if model.attributes[n].category in order else len(order), n))
    return [(f"{name} {value:+.0f}", [("set_attribute", (name, value, "shape"), {})] if value else [])
            for name in names for value in values]


SHEETS = {"demo": demo_cells, "people": people_cells, "attributes": attribute_cells}
