"""Emotion curves from emoticons (thesis 4.3.5, Table 4.1): 100 % at the emoticon, fading linearly to zero
at the borders of its intonational phrase, over both phrases when it stands between two; ;-) adds a wink;
the curves go on the emotion layer, where anim.layers.mix adds them to speech and clamps."""
from __future__ import annotations

import json

import numpy as np
import pytest

from faces_hands_addon.anim.layers import mix
from faces_hands_addon.anim.tracks import TrackSet
from faces_hands_addon.core import presets
from faces_hands_addon.emotion import emotion_tracks, emotion_windows, expression_for, face_specs, load_model
from faces_hands_addon.speech import extract_emoticons
from faces_hands_addon.speech.utterance import Phone, WordDraft, assemble_utterance, token_spans

RATE = 16000


def utterance(text, word_times, phrase_ends, duration=2.0):
    """An utterance with one vowel per word at ``word_times`` and phrases ending after ``phrase_ends``."""
    cleaned, tags = extract_emoticons(text)
    spans = token_spans(cleaned)
    assert len(spans) == len(word_times)
    phones, drafts, now = [], [], 0.0
    for k, ((a, b), (start, end)) in enumerate(zip(spans, word_times)):
        if start > now:
            phones.append(Phone("_", "sil", now, start - now))
        drafts.append(WordDraft(a, b, [len(phones)], 0, ends_phrase=k in phrase_ends))
        phones.append(Phone("a", "a", start, end - start, 1))
        now = end
    phones.append(Phone("_", "sil", now, duration - now))
    return assemble_utterance(text=text, language="en", samples=np.zeros(int(duration * RATE), np.float32),
                              sample_rate=RATE, phones=phones, words=drafts, emotions=tags, pitch=None,
                              source="tts", warnings=[])


WORDS = [(0.1, 0.4), (0.45, 0.8), (1.0, 1.2), (1.25, 1.4), (1.45, 1.8)]   # phrases: words 0-1 and 2-4


@pytest.fixture(scope="module")
def model():
    return load_model()


def test_apex_at_the_emoticon_and_linear_fade_to_the_phrase_borders(model):
    utt = utterance("Hello :-) there, how are you", WORDS, {1})
    assert [(p.start, p.end) for p in utt.phrases] == [(0.1, 0.8), (1.0, 1.8)]
    (window,) = emotion_windows(utt)
    assert (window.start, window.apex, window.end) == pytest.approx((0.1, 0.425, 0.8))
    tracks = emotion_tracks(utt, fps=25, model=model)
    joy = expression_for("joy", model)
    assert set(tracks.names) == set(joy)
    smile = tracks["zygomaticus_major_L"]
    full = joy["zygomaticus_major_L"]
    assert smile.sample(0.425) == pytest.approx(full)                        # 100 % at the climax
    assert smile.sample(0.1 + 0.5 * 0.325) == pytest.approx(0.5 * full)      # linear rise
    assert smile.sample(0.425 + 0.75 * 0.375) == pytest.approx(0.25 * full)  # linear fall
    assert smile.sample([0.0, 0.05, 0.1, 0.8, 0.9, 1.5, 2.0]) == pytest.approx([0.0] * 7)
    keys = [0.1, 0.425, 0.8] + list(np.arange(0, 51) / 25.0)                # borders, apex, every frame
    assert all(np.isclose(smile.times, t, atol=1e-9).any() for t in keys)


def test_between_two_phrases_the_emotion_spans_both(model):
    utt = utterance("Hello there :-( how are you", WORDS, {1})
    (window,) = emotion_windows(utt)
    assert (window.start, window.apex, window.end) == pytest.approx((0.1, 0.9, 1.8))
    tracks = emotion_tracks(utt, fps=30, model=model)
    frown = tracks["depressor_anguli_oris_R"]
    full = expression_for("sorry-for", model)["depressor_anguli_oris_R"]
    assert frown.sample(0.9) == pytest.approx(full)
    assert frown.sample(0.5) == pytest.approx(0.5 * full)      # (0.5 - 0.1) / (0.9 - 0.1)
    assert frown.sample(1.35) == pytest.approx(0.5 * full)     # (1.8 - 1.35) / (1.8 - 0.9)
    assert frown.sample(1.9) == 0.0


def test_an_emoticon_inside_the_second_phrase_stays_there(model):
    utt = utterance("Hello there, how :-o are you", WORDS, {1})
    (window,) = emotion_windows(utt)
    assert (window.start, window.apex, window.end) == pytest.approx((1.0, 1.225, 1.8))
    jaw = emotion_tracks(utt, model=model)["jaw_open"]
    assert jaw.sample(0.9) == 0.0 and jaw.sample(1.225) == pytest.approx(expression_for("surprise", model)["jaw_open"])


def test_an_emoticon_after_the_last_word_fades_over_the_trailing_pause(model):
    utt = utterance("Hello there, how are you >:-<", WORDS, {1})
    (window,) = emotion_windows(utt)
    assert (window.start, window.apex, window.end) == pytest.approx((1.0, 1.8, 2.0))
    brow = emotion_tracks(utt, model=model)["corrugator_supercilii_L"]
    assert brow.sample(1.4) == pytest.approx(0.5 * expression_for("anger", model)["corrugator_supercilii_L"])
    assert brow.sample(2.0) == 0.0


def test_kidding_adds_a_wink_of_one_eye(model):
    utt = utterance("Hello ;-) there, how are you", WORDS, {1})
    tracks = emotion_tracks(utt, fps=30, model=model)
    doc = json.loads((presets.SHIPPED_FOLDER / "emotion" / "basic_expressions.json").read_text(encoding="utf-8"))
    wink = doc["tags"]["kidding"]["wink"]
    lid = tracks[wink["control"]]
    apex = 0.425
    assert lid.sample(apex) == pytest.approx(wink["value"]) == pytest.approx(1.0)
    after = apex + 0.5 * wink["hold"] + wink["open"]
    assert lid.sample([0.0, apex - 0.5 * wink["hold"] - wink["close"], after, after + 0.2]) == pytest.approx([0.0] * 4)
    other = "eyelid_close_L" if wink["control"] == "eyelid_close_R" else "eyelid_close_R"
    assert other not in tracks                                   # one eye only
    assert tracks["zygomaticus_major_L"].sample(apex) == pytest.approx(expression_for("joy", model)["zygomaticus_major_L"])


def test_overlapping_emotions_add_up_and_clamp(model):
    utt = utterance("Hello :-) there :-) , how are you", WORDS, {1})
    tracks = emotion_tracks(utt, model=model)
    windows = emotion_windows(utt)
    assert len(windows) == 2
    t = 0.6
    expected = sum(np.interp(t, [w.start, w.apex, w.end], [0, 1, 0]) for w in windows) * 0.9
    assert expected > 1.0
    assert tracks["zygomaticus_major_L"].sample(t) == pytest.approx(1.0)
    assert tracks["orbicularis_oculi_L"].sample(t) == pytest.approx(expected / 0.9 * 0.5)


def test_emotion_layer_mixes_with_speech_by_the_layer_rule(model):
    utt = utterance("Hello :-) there, how are you", WORDS, {1})
    tracks = emotion_tracks(utt, model=model)
    specs = face_specs()
    emotion = {name: float(values) for name, values in tracks.sample(np.array(0.425)).items()}
    speech = {"zygomaticus_major_L": 0.5, "depressor_anguli_oris_L": 0.3, "jaw_open": 0.2}
    shown = mix({"speech": speech, "emotion": emotion}, specs)
    assert shown["zygomaticus_major_L"] == 1.0                             # 0.5 + 0.9, clamped
    assert shown["depressor_anguli_oris_L"] == pytest.approx(0.3)
    assert shown["jaw_open"] == pytest.approx(0.2 + emotion["jaw_open"])
    assert shown["orbicularis_oculi_R"] == pytest.approx(emotion["orbicularis_oculi_R"])


def test_same_utterance_same_curves(model):
    one = emotion_tracks(utterance("Hello ;-) there :-( how are you :-|", WORDS, {1}), model=model)
    two = emotion_tracks(utterance("Hello ;-) there :-( how are you :-|", WORDS, {1}))
    assert isinstance(one, TrackSet) and one.names == two.names
    for track in one:
        assert np.array_equal(track.times, two[track.name].times)
        assert np.array_equal(track.values, two[track.name].values)


def test_no_emoticons_no_curves(model):
    assert len(emotion_tracks(utterance("Hello there, how are you", WORDS, {1}), model=model)) == 0
