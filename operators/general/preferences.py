# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on preferences page (Edit > Preferences > Add-ons > Faces & Hands): default output folder,
preset override folder, default voice, and the shape cache. ``operators.adapters.paths`` reads it."""
from __future__ import annotations

import bpy

from ..adapters.paths import configure_presets, shape_cache_summary, user_preset_folder

ROOT_PACKAGE = __package__.rsplit(".", 2)[0]       # the extension's package (bl_ext.<repo>.faces_hands)


def _voice_search(self, context, edit_text):
    from ...faces_hands_addon.speech.espeak import voice_names
    return [v for v in voice_names() if edit_text.lower() in v.lower()]


def _presets_changed(self, context):
    configure_presets(ROOT_PACKAGE)


class FH_Preferences(bpy.types.AddonPreferences):
    """Faces & Hands preferences"""

    bl_idname = ROOT_PACKAGE

    output_folder: bpy.props.StringProperty(
        name="Output Folder", subtype="DIR_PATH", default="//",
        description="Where exports (GLB, FBX, Live Link CSV) are suggested by default ('//' = beside the .blend file)")
    preset_folder: bpy.props.StringProperty(
        name="Preset Folder", subtype="DIR_PATH", default="", update=_presets_changed,
        description="Your presets that override the shipped ones, with the same relative paths (e.g. "
                    "face/muscles.json); empty = the extension's own user folder")
    voice: bpy.props.StringProperty(
        name="Default Voice", default="en-us", search=_voice_search,
        description="espeak-ng voice used when a scene's Speech panel leaves the voice empty, e.g. en-us, de, fr")

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "output_folder")
        row = layout.row()
        row.prop(self, "preset_folder")
        row.operator("faces_hands.copy_presets", text="", icon="DUPLICATE")
        if not self.preset_folder:
            layout.label(text=f"Presets in use: {user_preset_folder(ROOT_PACKAGE) or 'shipped only'}", icon="INFO")
        layout.prop(self, "voice")
        count, size = shape_cache_summary()
        row = layout.row()
        row.label(text=f"Shape cache: {count} settled shapes, {size / 1e6:.1f} MB", icon="FILE_CACHE")
        row.operator("faces_hands.clear_shape_cache", text="Clear", icon="TRASH")


CLASSES = [FH_Preferences]
