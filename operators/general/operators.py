# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of no single subsystem: the default assets into the scene, the presets into the user folder."""
from __future__ import annotations

import bpy

from ..bases.hardened import HardenedOperator
from ..adapters.paths import clear_shape_cache, copy_presets
from . import assets


class FH_OT_add_default_assets(HardenedOperator, bpy.types.Operator):
    """Add the default assets (MediaPipe canonical face, myo-sim skull and jaw) to a new collection"""

    bl_idname = "faces_hands.add_default_assets"
    bl_label = "Add Default Head Assets"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        collection = assets.add_default_head_assets(context.scene)
        self.report({"INFO"}, f"Added {len(collection.objects)} objects in '{collection.name}'")
        return {"FINISHED"}


class FH_OT_copy_presets(HardenedOperator, bpy.types.Operator):
    """Copy the shipped presets (muscles, landmarks, expressions, speech targets) into your user preset
    folder, where your edits override the shipped ones and survive updates"""

    bl_idname = "faces_hands.copy_presets"
    bl_label = "Copy Presets for Editing"
    bl_options = {"REGISTER"}

    overwrite: bpy.props.BoolProperty(name="Overwrite", default=False,
                                      description="Replace copies you already have with the shipped presets")

    def run(self, context):
        folder, copied = copy_presets(self.overwrite)
        self.report({"INFO"}, f"Copied {len(copied)} presets to {folder}" if copied
                    else f"Your presets in {folder} are up to date (nothing copied)")
        return {"FINISHED"}


class FH_OT_clear_shape_cache(HardenedOperator, bpy.types.Operator):
    """Delete the cached settled target shapes (they are simulated again at the next bake)"""

    bl_idname = "faces_hands.clear_shape_cache"
    bl_label = "Clear Shape Cache"
    bl_options = {"REGISTER"}

    def run(self, context):
        self.report({"INFO"}, f"Removed {clear_shape_cache()} cached shapes")
        return {"FINISHED"}


CLASSES = [FH_OT_add_default_assets, FH_OT_copy_presets, FH_OT_clear_shape_cache]
