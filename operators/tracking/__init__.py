# SPDX-License-Identifier: GPL-3.0-or-later
"""The pitch tracker in Blender (thesis 6.3): synthetic recordings, calibration, tracking of ball and hand
from multi-exposure photos and its replay. ``CLASSES`` and ``COMMANDS`` are collected by ``operators``."""
from . import commands, operators

CLASSES = list(operators.CLASSES)
COMMANDS = commands.COMMANDS
