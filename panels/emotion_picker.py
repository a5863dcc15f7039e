# SPDX-License-Identifier: GPL-3.0-or-later
"""What the emotion picker draws (thesis 4.4.1, 4.4.3): the point of the picker's word or sliders, its
expression (Eqs. 4.6-4.10) and the activation-evaluation disk as an icon. Only drawing helpers: the
operators that write to rigs are ``faces_hands.set_emotion`` and ``faces_hands.use_emotion_for_speech``."""
from __future__ import annotations

import bpy

from ..faces_hands_addon.emotion import EmotionPoint, expression_for, load_model
from ..faces_hands_addon.emotion.disk import disk_image, picked_point

__all__ = ["picker_point", "picker_expression", "disk_icon", "disk_preview", "free_previews"]

ICON_SIZE = 128
_state = {"collection": None, "key": None, "model": None}


def _model():
    """One read of the emotion presets for drawing (Set Emotion reads them afresh)."""
    if _state["model"] is None:
        _state["model"], _state["key"] = load_model(), None
    return _state["model"]


def picker_point(settings) -> EmotionPoint:
    return picked_point(settings.emotion_word, settings.emotion_activation, settings.emotion_evaluation,
                        _model().words)


def picker_expression(settings) -> dict[str, float]:
    """The face control values of the picker's point."""
    return expression_for(picker_point(settings), _model())


def disk_icon(settings) -> int:
    """The icon id of the disk (0 in background mode, where Blender makes no icons; the preview's pixels
    are there all the same)."""
    return disk_preview(settings).icon_id


def disk_preview(settings):
    """The preview holding the disk picture of the picker's point (redrawn only when the point changed)."""
    import bpy.utils.previews
    if _state["collection"] is None:
        _state["collection"] = bpy.utils.previews.new()
    collection = _state["collection"]
    preview = collection.get("disk") or collection.new("disk")
    key = (round(settings.emotion_activation, 3), round(settings.emotion_evaluation, 3))
    if _state["key"] != key:
        model = _model()
        image = disk_image(model.words, tuple(b.word for b in model.basics), picker_point(settings), ICON_SIZE)
        preview.image_size = (ICON_SIZE, ICON_SIZE)
        preview.image_pixels_float = image[::-1].ravel()          # Blender's rows run from the bottom
        _state["key"] = key
    return preview


def free_previews() -> None:
    """Called when the extension is unregistered."""
    if _state["collection"] is not None:
        bpy.utils.previews.remove(_state["collection"])
    _state.update(collection=None, key=None, model=None)
