"""Recorded audio: loading, forced alignment with pocketsphinx, phone recognition, bad input."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile
from scipy.signal import resample_poly

from faces_hands_addon import UserError
from faces_hands_addon.speech import align_audio, compare_phone_onsets, load_audio, synthesize

DATA = Path(__file__).resolve().parents[2] / "data" / "speech"
CLIPS = ["sense_and_sensibility_01_austen_64kb-0880", "sense_and_sensibility_01_austen_64kb-0930"]
ORACLE_TEXT = ("Can you show me the way to the conference hall? The quick brown fox jumps over the lazy "
               "dog. Albrecht built a talking head in two thousand five.")


def _reference_words(clip):
    ref = json.loads((DATA / f"{clip}.json").read_text(encoding="utf-8"))
    return [(w["t"].split("(")[0], w["b"], w["b"] + w["d"]) for w in ref["w"] if not w["t"].startswith("<")]


def _word_boundary_errors(utterance, reference):
    assert [w.text.lower() for w in utterance.words] == [r[0] for r in reference]
    return [abs(x) for w, (_, b, e) in zip(utterance.words, reference) for x in (w.start - b, w.end - e)]


@pytest.fixture(scope="module")
def hifi_copies(tmp_path_factory):
    """The 16 kHz mono clips as 44.1 kHz stereo 24-bit FLAC, to exercise loading and resampling."""
    folder = tmp_path_factory.mktemp("librivox")
    paths = {}
    for clip in CLIPS:
        samples, rate = soundfile.read(DATA / f"{clip}.wav", dtype="float32")
        upsampled = resample_poly(samples, 441, 160)
        path = folder / f"{clip}.flac"
        soundfile.write(path, np.stack([upsampled, 0.7 * upsampled], axis=1), 44100, subtype="PCM_24")
        paths[clip] = path
    return paths


@pytest.mark.parametrize("clip", CLIPS)
def test_librivox_word_boundaries(clip, hifi_copies):
    transcript = (DATA / f"{clip}.txt").read_text(encoding="utf-8")
    reference = _reference_words(clip)
    for path in (DATA / f"{clip}.wav", hifi_copies[clip]):
        utterance = align_audio(path, transcript)
        assert utterance.source == "alignment"
        assert np.median(_word_boundary_errors(utterance, reference)) <= 0.020
        assert utterance.sample_rate in (16000, 44100)
        assert np.isfinite(utterance.pitch.f0_hz).mean() > 0.2


def test_oracle_espeak_timing():
    """Synthesise (known phone times), align the audio: median phone-onset error <= 30 ms."""
    spoken = synthesize(ORACLE_TEXT)
    aligned = align_audio(spoken.samples, ORACLE_TEXT, sample_rate=spoken.sample_rate)
    errors = compare_phone_onsets(spoken.phones, aligned.phones)
    assert len(errors) > 0.7 * sum(not p.is_pause for p in spoken.phones)
    assert np.median(errors) <= 0.030
    assert [w.text for w in aligned.words] == [w.text for w in spoken.words]
    assert [s.kind for s in aligned.sentences] == ["question", "statement", "statement"]
    assert aligned.accented_syllables


def test_unknown_words_get_espeak_pronunciations():
    text = "The zorblaxian quintessoid greeted Albrecht."
    spoken = synthesize(text)
    aligned = align_audio(spoken.samples, text, sample_rate=spoken.sample_rate)
    assert any("zorblaxian" in w for w in aligned.warnings)
    assert [w.text for w in aligned.words] == ["The", "zorblaxian", "quintessoid", "greeted", "Albrecht"]
    errors = compare_phone_onsets(spoken.phones, aligned.phones)
    assert np.median(errors) <= 0.040


def test_emoticons_in_transcript_become_tags():
    clip = CLIPS[0]
    transcript = (DATA / f"{clip}.txt").read_text(encoding="utf-8").strip() + " :-("
    utterance = align_audio(DATA / f"{clip}.wav", transcript)
    assert [e.emotion for e in utterance.emotions] == ["sad"]
    assert utterance.emotions[0].time == pytest.approx(utterance.words[-1].end)


def test_without_transcript_phones_are_recognised_with_a_warning():
    utterance = align_audio(DATA / f"{CLIPS[0]}.wav")
    assert utterance.source == "phone_recognition" and utterance.words == []
    assert any("less accurate" in w for w in utterance.warnings)
    spoken = [p for p in utterance.phones if not p.is_pause]
    assert len(spoken) > 10
    assert utterance.phones[-1].end == pytest.approx(utterance.duration)


def test_audio_formats(tmp_path):
    samples, rate = soundfile.read(DATA / f"{CLIPS[1]}.wav", dtype="float32")
    for name, subtype, sr in (("a.wav", "PCM_16", 22050), ("b.wav", "FLOAT", 48000),
                              ("c.ogg", "VORBIS", 32000), ("d.wav", "PCM_32", 8000)):
        data = resample_poly(samples, sr // 100, rate // 100).astype(np.float32)
        soundfile.write(tmp_path / name, data, sr, subtype=subtype)
        loaded, loaded_rate = load_audio(tmp_path / name)
        assert loaded_rate == sr and loaded.ndim == 1 and abs(len(loaded) / sr - len(samples) / rate) < 0.01


def test_bad_audio(tmp_path):
    corrupt = tmp_path / "corrupt.wav"
    corrupt.write_bytes(b"RIFF\x10\x00\x00\x00WAVEfmt garbage" * 10)
    with pytest.raises(UserError, match="cannot read audio file"):
        align_audio(corrupt, "hello")
    empty = tmp_path / "empty.wav"
    soundfile.write(empty, np.zeros(0, dtype=np.float32), 16000)
    with pytest.raises(UserError, match="zero length"):
        align_audio(empty, "hello")
    short = tmp_path / "short.wav"
    soundfile.write(short, np.zeros(400, dtype=np.float32), 16000)
    with pytest.raises(UserError, match="too short"):
        align_audio(short, "hello")
    with pytest.raises(UserError, match="does not exist"):
        align_audio(tmp_path / "missing.wav", "hello")
    with pytest.raises(UserError, match="sample rate"):
        align_audio(np.zeros(16000, dtype=np.float32), "hello")
    # digital silence (or a hiss far below any microphone's noise floor) holds no speech
    with pytest.raises(UserError, match="silent .*digital silence"):
        align_audio(np.zeros(64000, dtype=np.float32), "hello there my friend", sample_rate=16000)
    hiss = np.random.default_rng(1).standard_normal(64000).astype(np.float32) * 1e-5
    with pytest.raises(UserError, match="silent"):
        align_audio(hiss, None, sample_rate=16000)


@pytest.mark.parametrize("wrong", [
    "the quick brown fox jumps over the lazy dog and keeps running through the whole night long",
    "hello world", "she sells sea shells by the sea shore",
])
def test_mismatched_transcript_is_refused(wrong):
    for clip in CLIPS:
        with pytest.raises(UserError, match="does not match the audio"):
            align_audio(DATA / f"{clip}.wav", wrong)


def test_one_wrong_word_still_aligns():
    clip = CLIPS[0]
    utterance = align_audio(DATA / f"{clip}.wav", "he was not an ill tempered young man")
    assert [w.text for w in utterance.words][-3:] == ["tempered", "young", "man"]
