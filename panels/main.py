# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Faces & Hands" tab in the 3D viewport's sidebar (N-panel). Panels only draw."""
from __future__ import annotations

import bpy

from .base import ROOT, SidebarPanel


class FH_PT_main(SidebarPanel, bpy.types.Panel):
    bl_label = "Faces & Hands"
    bl_idname = ROOT

    def draw(self, context):
        column = self.layout.column(align=True)
        column.operator("faces_hands.add_default_assets", icon="MESH_MONKEY")
        column.operator("faces_hands.copy_presets", icon="PRESET")


CLASSES = [FH_PT_main]
