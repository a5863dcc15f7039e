# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech sub-panel: text-to-speech and recorded-audio lip sync, and the emotion picker. Only draws."""
from __future__ import annotations

import bpy

from ..faces_hands_addon.core.errors import UserError
from ..faces_hands_addon.emotion.disk import strongest_controls
from . import emotion_picker as picker
from .base import ROOT, SidebarPanel
from ..names import MOUTH_CUES, TAKE_LAYERS


class FH_PT_speech(SidebarPanel, bpy.types.Panel):
    bl_label = "Speech"
    bl_idname = "FH_PT_speech"
    bl_parent_id = ROOT

    def draw(self, context):
        layout = self.layout
        settings = context.scene.faces_hands
        obj = context.active_object
        if obj is None:
            layout.label(text="Select a face rig or a mesh with viseme shape keys", icon="INFO")
        box = layout.box()
        box.label(text="From Text", icon="TEXT")
        box.prop(settings, "speech_text", text="")
        box.prop(settings, "speech_text_block")
        row = box.row(align=True)
        row.prop(settings, "speech_voice")
        row.prop(settings, "speech_rate")
        row = box.row(align=True)
        row.prop(settings, "speech_pitch")
        row.prop(settings, "speech_volume")
        box.operator("faces_hands.speak_text", icon="PLAY_SOUND")
        box = layout.box()
        box.label(text="Non-Verbal Behaviour and Emotion (face rigs)", icon="OUTLINER_OB_ARMATURE")
        row = box.row(align=True)
        row.prop(settings, "behavior_style")
        row.prop(settings, "behavior_seed")
        box.prop(settings, "speech_emotion")
        box = layout.box()
        box.label(text="From Recorded Audio", icon="SOUND")
        box.prop(settings, "audio_path", text="")
        box.prop(settings, "audio_transcript", text="")
        box.operator("faces_hands.lipsync_audio", icon="SPEAKER")
        box = layout.box()
        box.label(text="Animate Speech: lip sync + behaviour + emotion, one layer each", icon="ANIM")
        row = box.row(align=True)
        row.operator("faces_hands.animate_speech", text="From Text", icon="TEXT").source = "TEXT"
        row.operator("faces_hands.animate_speech", text="From Audio", icon="SOUND").source = "AUDIO"
        if obj is not None and obj.get(TAKE_LAYERS):
            row = box.row(align=True)
            for layer in ["speech", *str(obj[TAKE_LAYERS]).split()]:
                row.operator("faces_hands.mute_speech_layer", text=layer.capitalize(),
                             icon="HIDE_OFF").layer = layer.capitalize()
        if obj is not None and obj.get(MOUTH_CUES):
            layout.operator("faces_hands.export_mouth_cues", icon="EXPORT")


class FH_PT_emotion(SidebarPanel, bpy.types.Panel):
    """The emotion picker: a point on the activation-evaluation disk (thesis 4.4.1) and its expression"""

    bl_label = "Emotion"
    bl_idname = "FH_PT_emotion"
    bl_parent_id = "FH_PT_speech"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        settings = context.scene.faces_hands
        layout.prop(settings, "emotion_word", text="")
        col = layout.column(align=True)
        col.prop(settings, "emotion_activation", slider=True)
        col.prop(settings, "emotion_evaluation", slider=True)
        try:
            icon = picker.disk_icon(settings)
            values = picker.picker_expression(settings)
        except UserError as error:
            layout.label(text=str(error), icon="ERROR")
            return
        layout.template_icon(icon_value=icon, scale=8.0)
        point = picker.picker_point(settings)
        layout.label(text=f"Angle {point.angle:.0f} deg, intensity {min(point.radius, 100):.0f} of 100")
        box = layout.box()
        strongest = strongest_controls(values)
        if not strongest:
            box.label(text="Neutral: no expression")
        for name, value in strongest:
            row = box.row()
            row.label(text=name.replace("_", " "))
            row.label(text=f"{value:.2f}")
        row = layout.row(align=True)
        row.operator("faces_hands.set_emotion", icon="SHAPEKEY_DATA")
        row.operator("faces_hands.set_emotion", text="Key", icon="KEY_HLT").key = True
        layout.operator("faces_hands.use_emotion_for_speech", icon="PLAY_SOUND")


CLASSES = [FH_PT_speech, FH_PT_emotion]
