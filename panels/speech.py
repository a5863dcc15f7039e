# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech sub-panel: text-to-speech and recorded-audio lip sync. Only draws."""
from __future__ import annotations

import bpy

from .base import ROOT, SidebarPanel


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
        if obj is not None and obj.get("fh_take_layers"):
            row = box.row(align=True)
            for layer in ["speech", *str(obj["fh_take_layers"]).split()]:
                row.operator("faces_hands.mute_speech_layer", text=layer.capitalize(),
                             icon="HIDE_OFF").layer = layer.capitalize()
        if obj is not None and obj.get("fh_mouth_cues"):
            layout.operator("faces_hands.export_mouth_cues", icon="EXPORT")


CLASSES = [FH_PT_speech]
