# SPDX-License-Identifier: GPL-3.0-or-later
"""The engine-side utterance: audio plus its full phonetic and prosodic description.

This is what MARY's XML gave MEDUSA in the thesis (4.3.2, Table 4.3): sentences with their type
(statement / question / exclamation), intonational phrases, words with their text span and timing,
syllables and phonemes with stress and duration, accented syllables, pauses, the F0 contour and the
emotion tags of the emoticons (Table 4.1). The text-to-speech path (:func:`speech.synthesize`) and
the recorded-audio path (:func:`speech.align_audio`) both build one with :func:`assemble_utterance`.

All times are seconds from the first audio sample. Text offsets index the ORIGINAL input text
(before the emoticons were blanked out), as Python string indices (code points).
"""
from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass, field, replace

import numpy as np

from .emoticons import EmotionTag
from .phonemes import PHONES, is_vowel
from .pitch import PitchContour

_TOKEN = re.compile(r"\S+")
_EDGE_PUNCTUATION = "\"'“”‘’«»„‚()[]{}<>.,;:!?¿¡…-–—*_/\\|"

STATEMENT, QUESTION, EXCLAMATION = "statement", "question", "exclamation"

FUNCTION_WORDS = {
    "en": set("""a an the and or but nor if so as than then that this these those there here of to in
        on at by for with from into onto upon about over under up down out off is are was were be been
        being am do does did done have has had having i you he she it we they me him her us them my your
        his its our their mine yours hers ours theirs not no can could will would shall should may might
        must let lets i'm you're he's she's it's we're they're i've you've we've they've i'll you'll
        he'll she'll we'll they'll i'd you'd he'd she'd we'd they'd isn't aren't wasn't weren't don't
        doesn't didn't can't couldn't won't wouldn't shouldn't just""".split()),
    "de": set("""der die das den dem des ein eine einen einem einer eines und oder aber denn doch zu zum
        zur in im ins an am auf aus bei mit nach von vom vor für um durch über unter ist sind war waren
        bin bist sein seid hat haben hatte hatten wird werden wurde wurden ich du er sie es wir ihr mich
        dich sich mir dir ihm ihn ihnen uns euch mein dein sein ihr unser nicht als wie so da dass ob
        wenn noch nur schon auch ja man""".split()),
}


@dataclass(frozen=True)
class Phone:
    """One phone segment. ``symbol`` is the source's own name without stress marks (espeak-ng name
    for synthesis, ARPAbet for alignment), ``phone`` the unified inventory name (``speech.phonemes``),
    ``stress`` 1 primary / 2 secondary / 0 none, ``word``/``syllable`` indices (-1 for pauses)."""

    symbol: str
    phone: str
    start: float
    duration: float
    stress: int = 0
    word: int = -1
    syllable: int = -1

    @property
    def end(self) -> float:
        return self.start + self.duration

    @property
    def is_pause(self) -> bool:
        return PHONES[self.phone].kind == "pause"


@dataclass(frozen=True)
class Syllable:
    """Phones ``phones`` (indices into ``Utterance.phones``) of word ``word``; ``accented`` marks a
    stressed syllable of a content word (4.3.2: "accents are placed on content words")."""

    start: float
    end: float
    word: int
    phones: tuple[int, ...]
    stress: int
    accented: bool


@dataclass(frozen=True)
class Word:
    text: str
    text_start: int
    text_end: int
    start: float
    end: float
    phones: tuple[int, ...]
    syllables: tuple[int, ...]
    sentence: int
    phrase: int
    function_word: bool


@dataclass(frozen=True)
class Phrase:
    """An intonational phrase (4.3.5: "a natural unit in speech production ... typically surrounded
    by pauses"): words ``first_word..last_word`` of sentence ``sentence``."""

    start: float
    end: float
    first_word: int
    last_word: int
    sentence: int
    pause_after: float


@dataclass(frozen=True)
class Sentence:
    kind: str  # "statement", "question" or "exclamation"
    text_start: int
    text_end: int
    start: float
    end: float
    first_word: int
    last_word: int


@dataclass(frozen=True)
class Pause:
    """A silent stretch. ``kind``: "leading", "trailing", "sentence" (between sentences), "phrase"
    (between intonational phrases of one sentence) or "word" (inside a phrase)."""

    start: float
    duration: float
    kind: str

    @property
    def end(self) -> float:
        return self.start + self.duration


@dataclass
class Utterance:
    """Audio (mono float32 in [-1, 1]) with its phonetic description; see the module docstring."""

    text: str
    language: str
    samples: np.ndarray
    sample_rate: int
    phones: list[Phone]
    syllables: list[Syllable]
    words: list[Word]
    phrases: list[Phrase]
    sentences: list[Sentence]
    pauses: list[Pause]
    emotions: list[EmotionTag]
    pitch: PitchContour
    source: str  # "tts", "alignment" or "phone_recognition"
    warnings: list[str] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return len(self.samples) / float(self.sample_rate) if self.sample_rate else 0.0

    @property
    def accented_syllables(self) -> list[Syllable]:
        return [s for s in self.syllables if s.accented]

    def segments(self) -> list[tuple[str, float, float]]:
        """``(unified phone, start, duration)`` of every phone, pauses included: the input of the
        coarticulation (3.1.3: "as input it requires the phonemes ... and their durations")."""
        return [(p.phone, p.start, p.duration) for p in self.phones]


def sentence_kind(punctuation: str, language: str = "") -> str:
    """Sentence type from the punctuation that ends it (a question mark wins over "!")."""
    question_marks = "?？¿;;" if language.lower().startswith("el") else "?？¿؟"
    if any(c in punctuation for c in question_marks) or "\u037e" in punctuation:
        return QUESTION
    if any(c in punctuation for c in "!！¡"):
        return EXCLAMATION
    return STATEMENT


def _edge(ch: str) -> bool:
    return ch in _EDGE_PUNCTUATION or unicodedata.category(ch).startswith("P")


def token_spans(text: str) -> list[tuple[int, int]]:
    """Whitespace-separated tokens with surrounding punctuation (any script) trimmed (offsets into
    ``text``)."""
    spans = []
    for match in _TOKEN.finditer(text):
        start, end = match.start(), match.end()
        while start < end and _edge(text[start]):
            start += 1
        while end > start and _edge(text[end - 1]):
            end -= 1
        if end > start:
            spans.append((start, end))
    return spans


def is_function_word(text: str, language: str) -> bool:
    words = FUNCTION_WORDS.get(language.lower()[:2])
    return bool(words) and text.lower().replace("’", "'").strip(".,;:!?\"'()") in words


def _syllabify(word_phones: list[int], phones: list[Phone]) -> list[list[int]]:
    """Group a word's phones into syllables: one per vowel nucleus, consonants between two nuclei
    split half to the coda (rounded down) and the rest to the next onset."""
    nuclei = [k for k, i in enumerate(word_phones) if is_vowel(phones[i].phone)]
    if not nuclei:
        return [list(word_phones)]
    bounds = [0]
    for a, b in zip(nuclei, nuclei[1:]):
        cluster = b - a - 1
        bounds.append(a + 1 + cluster // 2)
    bounds.append(len(word_phones))
    return [word_phones[bounds[k]:bounds[k + 1]] for k in range(len(nuclei))]


def _emotion_times(tags: list[EmotionTag], words: list[Word]) -> list[EmotionTag]:
    """Apex of each emotion at its text position (4.3.5): the middle of the gap between the word
    before and the word after the emoticon (the end of the word before if it is the last one)."""
    resolved = []
    for tag in tags:
        before = [i for i, w in enumerate(words) if w.text_end <= tag.text_start]
        after = [i for i, w in enumerate(words) if w.text_start >= tag.text_end]
        prev_word = before[-1] if before else -1
        next_word = after[0] if after else -1
        if prev_word >= 0 and next_word >= 0:
            time = 0.5 * (words[prev_word].end + words[next_word].start)
        elif prev_word >= 0:
            time = words[prev_word].end
        elif next_word >= 0:
            time = words[next_word].start
        else:
            time = None
        resolved.append(replace(tag, time=time, previous_word=prev_word, next_word=next_word))
    return resolved


@dataclass
class WordDraft:
    """A word before assembly: its text span and the indices of its phones."""

    text_start: int
    text_end: int
    phones: list[int]
    sentence: int
    ends_phrase: bool = False


def _syllables(phones: list[Phone], words: list[WordDraft], function_flags: list[bool]):
    """Syllables of every word (stress from its vowel; accented = primary stress on a content word); the
    phones learn their syllable."""
    syllables: list[Syllable] = []
    word_syllables: list[tuple[int, ...]] = []
    for k, draft in enumerate(words):
        own = []
        for group in _syllabify(draft.phones, phones):
            stress = max((phones[i].stress for i in group if is_vowel(phones[i].phone)),
                         default=0, key=lambda s: {1: 2, 2: 1, 0: 0}[s])
            index = len(syllables)
            for i in group:
                phones[i] = replace(phones[i], syllable=index)
            syllables.append(Syllable(phones[group[0]].start, phones[group[-1]].end, k, tuple(group),
                                      stress, stress == 1 and not function_flags[k]))
            own.append(index)
        word_syllables.append(tuple(own))
    return syllables, word_syllables


def _phrase_bounds(words: list[WordDraft]) -> list[tuple[int, int]]:
    """(first word, last word) of every phrase: a phrase ends at a word marked ``ends_phrase`` and at every
    sentence end."""
    bounds, first = [], 0
    for k, draft in enumerate(words):
        last_in_sentence = k + 1 == len(words) or words[k + 1].sentence != draft.sentence
        if draft.ends_phrase or last_in_sentence:
            bounds.append((first, k))
            first = k + 1
    return bounds


def _sentences(text: str, language: str, final_words: list[Word], count: int) -> list[Sentence]:
    sentences = []
    members_of: dict[int, list[int]] = {}
    for k, w in enumerate(final_words):
        members_of.setdefault(w.sentence, []).append(k)
    for n in range(count):
        a, b = members_of[n][0], members_of[n][-1]
        text_end = final_words[b + 1].text_start if b + 1 < len(final_words) else len(text)
        trailing = text[final_words[b].text_end:text_end]
        sentences.append(Sentence(sentence_kind(trailing, language), final_words[a].text_start,
                                  text_end, final_words[a].start, final_words[b].end, a, b))
    return sentences


def _pauses(phones: list[Phone], final_words: list[Word]) -> list[Pause]:
    """Every pause phone, classified by what it separates (leading, word, phrase, sentence, trailing)."""
    pauses = []
    word_ends = np.array([w.end for w in final_words])
    word_starts = np.array([w.start for w in final_words])
    for ph in phones:
        if not ph.is_pause or ph.duration <= 0:
            continue
        n_before = int(np.searchsorted(word_ends, ph.start + 1e-9, side="right"))
        n_after_start = int(np.searchsorted(word_starts, ph.end - 1e-9, side="left"))
        if n_before == 0:
            kind = "leading"
        elif n_after_start >= len(final_words):
            kind = "trailing"
        elif final_words[n_before - 1].sentence != final_words[n_after_start].sentence:
            kind = "sentence"
        elif final_words[n_before - 1].phrase != final_words[n_after_start].phrase:
            kind = "phrase"
        else:
            kind = "word"
        pauses.append(Pause(ph.start, ph.duration, kind))
    return pauses


def assemble_utterance(*, text: str, language: str, samples: np.ndarray, sample_rate: int,
                       phones: list[Phone], words: list[WordDraft], emotions: list[EmotionTag],
                       pitch: PitchContour, source: str, warnings: list[str]) -> Utterance:
    """Derive words, syllables, accents, phrases, sentences and pauses from timed phones.

    ``phones`` must be in time order and tile the audio; ``words[k].phones`` are indices into it.
    A phrase ends at a word marked ``ends_phrase`` and at every sentence end."""
    phones = list(phones)
    words = [w for w in words if w.phones]
    # words in time order, phones know their word
    words.sort(key=lambda w: w.phones[0])
    for k, draft in enumerate(words):
        for i in draft.phones:
            phones[i] = replace(phones[i], word=k)
    function_flags = [is_function_word(text[w.text_start:w.text_end], language) for w in words]
    syllables, word_syllables = _syllables(phones, words, function_flags)
    sentence_ids = sorted({w.sentence for w in words})
    sentence_of = {s: n for n, s in enumerate(sentence_ids)}
    phrase_bounds = _phrase_bounds(words)
    phrase_of_word: list[int] = []
    for p, (a, b) in enumerate(phrase_bounds):
        phrase_of_word.extend([p] * (b - a + 1))

    def word_start(k):
        return phones[words[k].phones[0]].start

    def word_end(k):
        return phones[words[k].phones[-1]].end

    final_words = [Word(text[w.text_start:w.text_end], w.text_start, w.text_end, word_start(k),
                        word_end(k), tuple(w.phones), word_syllables[k], sentence_of[w.sentence],
                        phrase_of_word[k], function_flags[k]) for k, w in enumerate(words)]
    phrases = []
    for p, (a, b) in enumerate(phrase_bounds):
        next_start = word_start(b + 1) if b + 1 < len(words) else len(samples) / sample_rate
        phrases.append(Phrase(word_start(a), word_end(b), a, b, final_words[a].sentence,
                              max(0.0, next_start - word_end(b))))
    sentences = _sentences(text, language, final_words, len(sentence_ids))
    pauses = _pauses(phones, final_words)
    return Utterance(text=text, language=language, samples=samples, sample_rate=sample_rate,
                     phones=phones, syllables=syllables, words=final_words, phrases=phrases,
                     sentences=sentences, pauses=pauses, emotions=_emotion_times(emotions, final_words),
                     pitch=pitch, source=source, warnings=list(warnings))
