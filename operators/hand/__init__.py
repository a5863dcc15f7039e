# SPDX-License-Identifier: GPL-3.0-or-later
"""The hand subsystem in Blender (thesis 6.2): anatomical hand rigs as an armature with bone meshes and a
simulated skin, their operators and command-line subcommands. ``CLASSES`` and ``COMMANDS`` are collected by
``operators``."""
from ...faces_hands_addon import hand as _engine_hand  # noqa: F401  (registers the hand rig kind)
from . import commands, operators

CLASSES = list(operators.CLASSES)
COMMANDS = commands.COMMANDS
