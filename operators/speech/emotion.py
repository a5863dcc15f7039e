# SPDX-License-Identifier: GPL-3.0-or-later
"""The emotion picker's operators (thesis 4.4.1, 4.4.3; the panel is ``panels/emotion_picker``): Set Emotion
writes the expression of the picker's point into the face rig's Emotion layer, Use for Speech hands the
point to Animate Speech."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.emotion import EmotionPoint, expression_for, load_model
from ...faces_hands_addon.emotion.disk import picked_point
from ..adapters import controls, fcurves
from ..bases.hardened import HardenedOperator
from ..adapters.rig_store import is_rig, rig_of

__all__ = ["CLASSES", "picker_point"]


def picker_point(settings, words=None) -> EmotionPoint:
    return picked_point(settings.emotion_word, settings.emotion_activation, settings.emotion_evaluation, words)


def _emotion_animated(obj) -> bool:
    bag = fcurves.existing_channelbag(obj)
    prefix = controls.layer_prefix("emotion")
    return bag is not None and any(c.data_path.startswith(prefix) for c in bag.fcurves)


class FH_OT_set_emotion(HardenedOperator, bpy.types.Operator):
    """Write the picker's expression into the active face rig's Emotion layer (every emotion control: the
    expression's value or 0), optionally as keys at the current frame"""

    bl_idname = "faces_hands.set_emotion"
    bl_label = "Set Emotion on Rig"
    bl_options = {"REGISTER", "UNDO"}

    key: bpy.props.BoolProperty(name="Key", default=False,
                                description="Insert keys at the current frame (otherwise only set the values)")

    @classmethod
    def poll(cls, context):
        return is_rig(rig_of(context.active_object), "face")

    def run(self, context):
        obj = rig_of(context.active_object)
        if not is_rig(obj, "face"):
            raise UserError("select a Faces & Hands face rig (build one with 'Build Face Rig')")
        settings = context.scene.faces_hands
        model = load_model()                 # read afresh: an edited preset counts
        values = expression_for(picker_point(settings, model.words), model)
        names = sorted(set(model.specs) | set(values))
        missing = [n for n in names if controls.prop_name(n, "emotion") not in obj.keys()]
        if len(missing) == len(names):
            raise UserError(f"'{obj.name}' has no emotion layer controls; rebuild the rig")
        frame = context.scene.frame_current
        for name in names:
            if name in missing:
                continue
            obj[controls.prop_name(name, "emotion")] = float(values.get(name, 0.0))
            if self.key:
                obj.keyframe_insert(controls.data_path(name, "emotion"), frame=frame, group="Emotion")
        obj.update_tag()
        point = picker_point(settings)
        label = point.word or f"activation {point.activation:.0f}, evaluation {point.evaluation:.0f}"
        self.report({"INFO"}, f"Emotion '{label}' on '{obj.name}': {len(values)} controls"
                              + (f", keyed at frame {frame}" if self.key else ""))
        if missing:
            self.report({"WARNING"}, f"the rig lacks {len(missing)} emotion controls: {', '.join(missing[:5])}")
        if not self.key and _emotion_animated(obj):
            self.report({"WARNING"}, "the Emotion layer is animated (a take's emotions): the values hold until "
                                     "the frame changes; use Key, or mute the layer")
        return {"FINISHED"}


class FH_OT_use_emotion_for_speech(HardenedOperator, bpy.types.Operator):
    """Use the picker's emotion for the next Animate Speech / Speak take (face and voice, Table 4.5)"""

    bl_idname = "faces_hands.use_emotion_for_speech"
    bl_label = "Use for Speech"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        settings = context.scene.faces_hands
        point = picker_point(settings)
        settings.speech_emotion = point.word or f"{point.activation:g},{point.evaluation:g}"
        self.report({"INFO"}, f"Speech emotion: {settings.speech_emotion}")
        return {"FINISHED"}


CLASSES = [FH_OT_set_emotion, FH_OT_use_emotion_for_speech]
