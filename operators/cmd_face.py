# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands build-face | bake | render``: face rigs in batch (render farms, CI)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..faces_hands_addon.errors import UserError
from . import bl_export, bl_face, bl_sheet
from .bl_render import quiet_stdout
from .jobs import run_job
from .outputs import atomic_output, check_output_path, written

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".glb", ".gltf", ".fbx")


def open_blend(path: str) -> None:
    blend = Path(path)
    if not blend.is_file():
        raise UserError(f"{blend} does not exist")
    if blend.suffix.lower() != ".blend":
        raise UserError(f"{blend} is not a .blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(blend.resolve()), load_ui=False)
    except RuntimeError as error:
        raise UserError(f"cannot open {blend}: {error}") from None


def find_rig(name: str | None = None):
    rigs = [o for o in bpy.data.objects if bl_face.is_rig(o)]
    if name:
        rigs = [o for o in rigs if o.name == name]
    if not rigs:
        raise UserError("no Faces & Hands face rig in this file" + (f" named {name!r}" if name else ""))
    return rigs[0]


def save_blend(path: Path) -> None:
    with atomic_output(path) as tmp, quiet_stdout():
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True, check_existing=False)


def build_default(progress, name: str = "FH Head", resolution: str = "default"):
    from .ops_face import BuildDefaultRigJob
    bpy.ops.wm.read_homefile(use_empty=True)
    return run_job(BuildDefaultRigJob(name, resolution), bpy.context, progress), find_rig(name)


def rig_from_args(args, progress):
    """The rig object of ``--blend`` (picked by ``--rig`` when there are several), or a new default head."""
    if args.blend:
        open_blend(args.blend)
        return find_rig(args.rig)
    return build_default(progress)[1]


# ------------------------------------------------------------------------------ build-face
class BuildFace:
    NAME = "build-face"
    HELP = "build a MEDUSA face rig (default head, or fitted to --mesh) and save it as a .blend"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--mesh", help="head mesh to fit (OBJ, PLY, STL, glTF/GLB, FBX), facing -Y, Z up")
        parser.add_argument("--resolution", choices=("default", "10k"), default="default",
                            help="skin resolution of the default head")
        parser.add_argument("--name", default="FH Head", help="name of the rig object")
        parser.add_argument("--out", required=True, help="output .blend file")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend",))
        if args.mesh:
            from . import bl_fit
            bl_fit.build_fitted_from_file(args.mesh, args.name, progress)
        else:
            build_default(progress, args.name, args.resolution)
        save_blend(out)
        print(written([out]))
        return 0


# ------------------------------------------------------------------------------ bake
class Bake:
    NAME = "bake"
    HELP = "bake a face rig to shape keys (basis | expressions | animation) and save .glb, .fbx or .blend"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--blend", help="a .blend with a face rig (default: build the default head)")
        parser.add_argument("--mode", choices=("basis", "expressions", "animation"), required=True)
        parser.add_argument("--preset", default="all", choices=("arkit", "visemes", "named", "all"),
                            help="expression set for --mode expressions (default: all)")
        parser.add_argument("--rig", help="name of the rig object when the file has several")
        parser.add_argument("--out", required=True, help="output .glb, .fbx or .blend")

    @staticmethod
    def run(args, progress) -> int:
        from .ops_face import BakeJob
        out = check_output_path(args.out, (".glb", ".fbx", ".blend"))
        rig = rig_from_args(args, progress)
        report = run_job(BakeJob(bpy.context, rig, args.mode.upper(), args.preset), bpy.context, progress)
        print(report)
        if out.suffix.lower() == ".blend":
            save_blend(out)
        else:
            bl_export.export_rig(bpy.context, rig, str(out))
        print(written([out]))
        return 0


# ------------------------------------------------------------------------------ render
class Render:
    NAME = "render"
    HELP = "render a labelled contact sheet of a face rig (neutral, muscles, jaw, ARKit, visemes)"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--blend", help="a .blend with a face rig (default: the default head)")
        parser.add_argument("--sheet", choices=("expressions", "muscles"), default="expressions",
                            help="expressions: neutral, muscles, direct parameters, ARKit and visemes; "
                                 "muscles: neutral, muscles and direct parameters only")
        parser.add_argument("--rig", help="name of the rig object when the file has several")
        parser.add_argument("--columns", type=int, default=10)
        parser.add_argument("--view", choices=tuple(bl_sheet.VIEWS), default="front",
                            help="camera: front (default), three-quarter or side")
        parser.add_argument("--out", required=True, help="output .png")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".png",))
        if not 1 <= args.columns <= 50:
            raise UserError("--columns must be between 1 and 50")
        rig_obj = rig_from_args(args, progress)
        rig = bl_face.get_rig(rig_obj)
        include = ("neutral", "muscles", "direct") + (("arkit", "visemes") if args.sheet == "expressions" else ())
        cells = bl_sheet.expression_cells(rig, include)
        with atomic_output(out) as tmp:
            bl_sheet.render_sheet(bpy.context, rig_obj, cells, tmp, columns=args.columns, progress=progress,
                                  view=args.view)
        print(written([out]))
        return 0
