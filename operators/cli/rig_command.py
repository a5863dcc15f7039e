# SPDX-License-Identifier: GPL-3.0-or-later
"""The one base of the commands that work on a rig (``bake``, ``render``, ``animate-hand``, ``render-hand``,
...): ``--blend`` (a .blend holding the rig; without it the subsystem builds its default rig), ``--rig`` (the
rig object's name when the file has several) and ``--out``, checked before any work (its suffix, its
folder, never one of the inputs). Then the subsystem's work, the output written in one go (a .glb, .fbx or
.blend saved or exported, or a picture) and the files written reported."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters.export import save_or_export
from ..adapters.outputs import check_output_path, written

__all__ = ["RigCommand"]


class RigCommand:
    """Subclasses set ``NAME``, ``HELP``, ``OUTPUTS`` (allowed suffixes), ``BLEND_HELP``, ``EXPORT_ROLES`` and
    ``open_rig`` (``(blend or None, rig name or None, progress) -> rig object``: the subsystem's service) and
    implement ``work(args, obj, out, progress) -> report``; ``add_options`` adds their own arguments;
    ``write`` saves or exports the rig (override for pictures)."""

    NAME = HELP = ""
    INPUTS = ("blend",)                   # files the command line checks before any work
    OUTPUTS: tuple[str, ...] = (".glb", ".fbx", ".blend")
    BLEND_HELP = "a .blend with the rig (default: build the default rig)"
    EXPORT_ROLES: tuple[str, ...] = ()
    open_rig = None

    @classmethod
    def add_arguments(cls, parser) -> None:
        parser.add_argument("--blend", help=cls.BLEND_HELP)
        parser.add_argument("--rig", help="name of the rig object when the file has several")
        cls.add_options(parser)
        parser.add_argument("--out", required=True, help=f"output {', '.join(cls.OUTPUTS)}")

    @classmethod
    def add_options(cls, parser) -> None:
        """The command's own arguments."""

    @classmethod
    def run(cls, args, progress) -> int:
        out = check_output_path(args.out, cls.OUTPUTS)
        if args.blend and Path(args.blend).resolve() == out.resolve():
            raise UserError(f"--out {out} would overwrite the input --blend; choose another file name")
        cls.check(args)
        obj = cls.rig_object(args, progress)
        report = cls.work(args, obj, out, progress)
        if report:
            print(report)
        cls.write(args, obj, out, progress)
        print(written([out]))
        return 0

    @classmethod
    def check(cls, args) -> None:
        """Refuse bad arguments before any work (UserError)."""

    @classmethod
    def rig_object(cls, args, progress):
        return cls.open_rig(args.blend, args.rig, progress)

    @classmethod
    def work(cls, args, obj, out: Path, progress) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def write(cls, args, obj, out: Path, progress) -> None:
        save_or_export(bpy.context, obj, out, cls.EXPORT_ROLES)
