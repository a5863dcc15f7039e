# SPDX-License-Identifier: GPL-3.0-or-later
"""Faces from photographs and back into them in Blender (thesis 3.2.4-3.2.5): Head from Photo, the landmark
points to correct by hand over the photo, renders into the photo and talking photos. ``CLASSES`` and
``COMMANDS`` are collected by ``operators``."""
from ...faces_hands_addon import photo as _engine_photo  # noqa: F401  (the photo engine package)
from . import commands, operators

CLASSES = list(operators.CLASSES)
COMMANDS = commands.COMMANDS
