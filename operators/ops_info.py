# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators that bring the default assets into the scene."""
from __future__ import annotations

import bpy

from . import bl_assets
from .hardened import HardenedOperator


class FH_OT_add_default_assets(HardenedOperator, bpy.types.Operator):
    """Add the default assets (MediaPipe canonical face, myo-sim skull and jaw) to a new collection"""

    bl_idname = "faces_hands.add_default_assets"
    bl_label = "Add Default Head Assets"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        collection = bl_assets.add_default_head_assets(context.scene)
        self.report({"INFO"}, f"Added {len(collection.objects)} objects in '{collection.name}'")
        return {"FINISHED"}


CLASSES = [FH_OT_add_default_assets]
