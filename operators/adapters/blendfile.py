# SPDX-License-Identifier: GPL-3.0-or-later
"""Opening and saving .blend files for the command line (checked paths, clear errors, atomic saves)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.foreign_files import check_path
from .outputs import atomic_output
from .render import quiet_stdout

__all__ = ["open_blend", "save_blend"]


def open_blend(path: str) -> None:
    blend = check_path(path, "the .blend file")
    if blend.suffix.lower() != ".blend":
        raise UserError(f"{blend} is not a .blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(blend.resolve()), load_ui=False)
    except RuntimeError as error:
        raise UserError(f"cannot open {blend}: {error}") from None


def save_blend(path: Path) -> None:
    """Save a copy of the current file to ``path`` (all or nothing)."""
    with atomic_output(path) as tmp, quiet_stdout():
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True, check_existing=False)
