"""Recorded audio: loading, forced alignment with pocketsphinx, phone recognition, bad input.

Accuracy is measured against Festival, not against pocketsphinx: the fixtures in tests/data/speech are
sentences Festival's CMU ARCTIC SLT HTS voice spoke, with the segment and word times its duration model
placed (scripts/speech_fixtures.py writes them; ground truth, since the waveform follows them). Degraded
copies (white noise, telephone band, speed, reverb) are made here, seeded. The bounds come from
measured errors with margin (pooled word onsets of the four clips, clean: median 15 ms, p90 39 ms;
20 dB SNR 15/55; telephone 10/39; 1.1x speed 8/36; reverb 15/44) and labels shifted by 80 ms fail them
(clean: median 80 ms either way).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import soundfile
from scipy.signal import resample_poly

from faces_hands_addon import UserError
from faces_hands_addon.speech import align_audio, compare_phone_onsets, degrade, load_audio, synthesize
from faces_hands_addon.speech.evaluation import (error_summary, labelled_phones, read_labels,
                                                 signed_phone_onsets, word_timing_errors)

DATA = Path(__file__).resolve().parents[2] / "data" / "speech"
CLIPS = ["slt_ill_disposed", "slt_amiable", "slt_conference", "slt_pump"]
ORACLE_TEXT = ("Can you show me the way to the conference hall? The quick brown fox jumps over the lazy "
               "dog. Albrecht built a talking head in two thousand five.")
# condition -> (median, p90) bounds in seconds for pooled |word-onset error|
WORD_ONSET_BOUNDS = {"clean": (0.030, 0.060), "noisy20": (0.035, 0.080), "telephone": (0.030, 0.070),
                     "speed11": (0.030, 0.060), "reverb": (0.035, 0.075)}


def _labels(clip):
    return read_labels(DATA / f"{clip}.tsv")


def _transcript(clip):
    return _labels(clip)[0]


def _degraded(samples, rate, condition, seed):
    """(audio, label time scale) for one condition; seeded."""
    rng = np.random.default_rng(seed)
    if condition == "noisy20":
        return degrade.add_noise(samples, 20.0, rng), 1.0
    if condition == "telephone":
        return degrade.band_limit(samples, rate), 1.0
    if condition == "speed11":
        return degrade.change_speed(samples, 1.1), 1 / 1.1
    if condition == "reverb":
        return degrade.reverberate(samples, rate, 0.4, rng), 1.0
    return samples, 1.0


def _aligned(condition):
    """Per clip: (aligned Utterance, reference words, reference phones), labels scaled to the audio."""
    out = []
    for k, clip in enumerate(CLIPS):
        text, phones, words = _labels(clip)
        samples, rate = soundfile.read(DATA / f"{clip}.wav", dtype="float32")
        audio, scale = _degraded(samples, rate, condition, seed=20 + k)
        utterance = align_audio(audio, text, sample_rate=rate)
        out.append((utterance, [(w, a * scale, b * scale) for w, a, b in words],
                    labelled_phones([(p, a * scale, b * scale) for p, a, b in phones])))
    return out


def _onset_errors(aligned, shift=0.0):
    return np.concatenate([word_timing_errors([(w, a + shift, b + shift) for w, a, b in words], u.words)[0]
                           for u, words, _ in aligned])


def _within(errors, bounds):
    summary = error_summary(errors)
    return summary["p50_ms"] <= bounds[0] * 1000 and summary["p90_ms"] <= bounds[1] * 1000


@pytest.fixture(scope="module")
def clean_alignments():
    return _aligned("clean")


def test_festival_word_onsets_clean(clean_alignments):
    errors = _onset_errors(clean_alignments)
    assert len(errors) == sum(len(_labels(c)[2]) for c in CLIPS)
    assert _within(errors, WORD_ONSET_BOUNDS["clean"]), error_summary(errors)
    ends = np.concatenate([word_timing_errors(words, u.words)[1] for u, words, _ in clean_alignments])
    assert _within(ends, WORD_ONSET_BOUNDS["clean"]), error_summary(ends)
    phones = np.concatenate([signed_phone_onsets(ref, u.phones) for u, _, ref in clean_alignments])
    assert len(phones) > 0.8 * sum(not p.is_pause for _, _, ref in clean_alignments for p in ref)
    assert _within(phones, (0.025, 0.050)), error_summary(phones)


@pytest.mark.parametrize("shift", [0.080, -0.080])
def test_labels_shifted_by_80_ms_fail_the_bounds(clean_alignments, shift):
    """The accuracy check can fail: the same alignments against labels moved by 80 ms are out of bounds."""
    assert not _within(_onset_errors(clean_alignments, shift), WORD_ONSET_BOUNDS["clean"])


@pytest.mark.parametrize("condition", ["noisy20", "telephone", "speed11", "reverb"])
def test_festival_word_onsets_degraded(condition):
    aligned = _aligned(condition)
    errors = _onset_errors(aligned)
    assert _within(errors, WORD_ONSET_BOUNDS[condition]), error_summary(errors)
    assert not _within(_onset_errors(aligned, 0.080), WORD_ONSET_BOUNDS[condition])


@pytest.fixture(scope="module")
def hifi_copies(tmp_path_factory):
    """The 16 kHz mono clips as 44.1 kHz stereo 24-bit FLAC, to exercise loading and resampling."""
    folder = tmp_path_factory.mktemp("festival")
    paths = {}
    for clip in CLIPS[:2]:
        samples, rate = soundfile.read(DATA / f"{clip}.wav", dtype="float32")
        upsampled = resample_poly(samples, 441, 160)
        path = folder / f"{clip}.flac"
        soundfile.write(path, np.stack([upsampled, 0.7 * upsampled], axis=1), 44100, subtype="PCM_24")
        paths[clip] = path
    return paths


@pytest.mark.parametrize("clip", CLIPS[:2])
def test_files_align_like_arrays(clip, hifi_copies):
    text, _, words = _labels(clip)
    for path in (DATA / f"{clip}.wav", hifi_copies[clip]):
        utterance = align_audio(path, text)
        assert utterance.source == "alignment"
        onsets, _ = word_timing_errors(words, utterance.words)
        assert np.median(np.abs(onsets)) <= 0.030
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
    transcript = _transcript(clip) + " :-("
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
    for clip in CLIPS[:2]:
        with pytest.raises(UserError, match="does not match the audio"):
            align_audio(DATA / f"{clip}.wav", wrong)


def test_one_wrong_word_still_aligns():
    clip = CLIPS[0]
    utterance = align_audio(DATA / f"{clip}.wav", "he was not an ill tempered young man")
    assert [w.text for w in utterance.words][-3:] == ["tempered", "young", "man"]
