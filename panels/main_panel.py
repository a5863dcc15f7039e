# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Faces & Hands" tab in the 3D viewport's sidebar (N-panel). Panels only draw."""
from __future__ import annotations

import bpy


class FH_PT_main(bpy.types.Panel):
    bl_label = "Faces & Hands"
    bl_idname = "FH_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Faces & Hands"

    def draw(self, context):
        layout = self.layout
        layout.operator("faces_hands.add_default_assets", icon="MESH_MONKEY")


CLASSES = [FH_PT_main]
