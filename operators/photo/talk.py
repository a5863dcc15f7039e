# SPDX-License-Identifier: GPL-3.0-or-later
"""``photo-talk``'s work: the head from the photo with its rig, a speech take (text -> espeak-ng -> tracks,
behaviour and emotion as asked: the same performance as ``speak``), the frames simulated and rendered into
the photo by the engine (:class:`...faces_hands_addon.photo.talk.TalkingPhoto`), written as PNG frames and a
WAV, and encoded to MPEG-4 by Blender's FFmpeg output when an .mp4 is asked for."""
from __future__ import annotations

import tempfile
from pathlib import Path

import bpy

from ..adapters.outputs import atomic_output
from .images import write_picture
from .jobs import build_head

__all__ = ["talking_photo"]


def _take(args):
    from ...faces_hands_addon.performance import perform, take_of, voice_settings
    from ...faces_hands_addon.speech.takes import take_from_text
    from ...faces_hands_addon.emotion import parse_emotion
    emotion = parse_emotion(args.emotion) if args.emotion else None
    voice = voice_settings(emotion, float(args.rate))
    take = take_from_text(args.text, voice=args.voice, fps=args.fps, target="muscles", **voice)
    for warning in take.utterance.warnings:
        print(f"warning: {warning}")
    performed = perform(take, style=args.style, seed=int(args.seed), emotion=emotion)
    return performed, take_of(performed)


def talking_photo(photo, args, out: Path, folder: bool, progress) -> list[Path]:
    """Write the clip (or the frames and WAV into the folder ``out``); returns the files written."""
    from ...faces_hands_addon.photo.talk import TalkingPhoto
    from ...faces_hands_addon.speech import save_wav
    performed, take = _take(args)
    _, result = build_head(bpy.context, [photo], "FH Photo Head", "default", progress)
    talking = TalkingPhoto(result, photo.pixels, take, args.fps)
    fraction = 0.0
    while fraction < 1.0:
        fraction = talking.step()
        if progress is not None:
            progress(0.7 * fraction, talking.label)
    with tempfile.TemporaryDirectory(prefix="fh-talk-") as tmp:
        staging = Path(tmp)
        frames = []
        for index, picture in talking.frames():
            frames.append(write_picture(staging / f"frame_{index:05d}.png", picture))
            if progress is not None:
                progress(0.7 + 0.25 * (index + 1) / talking.count, "rendering the frames into the photo")
        wav = staging / "speech.wav"
        save_wav(wav, performed.utterance.samples, performed.utterance.sample_rate)
        if folder:
            out.mkdir(parents=True, exist_ok=True)
            written = []
            for source in frames + [wav]:
                target = out / source.name
                source.replace(target)
                written.append(target)
            return written
        from .video import encode_video
        height, width = photo.pixels.shape[:2]
        with atomic_output(out) as video:
            encode_video(frames, wav, args.fps, (width, height), Path(video))
        with atomic_output(out.with_suffix(".wav")) as sound:
            Path(sound).write_bytes(wav.read_bytes())
        return [out, out.with_suffix(".wav")]
