# SPDX-License-Identifier: GPL-3.0-or-later
"""Speak Text and Lip Sync Audio: speech takes on a face rig or a mesh with viseme shape keys."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..bases.file_operators import SaveFileOperator
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.modal import JobOperator
from ..adapters.paths import default_voice
from ..adapters.timing import scene_fps
from . import apply


class SpeechJob(Job):
    """Compute the take in steps (nothing written), then write it in ``commit``."""

    def __init__(self, obj_name: str, make_take, audio_path: str | None, start_frame: int | None):
        self.obj_name = obj_name
        self.make_take = make_take
        self.audio_path = audio_path
        self.start_frame = start_frame
        self.take = None

    def step(self) -> float:
        self.take = self.make_take()
        self.warnings = tuple(self.take.utterance.warnings)
        return 1.0

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        return apply.apply_take(context.scene, obj, self.take, start_frame=self.start_frame,
                                    audio_path=self.audio_path)


def _speech_settings(context):
    return context.scene.faces_hands


def _nonverbal(settings, kind: str):
    """(style or None, seed, emotion or None) from the panel, checked before the slow part; viseme shape
    keys only lip-sync."""
    from ...faces_hands_addon.emotion import parse_emotion
    if kind != "muscles":
        return None, 0, None
    style = None if settings.behavior_style in ("", "NONE") else settings.behavior_style
    return style, int(settings.behavior_seed), parse_emotion(settings.speech_emotion)


def _performed(take, style, seed, emotion):
    """The take with its behaviour and emotion layers and speech's priority over the lips (face rigs), or
    as it is (viseme shape keys)."""
    from ...faces_hands_addon.performance import perform
    if take.target != "muscles":
        return take
    return perform(take, style=style, seed=seed, emotion=emotion)


class _SpeechOperatorBase(JobOperator):
    start_at_current: bpy.props.BoolProperty(
        name="Start at Current Frame", default=False,
        description="Start the speech at the current frame instead of the scene's start frame")

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def _start_frame(self, context):
        return context.scene.frame_current if self.start_at_current else context.scene.frame_start


class FH_OT_speak_text(_SpeechOperatorBase, bpy.types.Operator):
    """Speak text with espeak-ng and lip-sync the active face rig (or viseme shape keys) to it,
    with Cohen-Massaro coarticulation; the audio goes into the sequencer"""

    bl_idname = "faces_hands.speak_text"
    bl_label = "Speak Text"
    bl_options = {"REGISTER", "UNDO"}

    text: bpy.props.StringProperty(name="Text", description="Text to speak (empty: use the panel's text)")

    def make_job(self, context) -> Job:
        from ...faces_hands_addon.speech.takes import take_from_text
        settings = _speech_settings(context)
        text = self.text or settings.speech_text
        if settings.speech_text_block is not None and not self.text:
            text = settings.speech_text_block.as_string()
        obj = context.active_object
        kind = apply.target_kind(obj)
        if not text.strip():
            raise UserError("there is no text to speak; type some into the Speech panel")
        fps = scene_fps(context.scene)
        style, seed, emotion = _nonverbal(settings, kind)

        def make():
            from ...faces_hands_addon.performance import voice_settings
            voice = voice_settings(emotion, settings.speech_rate, settings.speech_pitch, settings.speech_volume)
            take = take_from_text(text, voice=settings.speech_voice or default_voice(), fps=fps, target=kind,
                                  **voice)
            return _performed(take, style, seed, emotion)
        return SpeechJob(obj.name, make, None, self._start_frame(context))


class FH_OT_lipsync_audio(_SpeechOperatorBase, bpy.types.Operator):
    """Align recorded speech to its transcript (pocketsphinx) and lip-sync the active face rig
    (or viseme shape keys) to it; the audio goes into the sequencer"""

    bl_idname = "faces_hands.lipsync_audio"
    bl_label = "Lip Sync Audio"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="Audio File", subtype="FILE_PATH",
                                       description="WAV, FLAC or OGG (empty: use the panel's file)")
    transcript: bpy.props.StringProperty(name="Transcript",
                                         description="What is said (empty: use the panel's transcript)")

    def make_job(self, context) -> Job:
        from ...faces_hands_addon.speech.takes import take_from_audio
        settings = _speech_settings(context)
        path = bpy.path.abspath(self.filepath or settings.audio_path)
        transcript = self.transcript or settings.audio_transcript
        obj = context.active_object
        kind = apply.target_kind(obj)
        if not path:
            raise UserError("choose an audio file in the Speech panel first")
        fps = scene_fps(context.scene)
        style, seed, emotion = _nonverbal(settings, kind)

        def make():
            take = take_from_audio(path, transcript or None, fps=fps, target=kind,
                                   language=settings.speech_voice or default_voice())
            return _performed(take, style, seed, emotion)
        return SpeechJob(obj.name, make, path, self._start_frame(context))


class FH_OT_export_mouth_cues(HardenedOperator, SaveFileOperator, bpy.types.Operator):
    """Write the active object's last speech take as mouth cues in Rhubarb Lip Sync's format (shapes A-H and
    X; .tsv or .json), for 2D pipelines that read Rhubarb's files"""

    bl_idname = "faces_hands.export_mouth_cues"
    bl_label = "Export Mouth Cues (Rhubarb)"
    bl_options = {"REGISTER"}

    file_suffix = ".tsv"
    filter_glob: bpy.props.StringProperty(default="*.tsv;*.json;*.txt", options={"HIDDEN"},
                                          description="File types the file browser shows")

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def run(self, context):
        import json
        from pathlib import Path

        from ...faces_hands_addon.speech.cues import MouthCue, cue_format, cues_text
        from ..adapters.outputs import atomic_output
        obj = context.active_object
        stored = obj.get(apply.CUES_PROPERTY)
        if not stored:
            raise UserError(f"'{obj.name}' has no speech take: use Speak Text or Lip Sync Audio first")
        path = Path(bpy.path.abspath(self.filepath))
        fmt = cue_format(path)
        document = json.loads(stored)
        cues = [MouthCue(c["start"], c["end"], c["value"]) for c in document["mouthCues"]]
        with atomic_output(path) as tmp:
            Path(tmp).write_text(cues_text(cues, fmt, "", document["metadata"]["duration"]), encoding="utf-8")
        self.report({"INFO"}, f"Wrote {len(cues)} mouth cues to {path}")
        return {"FINISHED"}


CLASSES = [FH_OT_speak_text, FH_OT_lipsync_audio, FH_OT_export_mouth_cues]
