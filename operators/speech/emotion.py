# SPDX-License-Identifier: GPL-3.0-or-later
"""The emotion picker (thesis 4.4.1, 4.4.3): a point on the activation-evaluation disk, from a word of
Table 4.4 or two sliders, shown as a disk icon with the resulting expression; Set Emotion writes that
expression into the face rig's emotion layer, Use for Speech hands the point to Animate Speech."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.emotion import EmotionPoint, expression_for, load_model
from ...faces_hands_addon.emotion.disk import disk_image, strongest_controls
from ..common import controls, fcurves
from ..common.hardened import HardenedOperator
from ..common.registry import on_unregister
from ..common.rig_store import is_rig, rig_of

__all__ = ["CLASSES", "picker_point", "picker_expression", "disk_icon", "disk_preview",
           "CUSTOM"]

CUSTOM = "CUSTOM"
ICON_SIZE = 128
_previews = {"collection": None, "key": None, "model": None}


def _model(fresh: bool = False):
    """The emotion model; the panel reuses one read of the presets, the operators read them afresh (so an
    edited preset counts)."""
    if fresh or _previews.get("model") is None:
        _previews["model"], _previews["key"] = load_model(), None
    return _previews["model"]


def picker_point(settings) -> EmotionPoint:
    word = settings.emotion_word if settings.emotion_word != CUSTOM else ""
    return EmotionPoint(float(settings.emotion_activation), float(settings.emotion_evaluation), word=word)


def picker_expression(settings) -> dict[str, float]:
    """The face control values of the picker's point (Eqs. 4.6-4.10)."""
    return expression_for(picker_point(settings), _model())


def _free_previews() -> None:
    if _previews["collection"] is not None:
        bpy.utils.previews.remove(_previews["collection"])
    _previews.update(collection=None, key=None, model=None)


def disk_icon(settings) -> int:
    """The icon id of the disk showing the picker's point (0 in background mode, where Blender makes no
    icons; the preview's pixels are there all the same)."""
    return disk_preview(settings).icon_id


def disk_preview(settings):
    """The preview holding the disk picture of the picker's point (redrawn only when the point changed)."""
    import bpy.utils.previews
    if _previews["collection"] is None:
        _previews["collection"] = bpy.utils.previews.new()
        on_unregister(_free_previews)
    collection = _previews["collection"]
    preview = collection.get("disk") or collection.new("disk")
    key = (round(settings.emotion_activation, 3), round(settings.emotion_evaluation, 3))
    if _previews["key"] != key:
        model = _model()
        image = disk_image(model.words, tuple(b.word for b in model.basics), picker_point(settings), ICON_SIZE)
        preview.image_size = (ICON_SIZE, ICON_SIZE)
        preview.image_pixels_float = image[::-1].ravel()          # Blender's rows run from the bottom
        _previews["key"] = key
    return preview


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
        model = _model(fresh=True)
        values = expression_for(picker_point(settings), model)
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
