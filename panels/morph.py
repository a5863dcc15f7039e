# SPDX-License-Identifier: GPL-3.0-or-later
"""Morphable Face sub-panels (mind2model, 5.1): new face, attributes by Table 5.2 category, caricature,
segments (Table 5.1), constraints, database, history. Only draws; edits are operators."""
from __future__ import annotations

import json

import bpy

from ..faces_hands_addon.morph.model import matching_examples
from .base import ROOT, SidebarPanel
from ..names import MORPH_CHARACTER, MORPH_EXAMPLES, MORPH_HISTORY, MORPH_MARKER, MORPH_REFIT, MORPH_STATE

THUMBNAILS = 12
ABOUT = ("Default model: whole heads made from MakeHuman's CC0 target"
         "s on the character's mesh; no substitute for scans")


def morph_object(context):
    obj = context.active_object
    return obj if obj is not None and obj.get(MORPH_MARKER) else None


def _state(obj) -> dict:
    try:
        return json.loads(obj.get(MORPH_STATE, "{}"))
    except ValueError:
        return {}


def examples_shown(obj, settings) -> list[tuple[int, str]]:
    """Database examples that pass the sex / age group / population filters (5.1.1)."""
    try:
        examples = json.loads(obj.get(MORPH_EXAMPLES, "[]"))
    except ValueError:
        return []
    return matching_examples(examples, settings.filter_sex, settings.filter_age, settings.filter_population)


class FH_PT_morph(SidebarPanel, bpy.types.Panel):
    bl_label = "Morphable Face"
    bl_idname = "FH_PT_morph"
    bl_parent_id = ROOT

    def draw(self, context):
        layout = self.layout
        settings = context.scene.faces_hands_morph
        layout.prop(settings, "model_path")
        if not settings.model_path:
            box = layout.box()
            for line in (ABOUT[:60], ABOUT[60:]):
                box.label(text=line, icon="INFO" if line == ABOUT[:60] else "BLANK1")
        row = layout.row(align=True)
        row.operator("faces_hands.morph_new_face", text="Average").kind = "average"
        random = row.operator("faces_hands.morph_new_face", text="Random")
        random.kind, random.seed = "random", settings.seed
        example = row.operator("faces_hands.morph_new_face", text="Example")
        example.kind, example.index = "example", settings.example
        row = layout.row(align=True)
        row.prop(settings, "seed")
        row.prop(settings, "example")
        layout.operator("faces_hands.morph_build_model", icon="MOD_MESHDEFORM")
        obj = morph_object(context)
        if obj is None:
            layout.label(text="Select a morph face to edit it", icon="INFO")
            return
        morph = obj.faces_hands_morph
        row = layout.row(align=True)
        row.prop(morph, "caricature", slider=True)
        row = layout.row(align=True)
        row.operator("faces_hands.morph_save_face", icon="FILE_TICK")
        row.operator("faces_hands.morph_load_face", icon="FILE_FOLDER")
        row = layout.row(align=True)
        row.operator("faces_hands.morph_add_detail", icon="TEXTURE").factor = settings.detail_factor
        row.prop(settings, "detail_factor", text="")
        layout.operator("faces_hands.morph_make_animatable", icon="ARMATURE_DATA")
        row = layout.row(align=True)
        row.operator("faces_hands.morph_link_character", icon="OUTLINER_OB_ARMATURE")
        row.operator("faces_hands.morph_refit_character", icon="FILE_REFRESH")
        body = bpy.data.objects.get(obj.get(MORPH_CHARACTER, "") or "")
        if body is not None and body.get(MORPH_REFIT, "") != obj.get(MORPH_STATE, ""):
            layout.label(text=f"'{body.name}' has its face rig fitted to another head: Refit Face Rig", icon="INFO")


class FH_PT_morph_attributes(SidebarPanel, bpy.types.Panel):
    bl_label = "Attributes"
    bl_idname = "FH_PT_morph_attributes"
    bl_parent_id = "FH_PT_morph"

    @classmethod
    def poll(cls, context):
        return morph_object(context) is not None

    def draw(self, context):
        layout = self.layout
        obj = morph_object(context)
        settings = context.scene.faces_hands_morph
        layout.prop(settings, "slider_filter", text="", icon="VIEWZOOM")
        needle = settings.slider_filter.strip().lower()
        by_category = {}
        for item in obj.faces_hands_morph.sliders:
            if not needle or needle in item.name.lower():
                by_category.setdefault(item.category, []).append(item)
        if not by_category:
            layout.label(text="No attribute matches the filter")
        constrained = {c["attribute"] for c in _state(obj).get("constraints", [])}
        for category, items in by_category.items():
            box = layout.box()
            box.label(text=category.title())
            for item in items:
                row = box.row(align=True)
                row.label(text=item.name)
                row.prop(item, "shape", text="", slider=True)
                if item.has_colour:
                    row.prop(item, "colour", text="", slider=True)
                if item.name in constrained:
                    row.operator("faces_hands.morph_release", text="", icon="LOCKED", depress=True).name = item.name
                else:
                    lock = row.operator("faces_hands.morph_constrain", text="", icon="UNLOCKED")
                    lock.name, lock.part, lock.database = item.name, settings.part, settings.constraint_database


class FH_PT_morph_segments(SidebarPanel, bpy.types.Panel):
    bl_label = "Segments"
    bl_idname = "FH_PT_morph_segments"
    bl_parent_id = "FH_PT_morph"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return morph_object(context) is not None

    def draw(self, context):
        layout = self.layout
        morph = morph_object(context).faces_hands_morph
        layout.prop(morph, "show_segments")
        column = layout.column(align=True)
        for item in morph.segments:
            row = column.row(align=True)
            row.separator(factor=2.0 * item.depth)
            row.prop(item, "selected", text=item.name)
        layout.label(text="Edits, imports and transforms go to the checked segments")
        row = layout.row(align=True)
        row.operator("faces_hands.morph_transform", icon="ORIENTATION_GLOBAL")


class FH_PT_morph_constraints(SidebarPanel, bpy.types.Panel):
    bl_label = "Constraints, Database, History"
    bl_idname = "FH_PT_morph_constraints"
    bl_parent_id = "FH_PT_morph"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return morph_object(context) is not None

    def draw(self, context):
        layout = self.layout
        obj = morph_object(context)
        settings = context.scene.faces_hands_morph
        state = _state(obj)
        row = layout.row(align=True)
        row.prop(settings, "part", text="")
        row.prop(settings, "constraint_database")
        box = layout.box()
        constraints = state.get("constraints", [])
        if not constraints:
            box.label(text="No constraints (lock an attribute to keep its value)")
        for entry in constraints:
            row = box.row(align=True)
            where = f" [{', '.join(entry['segments'])}]" if entry.get("segments") else ""
            row.label(text=f"{entry['attribute']}{where}", icon="LOCKED")
            row.operator("faces_hands.morph_release", text="", icon="X").name = entry["attribute"]
        box = layout.box()
        box.label(text="Database (5.1.1 filters)")
        row = box.row(align=True)
        row.prop(settings, "filter_sex", text="")
        row.prop(settings, "filter_age", text="")
        box.prop(settings, "filter_population")
        box.operator("faces_hands.morph_render_thumbnails", icon="RENDER_STILL")
        for index, name in examples_shown(obj, settings)[:THUMBNAILS]:
            row = box.row(align=True)
            image = bpy.data.images.get(f"FH Example {index:03d}")
            if image is not None and image.preview is not None:
                row.template_icon(icon_value=image.preview.icon_id, scale=3.0)
            row.label(text=name)
            start = row.operator("faces_hands.morph_new_face", text="", icon="USER")
            start.kind, start.index = "example", index
        row = box.row(align=True)
        row.prop(settings, "example")
        row.operator("faces_hands.morph_import_feature", icon="IMPORT").index = settings.example
        box = layout.box()
        row = box.row()
        row.label(text="History")
        row.operator("faces_hands.morph_undo_edit", text="", icon="LOOP_BACK")
        for line in obj.get(MORPH_HISTORY, "").splitlines()[-12:]:
            box.label(text=line)


CLASSES = [FH_PT_morph, FH_PT_morph_attributes, FH_PT_morph_segments, FH_PT_morph_constraints]
