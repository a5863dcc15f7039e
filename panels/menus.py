# SPDX-License-Identifier: GPL-3.0-or-later
"""Menu entries, so every tool is where Blender users look (and F3 search, which searches menus, finds
it): Add > Faces & Hands (the rigs), Object > Faces & Hands (every tool by subsystem), File > Export (the
baked face and hand, the Live Link CSV). Menus only draw; ``MENUS`` is what the registry appends."""
from __future__ import annotations

import bpy

ADD_ITEMS = (("faces_hands.add_character", "Character", "ARMATURE_DATA"),
             ("faces_hands.build_face_rig", "Face Rig (Default Head)", "USER"),
             ("faces_hands.morph_new_face", "Morphable Face", "SHAPEKEY_DATA"),
             ("faces_hands.head_from_photo", "Head from Photo", "IMAGE_DATA"),
             ("faces_hands.build_hand_rig", "Hand Rig", "VIEW_PAN"),
             ("faces_hands.track_pitch", "Pitch Replay from Photos", "SPHERE"),
             ("faces_hands.add_default_assets", "Default Assets (Skull, Jaw, Face)", "ASSET_MANAGER"))

OBJECT_SECTIONS = (
    ("Character", ("faces_hands.add_character", "faces_hands.fit_character", "faces_hands.retarget_character")),
    ("Face", ("faces_hands.locate_landmarks", "faces_hands.fit_face_rig", "faces_hands.live_simulation",
              "faces_hands.reset_controls", "faces_hands.bake_face", "faces_hands.export_face")),
    ("Speech", ("faces_hands.animate_speech", "faces_hands.speak_text", "faces_hands.lipsync_audio",
                "faces_hands.transfer_animation", "faces_hands.export_live_link", "faces_hands.export_mouth_cues")),
    ("Morphable Face", ("faces_hands.morph_make_animatable", "faces_hands.morph_build_model",
                        "faces_hands.morph_save_face", "faces_hands.morph_load_face")),
    ("Photo", ("faces_hands.head_from_photo", "faces_hands.photo_edit_landmarks",
               "faces_hands.photo_head_from_landmarks")),
    ("Hand", ("faces_hands.load_hand_photo", "faces_hands.build_hand_from_photo", "faces_hands.apply_hand_pose",
              "faces_hands.animate_hand", "faces_hands.live_hand", "faces_hands.solve_contractions",
              "faces_hands.bake_hand", "faces_hands.export_hand", "faces_hands.retarget_hand")),
    ("Presets", ("faces_hands.copy_presets",)),
)

EXPORT_ITEMS = (("faces_hands.export_face", "Faces & Hands Face (.glb, .fbx)"),
                ("faces_hands.export_hand", "Faces & Hands Hand (.glb, .fbx)"),
                ("faces_hands.export_live_link", "Live Link Face ARKit Weights (.csv)"),
                ("faces_hands.export_mouth_cues", "Rhubarb Mouth Cues (.tsv, .json)"))


class FH_MT_add(bpy.types.Menu):
    """Add a Faces & Hands rig: the default face, a morphable face, the anatomical hand"""

    bl_idname = "FH_MT_add"
    bl_label = "Faces & Hands"

    def draw(self, context):
        for idname, text, icon in ADD_ITEMS:
            self.layout.operator(idname, text=text, icon=icon)


class FH_MT_object(bpy.types.Menu):
    """Faces & Hands tools for the selected rig or mesh"""

    bl_idname = "FH_MT_object"
    bl_label = "Faces & Hands"

    def draw(self, context):
        layout = self.layout
        for index, (title, idnames) in enumerate(OBJECT_SECTIONS):
            if index:
                layout.separator()
            layout.label(text=title)
            for idname in idnames:
                layout.operator(idname)


def draw_add(self, context):
    self.layout.menu(FH_MT_add.bl_idname, icon="USER")


def draw_object(self, context):
    self.layout.separator()
    self.layout.menu(FH_MT_object.bl_idname)


def draw_export(self, context):
    for idname, text in EXPORT_ITEMS:
        self.layout.operator(idname, text=text)


CLASSES = [FH_MT_add, FH_MT_object]
MENUS = [("VIEW3D_MT_add", draw_add), ("VIEW3D_MT_object", draw_object), ("TOPBAR_MT_file_export", draw_export)]
