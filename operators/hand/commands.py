# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands build-hand | animate-hand | render-hand``: hand rigs in batch."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.hand import motion
from ...faces_hands_addon.hand.template import DEFAULT_MESH, MESHES
from ..adapters.blendfile import save_blend
from ..adapters.outputs import atomic_output, check_output_path, written
from ..adapters.rig_store import get_rig
from ..cli.rig_command import RigCommand
from . import services, sheet
from .objects import EXPORT_ROLES


class BuildHand:
    INPUTS = ("photo", "points")
    NAME = "build-hand"
    HELP = "build an anatomical hand rig (the reference hand, or warped to a photo) and save it as a .blend"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--side", choices=("right", "left"), default="right", help="which hand (default right)")
        parser.add_argument("--photo", help="photo of a flat hand (PNG/JPEG): with --points, the clicked points; "
                                               "alone, the points are found automatically (give --hand-length-mm)")
        parser.add_argument("--points", help="JSON with the clicked feature points and ruler marks (pixels)")
        parser.add_argument("--hand-length-mm", type=float,
                            help="with --photo alone: the hand's length, wrist crease to middle finger tip, in mm "
                                 "(it stands for the ruler)")
        parser.add_argument("--mesh", choices=MESHES, default=DEFAULT_MESH,
                            help="the hand's skin: tube (the WebXR hand shaped round the bones; default) or mpfb2 "
                                 "(MPFB2's hand, the character's)")
        parser.add_argument("--name", default="FH Hand", help="name of the rig object")
        parser.add_argument("--out", required=True, help="output .blend file")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend",))
        photo = None
        if args.points and not args.photo:
            raise UserError("--points needs --photo: the photo the feature points were clicked on")
        if args.photo and not args.points:
            if args.hand_length_mm is None:
                raise UserError("--photo alone finds the feature points automatically; give --hand-length-mm "
                                "(wrist crease to middle finger tip) for the scale, or --points with a ruler")
            if Path(args.photo).resolve() == out.resolve():
                raise UserError("the output must not overwrite an input")
            photo = services.detect_photo(args.photo, args.side, args.hand_length_mm)
        elif args.points:
            if not Path(args.photo).is_file():
                raise UserError(f"{args.photo} does not exist")
            if Path(args.photo).resolve() == out.resolve() or Path(args.points).resolve() == out.resolve():
                raise UserError("the output must not overwrite an input")
            photo = services.read_photo(args.points)
            photo["image"] = str(Path(args.photo).resolve())
        services.build_hand_object(progress, args.name, args.side, photo, args.mesh)
        save_blend(out)
        print(written([out]))
        return 0


class _HandCommand(RigCommand):
    BLEND_HELP = "a .blend with a hand rig (default: build the reference hand)"
    EXPORT_ROLES = EXPORT_ROLES
    open_rig = staticmethod(services.hand_object)


class AnimateHand(_HandCommand):
    NAME = "animate-hand"
    HELP = "animate a hand rig with a preset pose or motion, bake it and export .glb, .fbx or .blend"

    @classmethod
    def add_options(cls, parser):
        parser.add_argument("--preset", required=True, help="a motion or pose of presets/hand/poses.json")
        parser.add_argument("--fps", type=float, default=30.0, help="frame rate of the animation (default 30)")

    @classmethod
    def check(cls, args) -> None:
        """Arguments checked before any rig is built or opened (a wrong name costs no building)."""
        if not 1.0 <= args.fps <= 240.0:
            raise UserError("--fps must be between 1 and 240")
        motion.check_preset_name(args.preset)

    @classmethod
    def work(cls, args, obj, out, progress) -> str:
        scene = bpy.context.scene
        scene.render.fps, scene.render.fps_base = int(round(args.fps)), round(args.fps) / args.fps
        first, last = services.animate(bpy.context, obj, args.preset)
        print(f"keyed {args.preset!r} on frames {first}-{last}")
        return services.bake(bpy.context, obj, progress)


class RenderHand(_HandCommand):
    NAME = "render-hand"
    HELP = "render a labelled contact sheet of a hand rig in preset poses"
    OUTPUTS = (".png",)
    BLEND_HELP = "a .blend with a hand rig (default: the reference hand)"

    @classmethod
    def add_options(cls, parser):
        parser.add_argument("--sheet", choices=("poses", "bulges"), default="poses",
                            help="poses: preset poses simulated; bulges: each geometric muscle contracted, joints held")
        parser.add_argument("--poses", help="comma-separated pose names (default: every preset pose)")
        parser.add_argument("--view", choices=tuple(sheet.VIEWS), default="palm", help="camera (default palm)")
        parser.add_argument("--columns", type=int, default=4)
        parser.add_argument("--bones", action="store_true", help="render the bones instead of the skin")
        parser.add_argument("--cell-size", default="240x300", help="pixels of one cell, WIDTHxHEIGHT (default 240x300)")
        parser.add_argument("--frame", choices=("rest", "pose"), default="rest",
                            help="rest: every cell framed on the hand at rest; pose: each cell on its own pose")
        parser.add_argument("--shading", choices=("studio", "shape"), default="studio",
                            help="studio light, or a matcap that shows surface shape (muscle bulges)")

    @staticmethod
    def _cell_size(args) -> tuple[int, int]:
        try:
            cell_size = tuple(int(v) for v in args.cell_size.lower().split("x"))
        except ValueError:
            cell_size = ()
        if len(cell_size) != 2 or not all(64 <= v <= 4096 for v in cell_size):
            raise UserError("--cell-size must be WIDTHxHEIGHT, each 64-4096 pixels (e.g. 720x900)")
        return cell_size

    @staticmethod
    def _pose_names(args) -> list[str] | None:
        return [n.strip() for n in args.poses.split(",")] if args.poses else None

    @classmethod
    def check(cls, args) -> None:
        if not 1 <= args.columns <= 20:
            raise UserError("--columns must be between 1 and 20")
        cls._cell_size(args)
        if args.poses and args.sheet == "poses":
            motion.check_pose_names(cls._pose_names(args))

    @classmethod
    def work(cls, args, obj, out, progress) -> str:
        return ""

    @classmethod
    def write(cls, args, obj, out, progress) -> None:
        names = cls._pose_names(args)
        rig = get_rig(obj, "hand")
        cells = sheet.bulge_cells(rig) if args.sheet == "bulges" else sheet.pose_cells(rig, names)
        with atomic_output(out) as tmp:
            sheet.render_hand_sheet(bpy.context, obj, cells, tmp, args.view, args.columns,
                                    cell_size=cls._cell_size(args), progress=progress, show_bones=args.bones,
                                    framing=args.frame,
                                    matcap=sheet.SHAPE_MATCAP if args.shading == "shape" else None)


COMMANDS = [BuildHand, AnimateHand, RenderHand]
