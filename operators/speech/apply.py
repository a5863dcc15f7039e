# SPDX-License-Identifier: GPL-3.0-or-later
"""Put a speech take (engine ``SpeechTake``) on a character: F-curves + a sound strip.

Two kinds of target object:

* a rig (``adapters.rig_store``): the take's control tracks go to the rig's speech
  layer ``["fh.speech.<control>"]`` (see ``adapters.controls``);
* any mesh with Meta/Oculus viseme shape keys (``viseme_sil`` ... ``viseme_ou``, or the Ready Player Me
  spellings ``viseme_I/O/U``): the take's viseme
  weights animate those shape keys, so characters without a muscle rig lip-sync too.

Everything is computed before anything is written; writing replaces the previous take (its curves and
its sound strip) and nothing else, and if writing fails half way the partial curves are removed.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.speech import VISEMES, save_wav
from ...faces_hands_addon.performance import take_of
from ...faces_hands_addon.speech.phonemes import VISEME_ALIASES
from ..adapters import controls, fcurves
from ..adapters.takes import remove_take, store_take
from ..adapters.rig_store import is_rig
from ..adapters.timing import scene_fps, seconds_to_frames
from . import head as head_motion
from ...names import MOUTH_CUES, TAKE_LAYERS

STRIP_PREFIX = "FH Speech"
#: object property holding the last take's mouth cues (Rhubarb shapes), for File > Export > Mouth Cues
CUES_PROPERTY = MOUTH_CUES
#: object property naming the layers besides speech the last take wrote (behavior, emotion)
TAKE_LAYERS_PROPERTY = TAKE_LAYERS
VISEME_PATH = 'key_blocks["{}"].value'


def viseme_keys(obj) -> dict[str, str]:
    """Viseme track name -> the shape key on ``obj`` that shows it (canonical name or an alias)."""
    key = getattr(getattr(obj, "data", None), "shape_keys", None)
    if key is None:
        return {}
    found = {}
    for name in VISEMES:
        for candidate in (name, *VISEME_ALIASES.get(name, ())):
            if candidate in key.key_blocks:
                found[name] = candidate
                break
    return found


def target_kind(obj) -> str:
    """``"muscles"`` for a face rig, ``"visemes"`` for a mesh with viseme shape keys."""
    if obj is None:
        raise UserError("select the face rig or a mesh with viseme shape keys first")
    if is_rig(obj):
        return "muscles"
    if viseme_keys(obj):
        return "visemes"
    raise UserError(f"'{obj.name}' is neither a Faces & Hands face rig nor a mesh with viseme shape keys "
                    f"({', '.join(VISEMES[:3])}, ...); build a face rig or bake its visemes first")


def layer_group(layer: str) -> str:
    """The F-curve group (Dope Sheet / Graph Editor channel group) of a take's layer: one group per layer
    ("Speech", "Behavior", "Emotion", "Head"), so the artist mutes or tweaks a layer as a whole."""
    return "Speech" if layer == "speech" else layer.capitalize()


def _curves_for_take(obj, take, scene, start_frame, groups: dict | None = None):
    """data path -> (frames, values) and the ID block the curves belong to; ``groups`` (if given) is
    filled with data path -> the layer's group name (:func:`layer_group`)."""
    curves = {}
    groups = {} if groups is None else groups
    if take.target == "muscles":
        owner = obj
        for layer, tracks in (("speech", take.tracks), *take.layers.items()):
            for track in tracks:
                path = controls.data_path(track.name, layer)
                curves[path] = (seconds_to_frames(track.times, scene, start_frame), track.values)
                groups[path] = layer_group(layer)
        head = head_motion.head_curves(obj, take.head, scene, start_frame)
        curves.update(head)
        groups.update({key: layer_group("head") for key in head})
    else:
        owner = obj.data.shape_keys
        present = viseme_keys(obj)
        for track in take.tracks:
            if track.name in present:
                curves[VISEME_PATH.format(present[track.name])] = (
                    seconds_to_frames(track.times, scene, start_frame), track.values)
    return owner, curves


def _remove_previous_take(scene, obj, owner, take_target: str, layers=()) -> None:
    if take_target == "muscles":
        owned = {"speech", *layers, *str(obj.get(TAKE_LAYERS_PROPERTY, "")).split()}
        head = "head" in owned
        owned.discard("head")
        fcurves.remove_fcurves(owner, tuple(controls.layer_prefix(layer) for layer in sorted(owned))
                               + (head_motion.HEAD_PATHS if head else ()))
        if head:
            head_motion.reset_head(obj)
        if TAKE_LAYERS_PROPERTY in obj:
            del obj[TAKE_LAYERS_PROPERTY]
    else:
        names = [alias for v in VISEMES for alias in (v, *VISEME_ALIASES.get(v, ()))]
        fcurves.remove_fcurves(owner, tuple(VISEME_PATH.format(v) for v in names))
    if CUES_PROPERTY in obj:
        del obj[CUES_PROPERTY]
    remove_take(obj)
    editor = scene.sequence_editor
    if editor is not None:
        for strip in [s for s in editor.strips if s.name.startswith(f"{STRIP_PREFIX} {obj.name}")]:
            sound = getattr(strip, "sound", None)
            editor.strips.remove(strip)
            if sound is not None and sound.users == 0:
                bpy.data.sounds.remove(sound)


def _strip_span(strip) -> tuple[float, float]:
    """First and last frame a strip shows (Blender 5.2 renamed ``frame_final_start/end`` to the handles)."""
    if hasattr(strip, "left_handle"):
        return strip.left_handle, strip.right_handle
    return strip.frame_final_start, strip.frame_final_end


def _free_channel(editor, start: int, end: int) -> int:
    for channel in range(1, 128):
        if all(s.channel != channel or _strip_span(s)[1] <= start or _strip_span(s)[0] >= end
               for s in editor.strips):
            return channel
    return 1


def _add_sound_strip(scene, obj, take, start_frame: int, audio_path: str | None):
    editor = scene.sequence_editor or scene.sequence_editor_create()
    tmp_dir = None
    try:
        if audio_path is None:  # synthesised speech: write a WAV, pack it into the .blend
            tmp_dir = tempfile.mkdtemp(prefix="fh-speech-")
            audio_path = os.path.join(tmp_dir, f"{obj.name}_speech.wav")
            save_wav(audio_path, take.utterance.samples, take.utterance.sample_rate)
        end = start_frame + int(np.ceil(take.duration * scene_fps(scene)))
        strip = editor.strips.new_sound(name=f"{STRIP_PREFIX} {obj.name}", filepath=str(audio_path),
                                        channel=_free_channel(editor, start_frame, end), frame_start=start_frame)
        if tmp_dir is not None:
            strip.sound.pack()
        return strip
    finally:
        if tmp_dir is not None:
            for path in Path(tmp_dir).glob("*"):
                path.unlink()
            os.rmdir(tmp_dir)


def _cues_json(take) -> str:
    from ...faces_hands_addon.speech.cues import cues_text, mouth_cues
    return cues_text(mouth_cues(take.utterance.phones, take.duration), "json", "", take.duration)


def apply_take(scene, obj, take, *, start_frame: int | None = None, audio_path: str | None = None,
               add_sound: bool = True) -> str:
    """Write ``take`` (a performed ``SpeechTake``) onto ``obj``, replacing its previous take: F-curves per
    layer, the sound strip, and for a face rig the engine take the bakes start from (``adapters.takes``);
    returns a one-line report."""
    kind = target_kind(obj)
    if kind != take.target:
        raise UserError(f"this take drives {take.target}, but '{obj.name}' needs {kind}")
    start = scene.frame_start if start_frame is None else int(start_frame)
    groups: dict = {}
    owner, curves = _curves_for_take(obj, take, scene, start, groups)
    if not curves:
        raise UserError(f"nothing to animate on '{obj.name}'")
    if take.target == "muscles":
        for layer, tracks in (("speech", take.tracks), *take.layers.items()):
            for track in tracks:
                low, high = take.ranges.get(track.name, (0.0, 1.0))
                controls.ensure_property(obj, track.name, layer, low, high)
    owned = [*take.layers, *(["head"] if any(isinstance(k, tuple) for k in curves) else [])]
    _remove_previous_take(scene, obj, owner, take.target, owned)
    try:
        for group in dict.fromkeys(groups.get(key, "Speech") for key in curves):
            fcurves.write_curves(owner, {k: v for k, v in curves.items() if groups.get(k, "Speech") == group},
                                 action_name=f"{obj.name} Speech", group=group)
        if add_sound:
            _add_sound_strip(scene, obj, take, start, audio_path)
        obj[CUES_PROPERTY] = _cues_json(take)
        if owned:
            obj[TAKE_LAYERS_PROPERTY] = " ".join(sorted(owned))
        if take.target == "muscles":
            store_take(obj, take_of(take), scene, start)
    except Exception:
        _remove_previous_take(scene, obj, owner, take.target, owned)
        raise
    end_frame = int(np.ceil(start + take.duration * scene_fps(scene)))
    extended = ""
    if end_frame > scene.frame_end:
        scene.frame_end = end_frame
        extended = f"; scene end extended to frame {end_frame}"
    words = len(take.utterance.words)
    return (f"{take.duration:.2f} s of speech ({words} words, {len(curves)} curves) on '{obj.name}' "
            f"from frame {start}{extended}")
