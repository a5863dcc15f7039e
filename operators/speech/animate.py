# SPDX-License-Identifier: GPL-3.0-or-later
"""Animate Speech: one operator for the whole performance of a face rig (thesis 4.2, 4.3.5, 4.4) from text
or from recorded audio + transcript: lip sync (the speech layer), non-verbal behaviour in a character
style with a seed (the behaviour layer and the head motion), the emoticons' and the take's emotion (the
emotion layer), and for recordings the loudness scaling of 4.2.1 "Volume-controlled Intensity".

Each layer is its own F-curve group of the rig's action ("Speech", "Behavior", "Emotion", "Head"), so the
artist mutes or tweaks one in the Dope Sheet or Graph Editor; the take is put on the rig by
``apply.apply_take`` like Speak Text's and Lip Sync Audio's takes (it replaces their takes and they replace
it). The work runs as a job in steps (progress bar, Esc cancels before anything is written), undoable.
"""
from __future__ import annotations

import os

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.modal import JobOperator
from ..adapters.paths import default_voice
from ..adapters.timing import scene_fps
from . import apply

__all__ = ["AnimateSpeechJob", "FH_OT_animate_speech", "FH_OT_mute_speech_layer", "check_inputs", "set_layer_mute"]


def check_inputs(kind: str, source: str, text: str, path: str, style: str | None, emotion_text: str):
    """Every input checked before the slow part: a face rig, something to say or a readable audio file
    of an allowed length, a known style, a known emotion. Returns ``(style, emotion)``."""
    from ...faces_hands_addon.behavior.styles import load_style
    from ...faces_hands_addon.speech.audio import audio_header
    from ...faces_hands_addon.emotion import parse_emotion
    if kind != "muscles":
        raise UserError("Animate Speech needs a Faces & Hands face rig (behaviour and emotion drive its "
                        "muscles); for a mesh with viseme shape keys use Speak Text or Lip Sync Audio")
    if source == "TEXT" and not text.strip():
        raise UserError("there is no text to speak; type some into the Speech panel")
    if source == "AUDIO":
        if not path:
            raise UserError("choose an audio file in the Speech panel first (or switch the source to Text)")
        if not os.path.isfile(path):
            raise UserError(f"the audio file {path} does not exist")
        audio_header(path)
    if style is not None:
        load_style(style)
    return style, parse_emotion(emotion_text)


class _Cancelled(Exception):
    """Raised in the worker at its next progress report once the job was cancelled."""


class AnimateSpeechJob(Job):
    """Three steps (the take, its behaviour and emotion, its loudness), then ``commit`` writes it.

    The take (synthesis or alignment, the slow part: about 80 s for 10 minutes of audio) runs in a worker
    thread on engine data only, so the modal operator keeps Blender responsive, shows its progress and
    Esc cancels at once: the worker stops at its next progress report and its result is dropped; nothing
    is written before ``commit``."""

    label = "Animating speech"

    def __init__(self, obj_name: str, make_take, style, seed: int, emotion, loudness: bool,
                 audio_path: str | None, start_frame: int):
        self.obj_name, self.make_take = obj_name, make_take
        self.style, self.seed, self.emotion, self.loudness = style, seed, emotion, loudness
        self.audio_path, self.start_frame = audio_path, start_frame
        self.take, self.stage, self.curve = None, 0, None
        self._thread, self._result, self._error, self._fraction, self._cancelled = None, None, None, 0.0, False

    def _report(self, fraction: float, message: str = "") -> None:
        if self._cancelled:
            raise _Cancelled()
        self._fraction = float(fraction)

    def _work(self) -> None:
        try:
            self._result = self.make_take(self._report)
        except BaseException as error:      # handed to the main thread by step()
            self._error = error

    def _take_step(self) -> float:
        import threading
        if self._thread is None:
            self._thread = threading.Thread(target=self._work, name="fh-animate-speech", daemon=True)
            self._thread.start()
        self._thread.join(timeout=0.02)
        if self._thread.is_alive():
            return 0.6 * min(self._fraction, 0.99)
        if self._error is not None:
            raise self._error
        self.take, self.stage = self._result, 1
        return 0.6

    def step(self) -> float:
        from ...faces_hands_addon.performance import with_loudness, with_nonverbal, with_speech_priority
        if self.stage == 0:
            return self._take_step()
        if self.stage == 1:
            self.take = with_nonverbal(self.take, style=self.style, seed=self.seed, emotion=self.emotion)
        elif self.stage == 2:
            if self.loudness:
                self.take, self.curve = with_loudness(self.take)
            self.take = with_speech_priority(self.take)
        self.stage += 1
        return (0.85, 1.0)[self.stage - 2]

    def cleanup(self) -> None:
        self._cancelled = True

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        report = apply.apply_take(context.scene, obj, self.take, start_frame=self.start_frame,
                                  audio_path=self.audio_path)
        layers = ["speech", *sorted(self.take.layers), *(["head"] if len(self.take.head) else [])]
        groups = ", ".join(apply.layer_group(layer) for layer in layers)
        notes = list(self.take.utterance.warnings)
        if not any(not p.is_pause for p in self.take.utterance.phones):
            notes.append("no speech was found in the recording (noise?): the mouth stays still, only blinks "
                         "and gaze are animated")
        warnings = "".join(f"; warning: {w}" for w in notes)
        return f"{report}; layers {groups} (mute one: its channel group in the Dope Sheet){warnings}"


class FH_OT_animate_speech(JobOperator, bpy.types.Operator):
    """Lip sync + non-verbal behaviour + emotion on the active face rig, from text (espeak-ng) or from
    recorded audio and its transcript, in a character style with a seed; each layer is its own channel
    group (Speech, Behavior, Emotion, Head) so it can be muted or tweaked"""

    bl_idname = "faces_hands.animate_speech"
    bl_label = "Animate Speech"
    bl_options = {"REGISTER", "UNDO"}

    source: bpy.props.EnumProperty(
        name="Source", default="TEXT", description="Speak text, or lip-sync a recording with its transcript",
        items=[("TEXT", "Text", "Synthesise the text with espeak-ng"),
               ("AUDIO", "Audio", "Align a recording (WAV, FLAC, OGG) to its transcript")])
    text: bpy.props.StringProperty(name="Text", description="Text to speak (empty: the panel's text)")
    filepath: bpy.props.StringProperty(name="Audio File", subtype="FILE_PATH",
                                       description="Recorded speech (empty: the panel's file)")
    transcript: bpy.props.StringProperty(name="Transcript",
                                         description="What is said in the recording (empty: the panel's)")
    style: bpy.props.StringProperty(
        name="Style", description="Character style of presets/behavior/styles.json (empty: the panel's; "
                                  "NONE: no behaviour)")
    seed: bpy.props.IntProperty(name="Seed", default=-1, min=-1,
                                description="Seed of the behaviour's random choices (-1: the panel's)")
    emotion: bpy.props.StringProperty(name="Emotion",
                                      description="Emotion word or activation,evaluation (empty: the panel's)")
    loudness: bpy.props.BoolProperty(
        name="Loudness", default=True,
        description="Scale mouth, brows and head by the recording's loudness (thesis 4.2.1; audio only)")
    start_at_current: bpy.props.BoolProperty(
        name="Start at Current Frame", default=False,
        description="Start the speech at the current frame instead of the scene's start frame")

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def make_job(self, context) -> Job:
        from ...faces_hands_addon.performance import voice_settings
        from ...faces_hands_addon.speech.takes import take_from_audio, take_from_text
        settings = context.scene.faces_hands
        obj = context.active_object
        kind = apply.target_kind(obj)
        text = self.text or (settings.speech_text_block.as_string() if settings.speech_text_block is not None
                             else settings.speech_text)
        path = bpy.path.abspath(self.filepath or settings.audio_path) if self.source == "AUDIO" else ""
        transcript = self.transcript or settings.audio_transcript
        style_name = self.style or settings.behavior_style
        style_name = None if style_name in ("", "NONE") else style_name
        style, emotion = check_inputs(kind, self.source, text, path, style_name,
                                      self.emotion or settings.speech_emotion)
        seed = int(settings.behavior_seed) if self.seed < 0 else int(self.seed)
        fps, voice = scene_fps(context.scene), settings.speech_voice or default_voice()
        if self.source == "TEXT":       # read every setting here: make() runs in a worker thread
            spoken = voice_settings(emotion, settings.speech_rate, settings.speech_pitch, settings.speech_volume)

            def make(progress):
                return take_from_text(text, voice=voice, fps=fps, target=kind, progress=progress, **spoken)
        else:
            def make(progress):
                return take_from_audio(path, transcript or None, fps=fps, target=kind, language=voice,
                                       progress=progress)
        start = context.scene.frame_current if self.start_at_current else context.scene.frame_start
        return AnimateSpeechJob(obj.name, make, style, seed, emotion, self.loudness and self.source == "AUDIO",
                                path or None, start)


def set_layer_mute(obj, group_name: str, mute: bool | None = None) -> tuple[bool, int]:
    """Mute (``True``), unmute (``False``) or toggle (``None``) the take layer ``group_name`` of ``obj``:
    the group and each of its F-curves (Blender 5.0 does not skip a muted group's curves when it
    evaluates a layered action; the Dope Sheet's group toggle flushes to the curves, this does the same).
    Returns (muted, how many curves)."""
    from ..adapters.fcurves import existing_channelbag
    bag = existing_channelbag(obj)
    group = bag.groups.get(group_name) if bag is not None else None
    curves = [fc for fc in bag.fcurves if fc.group == group] if group is not None else []
    if not curves:
        raise UserError(f"'{obj.name}' has no '{group_name}' layer: run Animate Speech first")
    state = (not all(fc.mute for fc in curves)) if mute is None else bool(mute)
    group.mute = state
    for fcurve in curves:
        fcurve.mute = state
    return state, len(curves)


class FH_OT_mute_speech_layer(HardenedOperator, bpy.types.Operator):
    """Mute or unmute one layer of the active rig's speech take (Speech, Behavior, Emotion, Head): its
    channel group and every curve in it"""

    bl_idname = "faces_hands.mute_speech_layer"
    bl_label = "Mute Speech Layer"
    bl_options = {"REGISTER", "UNDO"}

    layer: bpy.props.EnumProperty(
        name="Layer", description="The take's layer (its channel group)",
        items=[(n, n, f"The take's {n.lower()} layer") for n in ("Speech", "Behavior", "Emotion", "Head")])
    action: bpy.props.EnumProperty(
        name="Action", default="TOGGLE", description="Mute, unmute or toggle the layer",
        items=[("TOGGLE", "Toggle", "Mute if playing, else unmute"), ("MUTE", "Mute", "Stop the layer"),
               ("UNMUTE", "Unmute", "Play the layer")])

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def run(self, context):
        obj = context.active_object
        mute = {"TOGGLE": None, "MUTE": True, "UNMUTE": False}[self.action]
        state, count = set_layer_mute(obj, self.layer, mute)
        self.report({"INFO"}, f"{self.layer} layer of '{obj.name}' {'muted' if state else 'playing'} ({count} curves)")
        return {"FINISHED"}


CLASSES = [FH_OT_animate_speech, FH_OT_mute_speech_layer]
