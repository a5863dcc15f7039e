# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators that write a file the artist names: a file browser opening in the preferences' output folder
with a name from the .blend (or the rig), and, for baked rigs, the export options Blender users expect
from File > Export (frame range, selected parts only, scale)."""
from __future__ import annotations

import bpy

from ..adapters.export import ExportOptions
from ..adapters.paths import output_folder

__all__ = ["SaveFileOperator", "ExportRigOperator"]


class SaveFileOperator:
    """Mixin: ``filepath`` + ``filter_glob`` and an ``invoke`` that proposes ``<output folder>/<name><ext>``.
    Subclasses set ``file_suffix`` (".glb") and may override ``default_stem(context)``."""

    file_suffix = ".glb"

    filepath: bpy.props.StringProperty(subtype="FILE_PATH", description="Where to write the file")
    filter_glob: bpy.props.StringProperty(default="*.glb;*.fbx", options={"HIDDEN"},
                                          description="File types the file browser shows")

    def default_stem(self, context) -> str:
        obj = context.active_object
        return bpy.path.display_name_from_filepath(bpy.data.filepath) or (obj.name if obj else "untitled")

    def invoke(self, context, event):
        if not self.filepath:
            name = bpy.path.clean_name(self.default_stem(context)) + self.file_suffix
            self.filepath = str(output_folder() / name)
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


class ExportRigOperator(SaveFileOperator):
    """Mixin for exporting a baked rig (.glb or .fbx); ``export_options()`` gathers the settings."""

    use_scene_range: bpy.props.BoolProperty(
        name="Scene Frame Range", default=True,
        description="Export the scene's frame range (off: the Start and End frames below)")
    frame_start: bpy.props.IntProperty(name="Start", default=1, min=0, description="First frame to export")
    frame_end: bpy.props.IntProperty(name="End", default=250, min=0, description="Last frame to export")
    use_selection: bpy.props.BoolProperty(
        name="Selected Parts Only", default=False,
        description="Export only the parts of the rig that are selected (e.g. the skin without teeth)")
    global_scale: bpy.props.FloatProperty(
        name="Scale", default=1.0, min=0.001, max=1000.0, soft_min=0.01, soft_max=100.0,
        description="Scale of the exported rig (100 for engines that count in centimetres)")

    def export_options(self, clip: str | None = None) -> ExportOptions:
        frame_range = None if self.use_scene_range else (self.frame_start, self.frame_end)
        return ExportOptions(clip=clip, frame_range=frame_range, scale=self.global_scale,
                             selected_only=self.use_selection)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "use_scene_range")
        column = layout.column(align=True)
        column.enabled = not self.use_scene_range
        column.prop(self, "frame_start")
        column.prop(self, "frame_end")
        layout.prop(self, "use_selection")
        layout.prop(self, "global_scale")
