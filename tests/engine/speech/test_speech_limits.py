"""Cheap limits before expensive work: audio length from the header, text length from a word count."""
from __future__ import annotations

import struct

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.speech.audio import MAX_TAKE_SECONDS, audio_header, load_audio, save_wav, written_here
from faces_hands_addon.speech.takes import check_text_length, estimated_seconds, take_from_text


def _sparse_wav(path, seconds: float, rate: int = 16000):
    """A 16-bit mono WAV header announcing ``seconds`` of audio, the samples a sparse hole of zeros."""
    size = int(seconds * rate) * 2
    header = (b"RIFF" + struct.pack("<I", 36 + size) + b"WAVEfmt " + struct.pack("<IHHIIHH", 16, 1, 1, rate,
              rate * 2, 2, 16) + b"data" + struct.pack("<I", size))
    with open(path, "wb") as handle:
        handle.write(header)
        handle.truncate(len(header) + size)


def test_ten_hours_of_silence_is_refused_from_the_header(tmp_path):
    wav = tmp_path / "ten_hours.wav"
    _sparse_wav(wav, 10 * 3600)
    with pytest.raises(UserError, match=r"600\.0 minutes long.*split the recording"):
        audio_header(wav)
    with pytest.raises(UserError, match="minutes long"):
        load_audio(wav)


def test_a_take_just_inside_the_limit_passes_the_header_check(tmp_path):
    wav = tmp_path / "long.wav"
    _sparse_wav(wav, MAX_TAKE_SECONDS - 1)
    header = audio_header(wav)
    assert header.duration == pytest.approx(MAX_TAKE_SECONDS - 1) and not header.written_here


def test_text_length_is_estimated_before_synthesis():
    assert estimated_seconds("one two three four five six", 180) == pytest.approx(2.0)
    check_text_length("word " * 5000, 175)                   # ~29 minutes: fine
    with pytest.raises(UserError, match="split it into takes"):
        take_from_text("word " * 20000, rate=80)            # 250 minutes: refused before espeak-ng runs


def test_wavs_written_here_carry_the_software_tag(tmp_path):
    ours = tmp_path / "ours.wav"
    save_wav(ours, np.zeros(800, np.float32), 16000)
    assert written_here(ours) and audio_header(ours).written_here
    import soundfile
    soundfile.write(str(tmp_path / "theirs.wav"), np.zeros(800, np.float32), 16000)
    assert not written_here(tmp_path / "theirs.wav")
    (tmp_path / "text.wav").write_text("not audio")
    assert not written_here(tmp_path / "text.wav") and not written_here(tmp_path / "missing.wav")
    with pytest.raises(UserError, match="NaN"):
        save_wav(tmp_path / "nan.wav", np.array([0.0, np.nan], np.float32), 16000)
    assert not (tmp_path / "nan.wav").exists()
