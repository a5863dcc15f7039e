# SPDX-License-Identifier: GPL-3.0-or-later
"""The base every Faces & Hands panel draws from: the 3D viewport's sidebar (N), tab "Faces & Hands"."""
from __future__ import annotations

import json

from ..names import RIG_CONTROLS, RIG_KIND, RIG_MARKER, control_property

CATEGORY = "Faces & Hands"
ROOT = "FH_PT_main"


class SidebarPanel:
    """Mixin for ``bpy.types.Panel`` subclasses: where the panel lives. Sub-panels set ``bl_parent_id``."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY


def rig_of_kind(context, kind: str):
    """The rig object of the active object if it is a rig of ``kind`` ("face", "hand"), else None."""
    obj = rig_object(context)
    return obj if obj is not None and obj.get(RIG_KIND, "face") == kind else None


def draw_rig_controls(layout, context, obj, group_order, nothing: str = "No control matches the filter") -> None:
    """Every animatable control of the rig ``obj`` as a slider, in boxes by group (``group_order`` first,
    others after), filtered by the scene's control filter."""
    settings = context.scene.faces_hands
    layout.prop(settings, "control_filter", text="", icon="VIEWZOOM")
    needle = settings.control_filter.strip().lower()
    try:
        controls = json.loads(obj.get(RIG_CONTROLS, "[]"))
    except ValueError:
        controls = []
    by_group = {}
    for name, group, _kind in controls:
        if not needle or needle in name.lower():
            by_group.setdefault(group, []).append(name)
    if not by_group:
        layout.label(text=nothing)
    for group in [g for g in group_order if g in by_group] + sorted(set(by_group) - set(group_order)):
        box = layout.box()
        box.label(text=group.title())
        column = box.column(align=True)
        for name in by_group[group]:
            prop = control_property(name, "ctrl")
            if prop in obj.keys():
                column.prop(obj, f'["{prop}"]', text=name.replace("_", " "), slider=True)


def rig_object(context):
    """The rig object of the active object (itself or one of its parts), or None (panels only draw)."""
    obj = context.active_object
    while obj is not None and not obj.get(RIG_MARKER):
        obj = obj.parent
    return obj


def draw_live_row(layout, context, live_operator: str) -> None:
    """The row every rig panel starts with: Live Simulation (Stop Live while it runs) and Reset."""
    row = layout.row(align=True)
    running = bool(context.window_manager.faces_hands_runtime.live_object)
    row.operator(live_operator, text="Stop Live" if running else "Live Simulation",
                 icon="PAUSE" if running else "PLAY", depress=running)
    row.operator("faces_hands.reset_controls", icon="LOOP_BACK")


def draw_bake_box(layout, bake_operator: str, export_operator: str, bake_enum: str | None = None,
                  bake_icon: str = "SHAPEKEY_DATA"):
    """Bake (a menu of ``bake_enum`` when the operator has modes) and Export in one box; returns the box for
    the panel's own rows under them."""
    box = layout.box()
    row = box.row(align=True)
    if bake_enum:
        row.operator_menu_enum(bake_operator, bake_enum, text="Bake", icon=bake_icon)
    else:
        row.operator(bake_operator, text="Bake", icon=bake_icon)
    row.operator(export_operator, text="Export", icon="EXPORT")
    return box


class RigControlsPanel(SidebarPanel):
    """Mixin of a rig's control sub-panel: set ``rig_kind``, ``group_order`` and ``nothing`` (the text when the
    filter matches no control), plus the usual ``bl_*`` names."""

    rig_kind = "face"
    group_order: tuple[str, ...] = ()
    nothing = "No control matches the filter"

    @classmethod
    def poll(cls, context):
        return rig_of_kind(context, cls.rig_kind) is not None

    def draw(self, context):
        draw_rig_controls(self.layout, context, rig_of_kind(context, self.rig_kind), self.group_order, self.nothing)
