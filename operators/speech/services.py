# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech takes in batch: one line (text or recorded audio) put on a face rig, simulated frame by frame
and written as .glb/.fbx/.blend with the speech as a WAV beside it, or a CSV of many lines. Animation and
audio come from the same phone timing and both start at time 0 (thesis 3.1.4)."""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

import bpy

from ...faces_hands_addon.anim.timing import check_fps
from ...faces_hands_addon.core.errors import UserError
from ..adapters.blendfile import open_blend
from ..adapters.export import save_or_export
from ..adapters.outputs import atomic_output
from ..adapters.paths import rig_cache, rig_cache_key
from ..adapters.render import quiet_stdout
from ..adapters.rig_store import adopt_rig, get_rig, is_rig
from ..adapters.targets import write_live_link
from ..adapters.timing import scene_fps, set_scene_fps
from ..character import services as character
from ..face import services as face, sheet
from ..face.objects import EXPORT_ROLES
from . import apply, head as head_motion

__all__ = ["run_line", "shared_default_rig", "built_in_rig_file", "phoneme_cells", "rig_file", "MASK"]


MASK = "mask"         # ``--rig mask``: the face-only default head instead of the default character


def rig_file(rig: str | None) -> str | None:
    """The file ``--rig`` names, or None for the built-in rigs (no ``--rig``, or ``mask``)."""
    return None if rig in (None, MASK) else rig


def _check_fps(fps: float) -> None:
    try:
        check_fps(fps)
    except UserError as error:
        raise UserError(f"--fps: {error}") from None


def _prepare_rig(rig_path: str | None, fps: float, progress, engine_rig=None):
    """The rig of ``rig_path`` (a face rig or a character in a .blend; the built-in rigs come as files too,
    :func:`built_in_rig_file`), with the scene at ``fps``; ``engine_rig``: the file's engine rig, already
    loaded (a jobs worker reopens the file for every row, loads the rig once)."""
    _check_fps(fps)
    if rig_path in (None, MASK):
        raise ValueError("a built-in rig is opened from its file (run_line)")
    open_blend(rig_path)
    rig_obj = next((o for o in bpy.data.objects if is_rig(o, face.KIND) or is_rig(o, character.KIND)), None)
    if rig_obj is None:
        raise UserError(f"{rig_path} holds no Faces & Hands face rig or character")
    if engine_rig is not None:
        adopt_rig(rig_obj, engine_rig)
    set_scene_fps(bpy.context.scene, fps)
    return rig_obj


def _bake_take(rig_obj, take, progress, animation: str = "weights"):
    """Put the take on the rig (F-curves and sound for the artist), then bake the engine take itself,
    never the curves just written (data flows one way): every frame simulated, as engine-ready weights of
    the fixed targets or as the exact per-frame cache (``animation="frames"``). Returns the finished bake
    job and the engine take it baked (they give a GLB its clip: ``adapters.take_export``)."""
    from ...faces_hands_addon.performance import take_of
    from ..bases.jobs import run_job
    scene = bpy.context.scene
    scene.frame_start = 0
    report = apply.apply_take(scene, rig_obj, take, start_frame=0)
    scene.frame_end = max(1, int(math.ceil(take.duration * scene_fps(scene))))
    print(report)
    engine_take = take_of(take)
    job = face.bake_job(bpy.context, rig_obj, "animation", animation=animation, take=(engine_take, 0))
    print(run_job(job, bpy.context, progress))
    return job, engine_take


def _save_take(rig_obj, out: Path, baked) -> Path:
    """The take's file: a character's GLB from its still export and the bake's clip (``take_export``: no
    per-frame sampling), anything else through Blender's exporters."""
    from ..adapters import take_export
    job, engine_take = baked if baked is not None else (None, None)
    rig = get_rig(rig_obj)
    terms, fit = getattr(rig, "terms", None), getattr(job, "fit", None)
    weights_fit = fit() if fit is not None else None
    if (out.suffix.lower() == ".glb" and weights_fit is not None and terms
            and take_export.can_write_clip(rig_obj, EXPORT_ROLES, terms, weights_fit.names)):
        clip = take_export.clip_of_bake(rig_obj, EXPORT_ROLES, out.stem, weights_fit, job.table,
                                        scene_fps(bpy.context.scene), terms, rig.control_specs(),
                                        engine_take.head, 0)
        return take_export.write_take_glb(bpy.context, rig_obj, out, EXPORT_ROLES, clip, job.targets_key())
    return save_or_export(bpy.context, rig_obj, out, EXPORT_ROLES)


def phoneme_cells(take, limit: int = 40) -> list:
    """(label, layer values) at the centre of each spoken phone and at each emoticon's apex, for a contact
    sheet (the rig mixes the layers: ``face.sheet.cell_layers``)."""
    cells = []
    for phone in take.utterance.phones:
        if phone.is_pause:
            continue
        centre = phone.start + phone.duration / 2
        word = take.utterance.words[phone.word].text if phone.word is not None and phone.word >= 0 else ""
        cells.append((centre, f"/{phone.phone}/ {word}".strip()))
    cells += [(tag.time, f"{tag.emoticon} {tag.emotion}") for tag in take.utterance.emotions if tag.time is not None]
    def layers_at(time: float) -> dict:
        layers = {layer: {t.name: float(t.sample(time)) for t in tracks}
                  for layer, tracks in (("speech", take.tracks), *take.layers.items())}
        return {**layers, "head": {t.name: float(t.sample(time)) for t in take.head}}
    return [(label, layers_at(time)) for time, label in sorted(cells)][:limit]


def _write_outputs(rig_obj, take, out: Path, sheet_path: Path | None, progress, source_audio=None,
                   view: str = "front", extra_sheets=(), live_link: Path | None = None,
                   write_wav: bool = True, cues: Path | None = None, baked=None) -> list[Path]:
    from ...faces_hands_addon.speech import load_audio, save_wav
    paths = []
    wav = out.with_suffix(".wav")
    paths.append(_save_take(rig_obj, out, baked))
    if write_wav:
        with atomic_output(wav) as tmp:
            if source_audio is not None:
                samples, rate = load_audio(source_audio)
                save_wav(tmp, samples, rate)
            else:
                save_wav(tmp, take.utterance.samples, take.utterance.sample_rate)
        paths.append(wav)
    if live_link is not None:
        paths.append(Path(write_live_link(rig_obj, bpy.context.scene, str(live_link))))
    if cues is not None:
        paths.append(write_cues(take, Path(cues), wav.name if write_wav else ""))
    for path, sheet_view in ([(sheet_path, view)] if sheet_path is not None else []) + list(extra_sheets):
        with atomic_output(path) as tmp:
            sheet.render_sheet(bpy.context, rig_obj, phoneme_cells(take), tmp, columns=8, progress=progress,
                               view=sheet_view, pose_cell=head_motion.pose_head)
        paths.append(Path(path))
    return paths


def write_cues(take, path: Path, sound_file: str = "") -> Path:
    """The take's mouth cues in Rhubarb Lip Sync's format (TSV or JSON by the file name)."""
    from ...faces_hands_addon.speech.cues import cue_format, cues_text, mouth_cues
    fmt = cue_format(path)
    text = cues_text(mouth_cues(take.utterance.phones, take.duration), fmt, sound_file, take.duration)
    with atomic_output(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return path


def run_line(spec: dict, rig_path, fps, progress, engine_rig=None) -> list[Path]:
    """One take, ``spec`` as ``batch.checked_spec`` returns it: out and text (+voice, rate) or audio
    (+transcript, language in ``voice``); ``engine_rig``: ``rig_path``'s engine rig, already loaded. A
    built-in rig (None: the default character, ``"mask"``) is opened from its file for the take
    (:func:`built_in_rig_file`: the user's cache folder keeps it), which stays until the take is written."""
    if rig_path in (None, MASK):
        with tempfile.TemporaryDirectory(prefix="fh-rig-") as folder:
            return run_line(spec, built_in_rig_file(folder, fps, progress, rig_path), fps, progress)
    from ...faces_hands_addon.speech.takes import take_from_audio, take_from_text
    out = Path(spec["out"])
    sheet_path = Path(spec["sheet"]) if spec.get("sheet") else None
    for path in spec["outputs"]:
        if path.exists():
            print(f"replacing {path}")
    from ...faces_hands_addon.performance import perform, voice_settings
    emotion = spec.get("emotion")
    if spec.get("audio"):
        take = take_from_audio(spec["audio"], spec.get("transcript") or None, fps=fps, target="muscles",
                               language=spec.get("voice") or "en-us", progress=progress)
    else:
        voice = voice_settings(emotion, float(spec["rate"]))
        take = take_from_text(spec["text"], voice=spec.get("voice") or "en-us", fps=fps, target="muscles",
                              progress=progress, **voice)
    for warning in take.utterance.warnings:
        print(f"warning: {warning}")
    # recorded speech: mouth, brows and head scaled by its loudness (4.2.1)
    take = perform(take, style=spec.get("style"), seed=int(spec.get("seed") or 0), emotion=emotion,
                   loudness=bool(spec.get("audio")))
    rig_obj = _prepare_rig(rig_path, fps, progress, engine_rig)
    baked = _bake_take(rig_obj, take, progress, spec["animation"])
    return _write_outputs(rig_obj, take, out, sheet_path, progress, spec.get("audio"), spec["view"],
                          spec.get("extra_sheets", ()), spec.get("live_link"), spec.get("wav", True),
                          spec.get("cues"), baked)


def shared_default_rig(folder: str, fps: float, progress, which: str | None = None) -> str:
    """The default character (``which`` ``"mask"``: the face-only head) as a file in ``folder`` for every
    row of a jobs CSV; returns its path."""
    return built_in_rig_file(folder, fps, progress, which)


#: the built-in rigs' build options (their builders' defaults), part of their cache key
_CHARACTER = {"name": "FH Character", "skeleton": "game_engine", "hands": True}
_MASK = {"name": "FH Head", "resolution": "default"}


def built_in_rig_file(folder: str, fps: float, progress, which: str | None = None) -> str:
    """``folder``/rig.blend holding the default character (``which`` ``"mask"``: the face-only default head)
    at ``fps``: a copy of the built file in the rig cache when its entry checks out (``core.file_cache``),
    else built now and stored there. A damaged or unreadable entry is said and built again, never used.
    Every caller opens the file it returns, so a line's bytes are the same whether the cache held it or not
    (the rig is always the one saved and opened again, its engine rig loaded from the file)."""
    _check_fps(fps)
    rig_path = Path(folder) / "rig.blend"
    what, options = ("mask", _MASK) if which == MASK else ("character", _CHARACTER)
    cache = rig_cache()
    key, parts = rig_cache_key(what, fps, options) if cache is not None else ("", {})
    if cache is not None:
        fetched = cache.fetch(key, rig_path)
        if fetched.hit:
            print(f"the default {what} from the cache: {cache.record_path(key)}")
            return str(rig_path)
        if fetched.problem:
            print(f"warning: the cached default {what} ({cache.record_path(key)}) cannot be used: "
                  f"{fetched.problem}; building it again")
    if which == MASK:
        face.build_default_rig_object(progress, _MASK["name"], _MASK["resolution"])
    else:
        character.build_character_object(progress, _CHARACTER["name"], _CHARACTER["skeleton"])
    set_scene_fps(bpy.context.scene, fps)
    with quiet_stdout():
        bpy.ops.wm.save_as_mainfile(filepath=str(rig_path), copy=True, check_existing=False)
    if cache is not None and cache.store(key, rig_path, parts) is not None:
        print(f"the default {what} kept for the next runs: {cache.record_path(key)}")
    return str(rig_path)
