"""Utterances built directly (no synthesis): many pitch maxima, pauses of every kind, accents, questions
and filled pauses, with a known layout so the tests can count the candidates of every rule; and the
fixtures the behaviour tests share (computed once per session, whichever module asks first).

Test modules import the fixtures by name (a conftest.py here would shadow the suite's top-level
``conftest`` module that other tests import)."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from faces_hands_addon.speech.pitch import PitchContour
from faces_hands_addon.speech.utterance import Phone, WordDraft, assemble_utterance

SYLLABLE_S = 0.25           # CV syllables: consonant 0.1 s + vowel 0.15 s
PEAK_HZ = (150.0, 190.0)    # the pitch of the accented syllables (a clear maximum each)
BASE_HZ = 110.0


def build(sentences, *, phrase_pause=0.3, sentence_pause=0.5, long_pause=1.0, seed=0, rate=16000):
    """``sentences``: list of (kind, phrases); a phrase is a list of words; a word is a number of syllables
    (its first syllable accented when it is a content word) or the string "errr" (a filled pause) or
    "LONG" (a silent long pause between two words of a phrase). ``kind`` is "." / "?" / "!"."""
    rng = np.random.default_rng(seed)
    phones, drafts, text, t = [], [], "", 0.0
    peaks = []                              # (time, hz) of the accents

    def pause(duration):
        nonlocal t
        phones.append(Phone("_", "sil", t, duration))
        t += duration

    pause(0.2)
    for n, (kind, phrases) in enumerate(sentences):
        for p, phrase in enumerate(phrases):
            for w, word in enumerate(phrase):
                if word == "LONG":
                    pause(long_pause)
                    continue
                start_text = len(text)
                indices = []
                if word == "errr":
                    text += "errr"
                    indices.append(len(phones))
                    phones.append(Phone("3:", "er", t, 0.6, 0))
                    t += 0.6
                else:
                    syllables = int(word)
                    text += "ta" * syllables if syllables > 1 else "tak"
                    for s in range(syllables):
                        stress = 1 if s == 0 else 0
                        indices.append(len(phones))
                        phones.append(Phone("t", "t", t, 0.1, 0))
                        indices.append(len(phones))
                        phones.append(Phone("a", "aa", t + 0.1, 0.15, stress))
                        if stress:
                            peaks.append((t + 0.175, float(rng.uniform(*PEAK_HZ))))
                        t += SYLLABLE_S
                last_word = w == len(phrase) - 1
                drafts.append(WordDraft(start_text, len(text), indices, n, ends_phrase=last_word))
                text += " "
            if p < len(phrases) - 1:
                text = text[:-1] + ", "
                pause(phrase_pause)
        text = text[:-1] + {".": ". ", "?": "? ", "!": "! "}[kind]
        pause(sentence_pause if n < len(sentences) - 1 else 0.4)
    duration = t
    samples = np.zeros(int(round(duration * rate)), np.float32)
    times = np.arange(int(np.ceil(duration / 0.01))) * 0.01
    f0 = np.full(times.shape, BASE_HZ)
    for centre, hz in peaks:
        f0 += (hz - BASE_HZ) * np.exp(-0.5 * ((times - centre) / 0.05) ** 2)
    f0 *= 1.0 + 0.003 * rng.standard_normal(times.shape)
    voiced = np.zeros(times.shape, bool)
    for ph in phones:
        if ph.phone not in ("sil", "t"):
            voiced |= (times >= ph.start) & (times < ph.end)
    f0 = np.where(voiced, f0, np.nan)
    utterance = assemble_utterance(text=text.strip(), language="en", samples=samples, sample_rate=rate,
                                   phones=phones, words=drafts, emotions=[],
                                   pitch=PitchContour(times, f0, 0.01), source="tts", warnings=[])
    return utterance, peaks


def long_monologue(seed=0, sentences=12):
    """A monologue of statements and questions with phrase pauses, long pauses and filled pauses."""
    rng = np.random.default_rng(1000 + seed)
    out = []
    for n in range(sentences):
        phrases = []
        for _ in range(int(rng.integers(2, 4))):
            phrase = [str(int(rng.integers(1, 4))) for _ in range(int(rng.integers(2, 5)))]
            if rng.random() < 0.3:
                phrase.insert(1, "LONG")
            if rng.random() < 0.2:
                phrase.insert(1, "errr")
            phrases.append(phrase)
        out.append(("?" if n % 3 == 2 else ".", phrases))
    return build(out, seed=seed)


SEEDS = 80


@functools.cache
def _monologues():
    return tuple(long_monologue(seed) for seed in range(SEEDS))


@functools.cache
def _neutral_runs():
    from faces_hands_addon.behavior import generate_behavior
    return tuple((u, generate_behavior(u, "neutral", seed=seed)) for seed, (u, _) in enumerate(_monologues()))


@pytest.fixture
def monologues():
    """(utterance, accent peaks) of SEEDS different monologues."""
    return _monologues()


@pytest.fixture
def neutral_runs():
    """The neutral style's behaviour of every monologue, one seed each."""
    return _neutral_runs()
