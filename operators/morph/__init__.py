# SPDX-License-Identifier: GPL-3.0-or-later
"""Morphable faces in Blender (thesis 3.2, 5.1: mind2model): morph face objects, their operators and the
``morph`` subcommand. ``CLASSES`` and ``COMMANDS`` are collected by ``operators``."""
from . import commands, operators

CLASSES = list(operators.CLASSES)
COMMANDS = commands.COMMANDS
