"""Text-to-speech bridge (thesis 4.3.2-4.3.6): espeak-ng events -> Utterance."""
from __future__ import annotations


import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.speech import list_voices, synthesize

THESIS_EXAMPLE = "Hi! ;-) Can you show me the way to the conference hall? :-)"  # Figure 4.7
POEM = """Es gingen zwei Parallelen
ins ; - ) Endlose hinaus,
zwei kerzengerade Seelen
und aus solidem Haus.

Sie wollten sich nicht : - ( schneiden
bis an ihr seliges Grab: : - ( )
Das war nun einmal der beiden
geheimer Stolz und Stab.

Doch als sie zehn Lichtjahre
gewandert neben sich hin,
da wards dem einsamen Paare
nicht : - o irdisch mehr zu Sinn.

Warn sie noch Parallelen?
Sie wußtens selber nicht, -
sie flossen nur wie zwei Seelen
zusammen durch ewiges Licht.

Das ewige Licht durchdrang sie,
da wurden sie : - o eins in ihm;
die Ewigkeit verschlang sie
als wie zwei Seraphim. : - )"""  # thesis Table 4.2 (Morgenstern), emoticons as printed


@pytest.fixture(scope="module")
def example():
    return synthesize(THESIS_EXAMPLE)


def test_thesis_example_structure(example):
    u = example
    assert u.source == "tts" and u.sample_rate > 8000 and u.samples.dtype == np.float32
    assert [s.kind for s in u.sentences] == ["exclamation", "question"]
    assert [w.text for w in u.words] == ["Hi", "Can", "you", "show", "me", "the", "way", "to", "the",
                                         "conference", "hall"]
    for w in u.words:  # spans index the original text
        assert THESIS_EXAMPLE[w.text_start:w.text_end] == w.text
    assert [e.emotion for e in u.emotions] == ["kidding", "happy"]
    kidding = u.emotions[0]
    assert THESIS_EXAMPLE[kidding.text_start:kidding.text_end] == ";-)"
    assert u.words[0].end <= kidding.time <= u.words[1].start
    assert u.emotions[1].time == pytest.approx(u.words[-1].end)
    assert "conference" in {u.words[s.word].text for s in u.accented_syllables}
    assert not any(u.words[s.word].function_word for s in u.accented_syllables)
    assert [p.kind for p in u.pauses][0] == "leading" and "sentence" in [p.kind for p in u.pauses]
    assert len(u.phrases) >= 2


def test_phone_timing_tiles_the_audio(example):
    u = example
    starts = np.array([p.start for p in u.phones])
    ends = np.array([p.end for p in u.phones])
    assert starts[0] == 0.0 and ends[-1] == pytest.approx(u.duration, abs=1e-6)
    assert np.allclose(starts[1:], ends[:-1])
    assert all(p.duration > 0 for p in u.phones)
    for w in u.words:
        assert all(u.phones[i].word == u.words.index(w) for i in w.phones)
        assert w.start == u.phones[w.phones[0]].start and w.end == u.phones[w.phones[-1]].end
    vowels = [p for p in u.phones if p.phone in ("ay", "ow", "ey", "ao", "aa", "uw", "iy", "ae", "ax")]
    assert all(0.02 < p.duration < 0.5 for p in vowels)
    # the audio agrees with the events: long pauses are quiet, vowels are loud
    def rms(a, b):
        seg = u.samples[int(a * u.sample_rate):int(b * u.sample_rate)]
        return float(np.sqrt(np.mean(seg.astype(np.float64) ** 2))) if seg.size else 0.0
    pause = max((p for p in u.pauses if p.kind == "sentence"), key=lambda p: p.duration)
    assert rms(pause.start + 0.02, pause.end - 0.02) < 0.1 * np.median([rms(p.start, p.end) for p in vowels])


def test_syllables_and_stress(example):
    u = example
    conference = next(w for w in u.words if w.text == "conference")
    assert len(conference.syllables) >= 2
    stresses = [u.syllables[s].stress for s in conference.syllables]
    assert stresses[0] == 1
    for s in u.syllables:
        assert all(u.phones[i].syllable == u.syllables.index(s) for i in s.phones)


def test_pitch_contour(example):
    c = example.pitch
    assert np.allclose(np.diff(c.times), 0.01)
    voiced = c.f0_hz[np.isfinite(c.f0_hz)]
    assert 0.3 < voiced.size / c.f0_hz.size < 0.95  # NaN marks unvoiced frames
    assert 70 < np.median(voiced) < 250


def test_rate_pitch_volume_are_settable():
    slow = synthesize("The quick brown fox jumps over the lazy dog.", rate=120)
    fast = synthesize("The quick brown fox jumps over the lazy dog.", rate=300)
    assert fast.duration < 0.7 * slow.duration
    low = synthesize("The quick brown fox jumps over the lazy dog.", pitch=10)
    high = synthesize("The quick brown fox jumps over the lazy dog.", pitch=90)
    assert np.nanmedian(high.pitch.f0_hz) > 1.2 * np.nanmedian(low.pitch.f0_hz)
    quiet = synthesize("The quick brown fox.", volume=30)
    loud = synthesize("The quick brown fox.", volume=150)
    assert np.abs(loud.samples).max() > 2 * np.abs(quiet.samples).max()


def test_german_poem_table_4_2():
    u = synthesize(POEM, voice="de")
    texts = [w.text for w in u.words]
    assert texts[:4] == ["Es", "gingen", "zwei", "Parallelen"] and texts[-1] == "Seraphim"
    assert "wußtens" in texts and "Lichtjahre" in texts
    assert [e.emotion for e in u.emotions] == ["kidding", "sad", "sad", "surprised", "surprised", "happy"]
    ins, endlose = texts.index("ins"), texts.index("Endlose")
    assert u.emotions[0].previous_word == ins and u.emotions[0].next_word == endlose
    assert u.words[ins].end <= u.emotions[0].time <= u.words[endlose].start
    assert u.emotions[-1].time == pytest.approx(u.words[-1].end)
    assert {"xj", "ts", "ay", "aw"} <= {p.phone for p in u.phones}  # sich, zwei, Haus
    assert "question" in [s.kind for s in u.sentences]  # "Warn sie noch Parallelen?"
    assert len(u.phrases) > len(u.sentences)
    assert not u.warnings


@pytest.mark.parametrize("voice, text, words, kinds", [
    ("ru", "Привет, как дела? Хорошо.", ["Привет", "как", "дела", "Хорошо"], ["question", "statement"]),
    ("el", "Καλημέρα κόσμε. Τι κάνεις;", ["Καλημέρα", "κόσμε", "Τι", "κάνεις"], ["statement", "question"]),
])
def test_non_latin_scripts(voice, text, words, kinds):
    u = synthesize(text, voice=voice)
    assert [w.text for w in u.words] == words
    assert [s.kind for s in u.sentences] == kinds
    assert not u.warnings  # every phone of the voice maps onto the inventory


def test_voices_are_listed():
    voices = list_voices()
    languages = {lang for v in voices for lang in v.languages}
    assert {"en-us", "de", "ru", "el"} <= languages


@pytest.mark.parametrize("text, message", [
    ("", "empty"), ("   \n ", "empty"), (":-) ;-)", "only emoticons"), ("?!", "nothing to speak"),
])
def test_bad_text(text, message):
    with pytest.raises(UserError, match=message):
        synthesize(text)


def test_bad_voice_and_parameters():
    with pytest.raises(UserError, match="unknown espeak-ng voice"):
        synthesize("hello", voice="xx-notalanguage")
    with pytest.raises(UserError, match="rate"):
        synthesize("hello", rate=5)
    with pytest.raises(UserError, match="pitch"):
        synthesize("hello", pitch=500)


def test_twenty_thousand_characters():
    text = ("The quick brown fox jumps over the lazy dog, and then it runs away. Can you see it? " * 300)[:20000]
    u = synthesize(text)  # its speed is measured in bench/, not asserted here
    assert len(u.words) > 3500 and u.words[-1].text_end > 19900
    assert sum(s.kind == "question" for s in u.sentences) > 200
    assert u.duration > 600


def test_same_text_gives_same_samples_within_one_process():
    """Regression: espeak-ng's static state made a repeated line a few samples longer (module espeak,
    "Repeatability"); every synthesis now starts from a fresh library instance."""
    first = synthesize("Good morning, this line is spoken twice.")
    synthesize("Something else in between, at another rate.", rate=260, pitch=80)
    again = synthesize("Good morning, this line is spoken twice.")
    assert first.samples.tobytes() == again.samples.tobytes()
    assert [(p.symbol, p.start, p.duration) for p in first.phones] == [(p.symbol, p.start, p.duration) for p in again.phones]
