# SPDX-License-Identifier: GPL-3.0-or-later
"""The base every Faces & Hands panel draws from: the 3D viewport's sidebar (N), tab "Faces & Hands"."""
from __future__ import annotations

import json

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
    return obj if obj is not None and obj.get("fh_rig_kind", "face") == kind else None


def draw_rig_controls(layout, context, obj, group_order, nothing: str = "No control matches the filter") -> None:
    """Every animatable control of the rig ``obj`` as a slider, in boxes by group (``group_order`` first,
    others after), filtered by the scene's control filter."""
    settings = context.scene.faces_hands
    layout.prop(settings, "control_filter", text="", icon="VIEWZOOM")
    needle = settings.control_filter.strip().lower()
    try:
        controls = json.loads(obj.get("fh_rig_controls", "[]"))
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
            prop = f"fh.ctrl.{name}"
            if prop in obj.keys():
                column.prop(obj, f'["{prop}"]', text=name.replace("_", " "), slider=True)


def rig_object(context):
    """The rig object of the active object (itself or one of its parts), or None (panels only draw)."""
    obj = context.active_object
    while obj is not None and not obj.get("fh_rig"):
        obj = obj.parent
    return obj
