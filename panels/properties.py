# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene-level settings of the extension (animatable controls of rigs live on the rig objects)."""
from __future__ import annotations

import bpy


class FH_SceneSettings(bpy.types.PropertyGroup):
    """Faces & Hands settings stored in the .blend file"""

    control_filter: bpy.props.StringProperty(
        name="Filter", description="Show only controls whose name contains this text", default="")


CLASSES = [FH_SceneSettings]
PROPERTIES = [(bpy.types.Scene, "faces_hands", bpy.props.PointerProperty(type=FH_SceneSettings))]
