# SPDX-License-Identifier: GPL-3.0-or-later
"""The character in Blender: the MPFB2 body skinned to an armature, the face rig on its head and the hand
rigs in its hands as one rig object, its operators and command-line subcommands. ``CLASSES`` and
``COMMANDS`` are collected by ``operators``."""
from ...faces_hands_addon import character as _engine_character  # noqa: F401  (registers the rig kind)
from . import commands, operators

CLASSES = list(operators.CLASSES)
COMMANDS = commands.COMMANDS
