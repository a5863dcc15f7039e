# SPDX-License-Identifier: GPL-3.0-or-later
"""A talking photo's frames and speech as a video file, through Blender's own FFmpeg output: a scene of its
own whose sequencer holds the PNG frames and the WAV, rendered to MPEG-4 (H.264 video, AAC audio). The
user's scenes are not touched; the helper scene is removed afterwards."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters.render import quiet_stdout

__all__ = ["encode_video"]


def _video_output(scene) -> None:
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):            # Blender 5.0+: images and videos are separate media
        settings.media_type = "VIDEO"
    settings.file_format = "FFMPEG"
    ffmpeg = scene.render.ffmpeg
    ffmpeg.format = "MPEG4"
    ffmpeg.codec = "H264"
    ffmpeg.constant_rate_factor = "HIGH"
    ffmpeg.audio_codec = "AAC"
    ffmpeg.audio_channels = "MONO"
    ffmpeg.audio_mixrate = 48000


def encode_video(frames: list[Path], wav: Path | None, fps: float, size: tuple[int, int], out: Path) -> Path:
    """``frames`` (PNG files in order) and ``wav`` into the MPEG-4 ``out`` at ``fps``."""
    if not frames:
        raise UserError("no frames to encode")
    if not bpy.app.ffmpeg.supported:
        raise UserError("this Blender has no FFmpeg output; write a PNG sequence instead (--out a folder)")
    scene = bpy.data.scenes.new("FH Talking Photo")
    try:
        rate = round(float(fps) * 1001) / 1001
        scene.render.fps, scene.render.fps_base = (int(round(rate)), 1.0) if abs(rate - round(rate)) < 1e-6 \
            else (int(round(rate * 1.001)), 1.001)
        scene.render.resolution_x, scene.render.resolution_y = size[0] - size[0] % 2, size[1] - size[1] % 2
        scene.render.resolution_percentage = 100
        scene.frame_start, scene.frame_end = 1, len(frames)
        editor = scene.sequence_editor_create()
        strip = editor.strips.new_image(name="frames", filepath=str(frames[0]), channel=1, frame_start=1)
        for frame in frames[1:]:
            strip.elements.append(frame.name)
        if wav is not None:
            editor.strips.new_sound(name="speech", filepath=str(wav), channel=2, frame_start=1)
        scene.render.use_sequencer = True
        scene.view_settings.view_transform = "Standard"
        _video_output(scene)
        scene.render.filepath = str(out)
        with quiet_stdout():
            bpy.ops.render.render(animation=True, scene=scene.name)
    finally:
        bpy.data.scenes.remove(scene)
    written = _written_file(out)
    if written is None:
        raise UserError(f"Blender's FFmpeg output wrote no file for {out}")
    return written


def _written_file(out: Path) -> Path | None:
    """Blender names a video after the frame range when the path has no extension; ours has one."""
    if out.exists():
        return out
    candidates = sorted(out.parent.glob(out.stem + "*" + out.suffix))
    if candidates:
        candidates[0].rename(out)
        return out
    return None
