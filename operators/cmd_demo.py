# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands demo``: the main job on the embedded default data, written under one folder."""
from __future__ import annotations

import bpy

from . import bl_assets, bl_render
from .outputs import atomic_output, check_output_dir, written

NAME = "demo"
HELP = "run the main job on the embedded default data and list what it wrote"


def add_arguments(parser) -> None:
    parser.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")


def run(args, progress) -> int:
    out_dir = check_output_dir(args.out)
    outputs = []
    progress(0.0, "loading default assets")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    collection = bl_assets.add_default_head_assets(scene)
    progress(0.4, "rendering the default assets")
    png = out_dir / "default_assets.png"
    with atomic_output(png) as tmp:
        bl_render.render_objects(scene, list(collection.objects), tmp, size=(480, 480))
    outputs.append(png)
    blend = out_dir / "default_assets.blend"
    with atomic_output(blend) as tmp:
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True, check_existing=False)
    outputs.append(blend)
    progress(1.0, "demo finished")
    print(written(outputs))
    return 0
