# SPDX-License-Identifier: GPL-3.0-or-later
"""The face subsystem in Blender (thesis 3.1): MEDUSA rigs as objects, their operators and their command-line
subcommands. ``CLASSES`` and ``COMMANDS`` are collected by ``operators``."""
from ...faces_hands_addon import face as _engine_face  # noqa: F401  (registers the face rig kinds)
from . import commands, fit_operators, operators, take_operators

CLASSES = [*operators.CLASSES, *fit_operators.CLASSES, *take_operators.CLASSES]
COMMANDS = commands.COMMANDS
