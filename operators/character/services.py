# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's services for commands, the demo and other subsystems (plain functions): build the
character into a new file, find it in a file, export it."""
from __future__ import annotations

import bpy

from ..bases.jobs import run_job
from .jobs import BuildCharacterJob

__all__ = ["KIND", "build_character_object"]

KIND = "character"


def build_character_object(progress=None, name: str = "FH Character", skeleton: str = "game_engine"):
    """A new empty file holding the default character; returns its body (the rig object)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    print(run_job(BuildCharacterJob(name, skeleton), bpy.context, progress))
    return bpy.data.objects[name]
