# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands build-face | bake | render``: face rigs in batch (render farms, CI)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters.blendfile import save_blend
from ..adapters.outputs import atomic_output, check_output_path, written
from ..adapters.rig_store import get_rig
from ..cli.rig_command import RigCommand
from . import services, sheet
from .objects import EXPORT_ROLES

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".glb", ".gltf", ".fbx")


class BuildFace:
    INPUTS = ("mesh",)
    NAME = "build-face"
    HELP = "build a MEDUSA face rig (default head, or fitted to --mesh) and save it as a .blend"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--mesh", help="head mesh to fit (OBJ, PLY, STL, glTF/GLB, FBX), in any axis orientation "
                                           "(searched; see --forward/--up); a fit that does not look like a face is "
                                           "refused and a preview OUT.fit-preview.png written beside --out")
        axes = ("-Y", "+Y", "Y", "+X", "-X", "X", "+Z", "-Z", "Z")
        parser.add_argument("--forward", choices=axes, metavar="AXIS",
                            help="the axis the face looks along after import, in Blender's axes: one of -Y, +Y, "
                                 "+X, -X, +Z, -Z (write --forward=-Y: a value that starts with '-' needs the '='); "
                                 "give --up too; default: searched")
        parser.add_argument("--up", choices=axes, metavar="AXIS",
                            help="the axis the top of the head points along after import (e.g. --up=+Z); give "
                                 "--forward too; default: searched")
        parser.add_argument("--resolution", choices=("default", "10k"), default="default",
                            help="skin resolution of the default head")
        parser.add_argument("--name", default="FH Head", help="name of the rig object")
        parser.add_argument("--out", required=True, help="output .blend file")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend",))
        if (args.forward is None) != (args.up is None):
            raise UserError("give both --forward and --up (e.g. --forward=-Y --up=+Z), or neither")
        if args.forward and not args.mesh:
            raise UserError("--forward/--up are the axes of a --mesh to fit; the default head needs none")
        if args.mesh:
            from .fit import preview_path
            forward, up = (None if a is None else a if a[0] in "+-" else "+" + a for a in (args.forward, args.up))
            services.build_fitted_from_file(args.mesh, args.name, progress, forward, up,
                                            preview_path(out, (Path(args.mesh),)))
        else:
            services.build_default_rig_object(progress, args.name, args.resolution)
        save_blend(out)
        print(written([out]))
        return 0


class _FaceCommand(RigCommand):
    BLEND_HELP = "a .blend with a face rig (default: build the default head)"
    EXPORT_ROLES = EXPORT_ROLES
    open_rig = staticmethod(services.rig_object)


class Bake(_FaceCommand):
    NAME = "bake"
    HELP = "bake a face rig to shape keys (basis | expressions | animation) and save .glb, .fbx or .blend"

    @classmethod
    def add_options(cls, parser):
        parser.add_argument("--mode", choices=("basis", "expressions", "animation"), required=True)
        parser.add_argument("--preset", default="all", choices=(*services.EXPRESSION_SETS, "all"),
                            help="expression set for --mode expressions, and the targets an animation is "
                                 "expressed with (default: all)")
        parser.add_argument("--animation", default="weights", choices=services.ANIMATION_KINDS,
                            help="--mode animation as engine-ready weights of fixed targets (default) or as the "
                                 "exact per-frame cache (frames: one shape key per frame, for offline renders)")

    @classmethod
    def work(cls, args, obj, out, progress) -> str:
        return services.bake(bpy.context, obj, args.mode, args.preset, progress, args.animation)


def _face_or_character(blend, rig_name=None, progress=None):
    """The face rig of ``blend`` or, when it has none, its character (whose head the sheet frames)."""
    if blend:
        from ..adapters.blendfile import open_blend
        from ..adapters.rig_store import find_rig, is_rig
        open_blend(blend)
        kind = services.KIND if any(is_rig(o, services.KIND) for o in bpy.data.objects) else "character"
        try:
            return find_rig(bpy.data.objects, rig_name, kind)
        except UserError:
            raise UserError("no Faces & Hands face rig or character in this file"
                            + (f" named {rig_name!r}" if rig_name else "")) from None
    return services.rig_object(None, rig_name, progress)


class Render(_FaceCommand):
    NAME = "render"
    HELP = "render a labelled contact sheet of a face rig or a character's head (neutral, muscles, jaw, ARKit, " \
           "visemes)"
    OUTPUTS = (".png",)
    BLEND_HELP = "a .blend with a face rig or a character (default: build the default head)"
    open_rig = staticmethod(_face_or_character)

    @classmethod
    def add_options(cls, parser):
        parser.add_argument("--sheet", choices=("expressions", "muscles"), default="expressions",
                            help="expressions: neutral, muscles, direct parameters, ARKit and visemes; "
                                 "muscles: neutral, muscles and direct parameters only")
        parser.add_argument("--cells", help="comma-separated cells to render, in this order (default: the whole "
                                             "sheet), e.g. neutral,jaw_open,viseme_PP,eyeBlinkLeft")
        parser.add_argument("--columns", type=int, default=10)
        parser.add_argument("--view", choices=tuple(sheet.VIEWS), default="front",
                            help="camera: front (default), three-quarter or side")

    @classmethod
    def check(cls, args) -> None:
        if not 1 <= args.columns <= 50:
            raise UserError("--columns must be between 1 and 50")

    @classmethod
    def work(cls, args, obj, out, progress) -> str:
        return ""

    @classmethod
    def write(cls, args, obj, out, progress) -> None:
        include = ("neutral", "muscles", "direct") + (("arkit", "visemes") if args.sheet == "expressions" else ())
        cells = _chosen(sheet.expression_cells(get_rig(obj)), args.cells) if args.cells else \
            sheet.expression_cells(get_rig(obj), include)
        with atomic_output(out) as tmp:
            sheet.render_sheet(bpy.context, obj, cells, tmp, columns=args.columns, progress=progress,
                               view=args.view)


def _chosen(cells, names: str) -> list:
    """The cells named in ``names`` (comma-separated), in that order; unknown names are refused."""
    known = dict(cells)
    wanted = [name.strip() for name in names.split(",") if name.strip()]
    unknown = [name for name in wanted if name not in known]
    if unknown or not wanted:
        raise UserError(f"--cells: no cell named {', '.join(unknown) or names!r}; cells are "
                        f"{', '.join(list(known)[:8])}, ... (every muscle, direct parameter, ARKit and viseme)")
    return [(name, known[name]) for name in wanted]


class Retarget:
    INPUTS = ("source", "character")
    NAME = "retarget"
    HELP = ("put a take (a face rig's weight animation, a Live Link Face CSV, or an exported GLB/FBX take) onto a "
            "character with ARKit or viseme shape keys and save it as .glb, .fbx or .blend")

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--source", required=True,
                            help="a .blend with a face rig whose animation is baked as weights, a Live Link CSV, "
                                 "a take exported as .glb/.fbx, or Rhubarb mouth cues (.tsv/.json)")
        parser.add_argument("--rig", help="name of the rig object when the source file has several")
        parser.add_argument("--csv-fps", type=float, default=None,
                            help="frame rate the CSV's timecodes count in (default: found in the timecodes; "
                                 "Live Link Face's 60 for a take shorter than a second)")
        parser.add_argument("--character", required=True,
                            help="the character: .blend, .glb/.gltf, .fbx or .obj with shape keys")
        parser.add_argument("--object", help="name of the character's mesh when the file has several")
        parser.add_argument("--fps", type=float, default=None,
                            help="frame rate of the output animation (default: the take's own; 30 for cues)")
        parser.add_argument("--out", required=True, help="output .glb, .fbx or .blend")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".glb", ".fbx", ".blend"))
        for source in (args.source, args.character):
            if Path(source).resolve() == out.resolve():
                raise UserError(f"--out {out} would overwrite the input {source}; choose another file name")
        report = services.retarget(args, out, progress)
        print(report)
        print(written([out]))
        return 0


COMMANDS = [BuildFace, Bake, Render, Retarget]
