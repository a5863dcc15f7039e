# SPDX-License-Identifier: GPL-3.0-or-later
"""Materials the operators create: one place that knows how Blender versions differ."""
from __future__ import annotations

import bpy

__all__ = ["enable_nodes"]


def enable_nodes(material) -> None:
    """Give ``material`` its shader node tree. Blender 4.x needs ``use_nodes``; from 5.0 every material has
    its tree and the flag is deprecated (setting it prints a warning), so it is left alone there."""
    if bpy.app.version < (5, 0, 0):
        material.use_nodes = True
