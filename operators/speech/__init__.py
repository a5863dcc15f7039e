# SPDX-License-Identifier: GPL-3.0-or-later
"""The speech subsystem in Blender (thesis 3.1.3, 4.3): speech takes on rigs or viseme shape keys, its
operators and command-line subcommands. ``CLASSES`` and ``COMMANDS`` are collected by ``operators``."""
from . import animate, commands, emotion, operators

CLASSES = list(operators.CLASSES) + list(animate.CLASSES) + list(emotion.CLASSES)
COMMANDS = commands.COMMANDS
