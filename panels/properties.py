# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene-level settings of the extension (animatable controls of rigs live on the rig objects)."""
from __future__ import annotations

import bpy

def _voice_search(self, context, edit_text):
    """Suggest espeak-ng voices while typing."""
    from ..faces_hands_addon.speech.espeak import voice_names
    return [v for v in voice_names() if edit_text.lower() in v.lower()]


def _style_items(self, context):
    """The character styles of the behaviour preset (the artist's copy wins), after "None"."""
    from ..faces_hands_addon.behavior.styles import style_names
    try:
        names = style_names()
    except Exception:  # a broken user preset must not break the panel; Speak reports it
        names = ["neutral"]
    _style_items.cache = [("NONE", "None", "Lip sync only: no blinks, brows, gaze or head motion")] + [
        (n, n.replace("_", " ").title(), f"Non-verbal behaviour in the '{n}' style (thesis 4.2.2)") for n in names]
    return _style_items.cache


def _emotion_word_items(self, context):
    """Table 4.4's words for the emotion picker, after "Custom" (the sliders' own point)."""
    from ..faces_hands_addon.emotion import load_words
    try:
        words = sorted(load_words())
    except Exception:  # a broken user preset must not break the panel; Set Emotion reports it
        words = []
    _emotion_word_items.cache = [("CUSTOM", "Custom", "The point of the Activation and Evaluation sliders")] + [
        (w, w.replace("_", " ").title(), f"'{w}' from the emotion table (Table 4.4)") for w in words]
    return _emotion_word_items.cache


def _emotion_word_chosen(self, context):
    """A word puts the sliders on its point (set directly, so the sliders' own update does not run)."""
    from ..faces_hands_addon.emotion import load_words
    point = load_words().get(self.emotion_word) if self.emotion_word != "CUSTOM" else None
    if point is not None:
        self["emotion_activation"], self["emotion_evaluation"] = point.activation, point.evaluation


def _emotion_point_moved(self, context):
    """Moving a slider leaves the word's point: the menu shows "Custom"."""
    self["emotion_word"] = 0


class FH_SceneSettings(bpy.types.PropertyGroup):
    """Faces & Hands settings stored in the .blend file"""

    control_filter: bpy.props.StringProperty(
        name="Filter", description="Show only controls whose name contains this text", default="")
    speech_text: bpy.props.StringProperty(
        name="Text", default="Can you show me the way to the conference hall?",
        description="What the character says. Emoticons such as :-) ;-) :-( add emotion tags")
    speech_text_block: bpy.props.PointerProperty(
        name="Text Block", type=bpy.types.Text,
        description="Speak this text datablock instead of the line above (for longer texts)")
    speech_voice: bpy.props.StringProperty(
        name="Voice", default="", search=_voice_search,
        description="espeak-ng voice or language, e.g. en-us, en-gb, de, fr, ru (empty: the preferences' voice)")
    speech_rate: bpy.props.IntProperty(name="Rate", default=175, min=80, max=450,
                                       description="Speaking rate in words per minute")
    speech_pitch: bpy.props.IntProperty(name="Pitch", default=50, min=0, max=100,
                                        description="Voice pitch (espeak-ng scale, 50 = normal)")
    speech_volume: bpy.props.IntProperty(name="Volume", default=100, min=0, max=200,
                                         description="Loudness in percent")
    behavior_style: bpy.props.EnumProperty(
        name="Behaviour", items=_style_items,
        description="Non-verbal behaviour with the speech (blinks, brow raises, gaze, thinking faces) in a "
                    "character style, on its own layer of the face rig")
    behavior_seed: bpy.props.IntProperty(name="Seed", default=0, min=0,
                                         description="Seed of the behaviour's random choices (same seed, same "
                                                     "animation)")
    speech_emotion: bpy.props.StringProperty(
        name="Emotion", default="",
        description="An emotion for the whole take, in face and voice: a word (joy, fear, anxiety, ...) or "
                    "activation,evaluation such as 50,-20 (empty: only the emoticons' emotions)")
    emotion_word: bpy.props.EnumProperty(
        name="Emotion Word", items=_emotion_word_items, update=_emotion_word_chosen,
        description="An emotion word of the table (thesis Table 4.4): puts the point on the disk at its "
                    "activation and evaluation")
    emotion_activation: bpy.props.FloatProperty(
        name="Activation", default=50.0, min=-100.0, max=100.0, update=_emotion_point_moved,
        description="Vertical axis of the emotion disk: passive (-100) to active (+100)")
    emotion_evaluation: bpy.props.FloatProperty(
        name="Evaluation", default=50.0, min=-100.0, max=100.0, update=_emotion_point_moved,
        description="Horizontal axis of the emotion disk: negative (-100) to positive (+100)")
    audio_path: bpy.props.StringProperty(name="Audio", subtype="FILE_PATH",
                                         description="Recorded speech: WAV, FLAC or OGG, any rate")
    audio_transcript: bpy.props.StringProperty(
        name="Transcript", description="What is said in the recording (without it, phones are "
                                       "recognised, which is less accurate)")


class FH_RuntimeState(bpy.types.PropertyGroup):
    """Faces & Hands state of this Blender session (window manager: not meant to outlive the session)"""

    live_object: bpy.props.StringProperty(
        name="Live Object", default="", options={"SKIP_SAVE"},
        description="The rig being simulated live (empty when the live simulation is off)")


CLASSES = [FH_SceneSettings, FH_RuntimeState]
PROPERTIES = [(bpy.types.Scene, "faces_hands", bpy.props.PointerProperty(type=FH_SceneSettings)),
              (bpy.types.WindowManager, "faces_hands_runtime", bpy.props.PointerProperty(type=FH_RuntimeState))]
