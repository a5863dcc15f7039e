"""The transcript check of audio alignment: right words accepted, wrong words and non-speech refused,
missing and added words named. The fixture is Festival speech (CMU ARCTIC SLT HTS voice, see
tests/data/transcript_check/README.md); Festival's own word times are the reference, not ours."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import soundfile

from faces_hands_addon import UserError
from faces_hands_addon.speech import align_audio, transcript_check

DATA = Path(__file__).resolve().parents[2] / "data" / "transcript_check"
WAV = DATA / "slt_bring_the_blue_basket.wav"
TEXT = "Bring the blue basket to the kitchen before dinner."
#: Festival's word ends (s) when it spoke the fixture; its first phone starts at 0.175 s
SPEECH_START = 0.175
FESTIVAL_WORD_ENDS = [0.420, 0.505, 0.745, 1.270, 1.455, 1.550, 1.930, 2.285, 2.690]
FESTIVAL_PHONES = 33  # non-pause segments Festival reported


@pytest.fixture(scope="module")
def speech():
    samples, rate = soundfile.read(WAV, dtype="float64")
    assert rate == 16000 and samples.ndim == 1
    return samples


def _noisy(samples, snr_db, seed=7):
    noise = np.random.default_rng(seed).standard_normal(len(samples))
    gain = np.sqrt(np.mean(samples ** 2) / (np.mean(noise ** 2) * 10 ** (snr_db / 10)))
    return (samples + gain * noise).astype(np.float32)


def test_correct_transcript_is_accepted_without_warnings():
    utterance = align_audio(WAV, TEXT)
    assert utterance.warnings == []
    assert [w.text for w in utterance.words] == TEXT.rstrip(".").split()
    ends = np.array([w.end for w in utterance.words])
    assert np.median(np.abs(ends - FESTIVAL_WORD_ENDS)) < 0.05


def test_correct_transcript_in_10db_noise_is_accepted(speech):
    utterance = align_audio(_noisy(speech, 10.0), TEXT, sample_rate=16000)
    assert len(utterance.words) == 9
    assert _word_warnings(utterance) == [], utterance.warnings


@pytest.mark.parametrize("wrong", ["The quick brown fox jumps over the lazy dog.",
                                   "She sells sea shells by the sea shore every summer.",
                                   "We will meet at the station at seven tomorrow morning."])
def test_unrelated_transcript_is_refused(wrong):
    with pytest.raises(UserError, match="does not match the audio"):
        align_audio(WAV, wrong)


WORD_WARNINGS = ("do not match", "not in the transcript", "not in the recording", "far longer",
                 "missing from the transcript")


def _word_warnings(utterance):
    return [w for w in utterance.warnings if any(m in w for m in WORD_WARNINGS)]


def test_added_word_is_named():
    """'elephant' is in the transcript but not spoken: the soft transcript's path leaves it out."""
    utterance = align_audio(WAV, "Bring the blue basket to the elephant kitchen before dinner.")
    assert _word_warnings(utterance) == [
        "these words are not in the recording (added to the transcript?): 'elephant'"], utterance.warnings
    assert [w.text for w in utterance.words][6] == "elephant"  # the word is still in the Utterance


def test_missing_word_is_named_by_its_place():
    """'basket' is spoken but not in the transcript: the warning names the place, between 'blue' and 'to',
    and the time (Festival: 'basket' 0.745-1.270 s)."""
    utterance = align_audio(WAV, "Bring the blue to the kitchen before dinner.")
    named = _word_warnings(utterance)
    assert len(named) == 1 and "between 'blue' and 'to'" in named[0], utterance.warnings
    at = float(named[0].split("between 'blue' and 'to' (")[1].split(" s)")[0])
    assert 0.7 <= at <= 1.35


def test_soft_pass_in_pieces_names_the_same_words(monkeypatch):
    """Long recordings are decoded in pieces cut at word ends: the words are still named."""
    monkeypatch.setattr(transcript_check, "SOFT_CHUNK_FRAMES", 60)
    utterance = align_audio(WAV, "Bring the blue basket to the elephant kitchen before dinner.")
    assert any("'elephant'" in w for w in _word_warnings(utterance)), utterance.warnings
    utterance = align_audio(WAV, "Bring the blue to the kitchen before dinner.")
    assert any("between 'blue' and 'to'" in w for w in _word_warnings(utterance)), utterance.warnings


def test_soft_path_reading():
    """Left-out tokens become added words, speech between words a missing word only when loud enough;
    a left-out word with speech in its place does not match."""
    keys = ["a", "b", "c", "d"]
    loud = np.zeros(200, dtype=bool)
    loud[40:60] = True
    segs = [("<s>", 0, 0), ("a", 1, 20), ("<sil>", 21, 30), ("c", 31, 39), ("[SPEECH]", 40, 60),
            ("d(2)", 61, 90), ("</s>", 91, 91)]
    path = transcript_check.SoftPath()
    transcript_check._read_piece(path, segs, keys, 0, 4, loud)
    assert path.skipped == [1]
    assert path.inserted == [(0, 2, 21, 30, 0), (2, 3, 40, 60, 20)]
    texts = ["A", "B", "C", "D"]
    assert transcript_check.soft_warnings(path, texts) == [
        "these words are not in the recording (added to the transcript?): 'B'",
        "speech not in the transcript between 'C' and 'D' (0.40-0.61 s): a missing word?"]
    path = transcript_check.SoftPath()
    transcript_check._read_piece(path, [("a", 0, 39), ("[SPEECH]", 40, 60), ("d", 61, 90)], keys, 0, 4, loud)
    assert transcript_check.soft_warnings(path, texts) == [
        "these words do not match the audio (other words spoken there?): 'B', 'C'"]


@pytest.mark.parametrize("kind", ["white", "hum", "hiss"])
def test_non_speech_is_refused(kind):
    rng = np.random.default_rng(3)
    t = np.arange(64000) / 16000
    audio = {"white": 0.1 * rng.standard_normal(64000), "hiss": 1e-3 * rng.standard_normal(64000),
             "hum": 0.2 * np.sin(2 * np.pi * 50 * t) + 0.1 * np.sin(2 * np.pi * 100 * t)}[kind]
    for transcript in (TEXT, None):
        with pytest.raises(UserError, match="no speech"):
            align_audio(audio.astype(np.float32), transcript, sample_rate=16000)


def test_digital_silence_is_refused():
    with pytest.raises(UserError, match="silent"):
        align_audio(np.zeros(64000, dtype=np.float32), TEXT, sample_rate=16000)


def test_without_transcript_phones_cover_the_speech():
    utterance = align_audio(WAV)
    spoken = [p for p in utterance.phones if not p.is_pause]
    assert 0.6 * FESTIVAL_PHONES <= len(spoken) <= 1.5 * FESTIVAL_PHONES
    assert max(p.duration for p in spoken) < 0.4
    first, last = spoken[0], spoken[-1]
    assert abs(first.start - SPEECH_START) < 0.1
    assert abs(last.end - FESTIVAL_WORD_ENDS[-1]) < 0.15
    assert utterance.phones[-1].is_pause  # the trailing silence is silence, not a held phone


def _fit(bad_tokens):
    words = [transcript_check.WordFit(t, f"w{t}", 30 * t, 30 * t + (20 if t in bad_tokens else 29),
                                      -600.0 if t in bad_tokens else -20.0, 7 if t in bad_tokens else 3)
             for t in range(8)]
    return transcript_check.TranscriptFit(words, texts=[w.text for w in words])


def test_one_unspoken_word_is_named_not_refused():
    """A transcript refused only because of an added word the soft path left out is judged without it;
    three such words (or none left out) still refuse."""
    fit = _fit({3})
    with pytest.raises(UserError, match="does not match"):
        transcript_check.judge(fit)
    transcript_check.judge_with_soft(fit, transcript_check.SoftPath(skipped=[3]))
    with pytest.raises(UserError, match="does not match"):
        transcript_check.judge_with_soft(fit, transcript_check.SoftPath(skipped=[]))
    with pytest.raises(UserError, match="does not match"):
        transcript_check.judge_with_soft(_fit({1, 3, 5}), transcript_check.SoftPath(skipped=[1, 3, 5]))


def _edit_insertions(recognised, transcript, words):
    """The same weighted edit alignment, cell by cell (the reference for the row-wise one)."""
    from faces_hands_addon.speech.missing_words import _substitution  # noqa: PLC0415
    n, m = len(recognised), len(transcript)
    cost = np.zeros((n + 1, m + 1))
    move = np.zeros((n + 1, m + 1), int)
    cost[:, 0], cost[0, :] = np.arange(n + 1), np.arange(m + 1)
    move[1:, 0], move[0, 1:] = 1, 2
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            options = [cost[i - 1, j - 1] + _substitution(recognised[i - 1], transcript[j - 1][0]),
                       cost[i - 1, j] + 1.0, cost[i, j - 1] + 1.0]
            move[i, j] = int(np.argmin(options))
            cost[i, j] = options[move[i, j]]
    out, i, j = np.zeros(words - 1), n, m
    while i > 0 or j > 0:
        if move[i, j] == 0:
            i, j = i - 1, j - 1
        elif move[i, j] == 1:
            word = transcript[j - 1][1] if j > 0 else -1
            if 0 <= word < words - 1:
                out[word] += 1
            i -= 1
        else:
            j -= 1
    return out


def test_recognised_phones_the_transcript_lacks_are_counted_at_their_boundary():
    from faces_hands_addon.speech.missing_words import insertions
    transcript = [("B", 0), ("R", 0), ("IH", 0), ("NG", 0), ("B", 1), ("L", 1), ("UW", 1), ("T", 2), ("UW", 2)]
    recognised = ["B", "R", "IH", "NG", "B", "L", "UW", "B", "AE", "S", "K", "IH", "T", "T", "UW"]
    assert insertions(recognised, transcript, 3).tolist() == [0.0, 6.0]      # "basket" after "blue"
    rng = np.random.default_rng(5)
    phones = ["AA", "IY", "P", "B", "S", "Z", "M", "N", "L"]
    for _ in range(40):
        words = int(rng.integers(2, 6))
        transcript = [(phones[k], int(w)) for k, w in zip(rng.integers(0, 9, 12), np.sort(rng.integers(0, words, 12)))]
        recognised = [phones[k] for k in rng.integers(0, 9, int(rng.integers(0, 18)))]
        assert insertions(recognised, transcript, words).tolist() == \
            _edit_insertions(recognised, transcript, words).tolist()


def test_a_broken_missing_word_model_is_refused(tmp_path):
    from faces_hands_addon.core import presets
    from faces_hands_addon.speech import missing_words
    (tmp_path / "speech").mkdir()
    doc = {"format": "faces_hands.transcript_check", "version": 1,
           "missing_word": {"features": ["excess_s"], "mean": [0], "scale": [1], "weights": [1], "bias": 0,
                            "threshold": 0}}
    (tmp_path / "speech" / "transcript_check.json").write_text(__import__("json").dumps(doc))
    before = presets.user_folder()
    presets.set_user_folder(tmp_path)
    try:
        with pytest.raises(UserError, match="features must be"):
            missing_words.load_model()
    finally:
        presets.set_user_folder(before)
    assert len(missing_words.load_model().weights) == len(missing_words.FEATURES)
