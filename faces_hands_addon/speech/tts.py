# SPDX-License-Identifier: GPL-3.0-or-later
"""Text -> :class:`Utterance` with espeak-ng (thesis 4.3.2-4.3.4, the MARY role).

Steps: the emoticons of Table 4.1 are blanked out of the text and kept as emotion tags; espeak-ng
synthesises the cleaned text twice (once reporting its own phoneme names, which are the ``symbol`` of
each phone and carry stress and pauses; once reporting IPA names, which map any voice's phonemes
onto the unified inventory); the events give words (merged per text token; a word event that covers
several text words is split back, so every text word is one :class:`Word`: ``speech.words``),
sentences (espeak's sentence events), intonational phrases (espeak's clause ends, which follow
punctuation and carry its pauses) and phone timing; F0 is measured on the audio.

Decisions (documented for callers):

* Characters the voice has no rules for (kanji in ``ja``: espeak reads them as the English words
  "Chinese letter") are named in ``Utterance.warnings`` (``speech.words.unreadable_characters``).
* Text with nothing to speak -- empty, blank, or only emoticons -- raises :class:`UserError`
  (an emotion needs words to be timed against; thesis 4.3.5).
* A phoneme event that is only a length mark (``ː``, Konkani) lengthens the phone before it.
* espeak sometimes reports a phone with zero duration (a final /l/ folded into the vowel before a
  pause); it is given the last 35 % of the phone before it so every phone has a visible segment.
* The two syntheses can differ by a few samples (espeak keeps state between calls); only the phone
  *names* of the IPA pass are used, and only when it has exactly as many phonemes as the first.
"""
from __future__ import annotations

import unicodedata

import numpy as np

from ..core.errors import UserError
from . import espeak, words
from .emoticons import blank_unknown_emoticons, extract_emoticons, unknown_emoticon_warning
from .phonemes import SILENCE, from_espeak, from_ipa, split_stress
from .pitch import track_pitch
from .utterance import Phone, Utterance, WordDraft, assemble_utterance, token_spans

ZERO_DURATION_SHARE = 0.35
_UNSPACED_SCRIPTS = ("CJK", "HIRAGANA", "KATAKANA", "THAI", "LAO", "KHMER", "MYANMAR", "TIBETAN")


def _unspaced(ch: str) -> bool:
    """A character of a script written without spaces between words (Chinese, Japanese, Thai ...)."""
    return any(script in unicodedata.name(ch, "") for script in _UNSPACED_SCRIPTS)


def word_spans(text: str, word_positions: list[int]) -> list[tuple[int, int]]:
    """Text spans of the words espeak spoke: whitespace tokens (edge punctuation trimmed), split
    further where espeak starts a word after punctuation or inside a script written without
    spaces ("你好，世界" -> 你好 / 世界), but not inside a number or a plain word ("1234")."""
    spans = []
    positions = sorted(set(word_positions))
    for start, end in token_spans(text):
        cuts = [p for p in positions if start < p < end
                and (not text[p - 1].isalnum() or _unspaced(text[p]) or _unspaced(text[p - 1]))]
        for a, b in zip([start] + cuts, cuts + [end]):
            spans.extend((a + x, a + y) for x, y in token_spans(text[a:b]))
    return spans


def _language_of(voice: str) -> str:
    """Language code of an espeak voice name ('en-us+f3' -> 'en-us')."""
    return voice.strip().split("+")[0].lower()


def _unified(name: str, ipa_name: str | None, language: str, unknown: set[str]) -> tuple[str, ...]:
    if name.startswith("_"):
        return (SILENCE,)
    if ipa_name:
        try:
            result = from_ipa(ipa_name, language)
            if result != (SILENCE,):
                return result
        except UserError:
            pass
    try:
        return from_espeak(name, language)
    except UserError:
        unknown.add(name)
        return ("ax",)


def synthesize(text: str, voice: str = "en-us", rate: float = 175, pitch: float = 50,
               volume: float = 100) -> Utterance:
    """Speak ``text`` with espeak-ng and describe it (see the module docstring).

    ``voice`` is any espeak-ng voice ('en-us', 'de', 'ru', 'el', 'en-us+f3', ...); ``rate`` in words
    per minute (80..450), ``pitch`` 0..100, ``volume`` 0..200 (percent)."""
    if not isinstance(text, str):
        raise UserError("the text to speak must be a string")
    if not text.strip():
        raise UserError("the text is empty; type something to speak")
    cleaned, tags = extract_emoticons(text)
    cleaned, unknown_emoticons = blank_unknown_emoticons(cleaned)
    if not any(ch.isalnum() for ch in cleaned):
        if tags or unknown_emoticons:
            raise UserError("the text has only emoticons and nothing to speak; add words around them")
        raise UserError("the text has nothing to speak (no letters or digits)")
    language = _language_of(voice)

    named = espeak.synthesize_raw(cleaned, voice, rate, pitch, volume, ipa_names=False)
    language = named.language or language
    ipa = espeak.synthesize_raw(cleaned, voice, rate, pitch, volume, ipa_names=True)
    named_phonemes = [e for e in named.events if e.kind == espeak.EVENT_PHONEME]
    ipa_phonemes = [e for e in ipa.events if e.kind == espeak.EVENT_PHONEME]
    ipa_names = [e.name for e in ipa_phonemes] if len(ipa_phonemes) == len(named_phonemes) else None

    sr = named.sample_rate
    total = len(named.samples)
    samples = named.samples.astype(np.float32) / 32768.0
    warnings: list[str] = [unknown_emoticon_warning(unknown_emoticons)] if unknown_emoticons else []
    if ipa_names is None:
        warnings.append("espeak-ng's IPA pass disagreed; phones were read from espeak names only")

    # walk the events: phones with their word event, sentence starts and clause ends
    spans = word_spans(cleaned, [e.text_position for e in named.events if e.kind == espeak.EVENT_WORD])
    span_starts = np.array([s for s, _ in spans]) if spans else np.zeros(0, int)
    raw_phones: list[tuple[str, tuple[str, ...], int, int, int]] = []  # symbol, unified, stress, sample, token
    token_sentence: dict[int, int] = {}
    phrase_end_tokens: set[int] = set()
    unknown: set[str] = set()
    sentence = 0
    current_token = -1
    last_token = -1
    phoneme_index = 0
    for event in named.events:
        if event.kind == espeak.EVENT_SENTENCE:
            sentence += 1
        elif event.kind == espeak.EVENT_WORD:
            # the word whose span holds the event; an event between words (espeak reading out a
            # symbol as several words) belongs to the word before it
            token = max(int(np.searchsorted(span_starts, event.text_position, side="right")) - 1, 0)
            if not spans:
                continue
            current_token = token
            token_sentence.setdefault(token, sentence)
        elif event.kind == espeak.EVENT_END:
            if last_token >= 0:
                phrase_end_tokens.add(last_token)
            current_token = -1
        elif event.kind == espeak.EVENT_PHONEME:
            if espeak.not_a_phone(event.name):  # a language switch "(en)" or a lone length mark
                phoneme_index += 1
                continue
            bare, stress = split_stress(event.name)
            unified = _unified(bare, ipa_names[phoneme_index] if ipa_names else None, language, unknown)
            is_pause = unified == (SILENCE,)
            token = -1 if is_pause else current_token
            raw_phones.append((bare or "_", unified, stress, event.sample, token))
            if token >= 0:
                last_token = token
            phoneme_index += 1
    warnings.extend(_reading_warnings(unknown, named.events, cleaned, voice, language))
    raw_phones = _every_word(raw_phones, spans, cleaned, voice, rate, token_sentence, phrase_end_tokens)

    phones, token_phones = _timed_phones(raw_phones, sr, total)
    drafts = [WordDraft(spans[t][0], spans[t][1], idx, token_sentence.get(t, 0), t in phrase_end_tokens)
              for t, idx in token_phones.items()]
    contour = track_pitch(samples, sr)
    return assemble_utterance(text=text, language=language, samples=samples, sample_rate=sr,
                              phones=phones, words=drafts, emotions=tags, pitch=contour, source="tts",
                              warnings=warnings)


def _reading_warnings(unknown: set[str], events, text: str, voice: str, language: str) -> list[str]:
    """Warnings about what espeak-ng could not read: phoneme names outside every table, and characters
    the voice has no rules for (:func:`words.unreadable_characters`)."""
    found = [f"unknown espeak phonemes read as schwa: {' '.join(sorted(unknown))}"] if unknown else []
    unreadable = words.unreadable_warning(words.unreadable_characters(events, text, voice, language), language)
    return found + ([unreadable] if unreadable else [])


def _every_word(raw_phones, spans, text, voice, rate, token_sentence, phrase_end_tokens):
    """Split espeak's merged word events back into the text's words (:func:`words.split_merged`); a
    split-off word joins its head's sentence, and the last word of the run ends the phrase if the
    head did."""
    raw_phones, head_of = words.split_merged(raw_phones, spans, text, voice, rate)
    for token, head in sorted(head_of.items()):
        if token != head:
            token_sentence.setdefault(token, token_sentence.get(head, 0))
    for head in sorted(set(head_of.values())):
        run = [t for t, h in head_of.items() if h == head]
        if head in phrase_end_tokens:
            phrase_end_tokens.discard(head)
            phrase_end_tokens.add(max(run))
    return raw_phones


def pronounce(text: str, voice: str = "en-us") -> dict[tuple[int, int], list[tuple[str, int]]]:
    """espeak-ng's pronunciation of every token of ``text``: ``{(start, end): [(unified phone,
    stress), ...]}`` keyed by the token spans of :func:`utterance.token_spans` (numbers and
    abbreviations get their spoken expansion)."""
    raw = espeak.synthesize_raw(text, voice, ipa_names=True)
    language = raw.language or _language_of(voice)
    spans = token_spans(text)
    starts = np.array([s for s, _ in spans]) if spans else np.zeros(0, int)
    result: dict[tuple[int, int], list[tuple[str, int]]] = {}
    token = -1
    for event in raw.events:
        if event.kind == espeak.EVENT_WORD:
            token = max(int(np.searchsorted(starts, event.text_position, side="right")) - 1, 0) if spans else -1
        elif event.kind == espeak.EVENT_END:
            token = -1
        elif event.kind == espeak.EVENT_PHONEME and token >= 0 and event.name:
            bare, stress = split_stress(event.name)
            try:
                units = from_ipa(bare, language)
            except UserError:
                continue
            for j, unit in enumerate(units):
                if unit != SILENCE:
                    result.setdefault(spans[token], []).append((unit, stress if j == 0 else 0))
    return result


def _timed_phones(raw_phones, sample_rate: int, total_samples: int):
    """Turn phoneme events into contiguous :class:`Phone` segments: durations run to the next event,
    pauses merge, multi-phone names split evenly, zero-length phones borrow from their predecessor."""
    starts = [r[3] for r in raw_phones] + [total_samples]
    segments: list[list] = []  # [symbol, phone, stress, start_sample, end_sample, token]
    for k, (symbol, unified, stress, start, token) in enumerate(raw_phones):
        end = max(starts[k + 1], start)
        if unified == (SILENCE,):
            if segments and segments[-1][1] == SILENCE:
                segments[-1][4] = end
            else:
                segments.append([symbol, SILENCE, 0, start, end, -1])
            continue
        n = len(unified)
        for j, name in enumerate(unified):
            a = start + (end - start) * j // n
            b = start + (end - start) * (j + 1) // n
            segments.append([symbol, name, stress if j == 0 else 0, a, b, token])
    if segments and segments[0][3] > 0:
        if segments[0][1] == SILENCE:
            segments[0][3] = 0
        else:
            segments.insert(0, ["_", SILENCE, 0, 0, segments[0][3], -1])
    # zero-length phones take the end of the phone before them (same word), else of the next
    for k, seg in enumerate(segments):
        if seg[1] == SILENCE or seg[4] > seg[3]:
            continue
        if k > 0 and segments[k - 1][1] != SILENCE and segments[k - 1][4] > segments[k - 1][3]:
            prev = segments[k - 1]
            cut = prev[4] - max(1, int((prev[4] - prev[3]) * ZERO_DURATION_SHARE))
            seg[3], prev[4] = cut, cut
        elif k + 1 < len(segments) and segments[k + 1][4] > segments[k + 1][3]:
            nxt = segments[k + 1]
            cut = nxt[3] + max(1, int((nxt[4] - nxt[3]) * ZERO_DURATION_SHARE))
            seg[4], nxt[3] = cut, cut
    segments = [s for s in segments if s[4] > s[3]]
    phones: list[Phone] = []
    token_phones: dict[int, list[int]] = {}
    for symbol, name, stress, a, b, token in segments:
        if token >= 0:
            token_phones.setdefault(token, []).append(len(phones))
        phones.append(Phone(symbol, name, a / sample_rate, (b - a) / sample_rate, stress))
    return phones, token_phones

