# SPDX-License-Identifier: GPL-3.0-or-later
"""Every word of the text kept (thesis 4.3.2, Table 4.3: MARY gives MEDUSA *every* word with its text
span and timing), and the characters a voice cannot read.

espeak-ng sometimes speaks several text words under ONE word event ("on the" -> one event "on" whose
phonemes are /ɒ n ð ə/), and it reads characters it has no rules for by switching to another
language's rules (the ``ja`` voice reads a kanji as the English words "Chinese letter"). This module
repairs the first and reports the second; :func:`tts.synthesize` calls both.
"""
from __future__ import annotations

import unicodedata

from . import espeak
from .phonemes import split_stress

#: a phone event as :func:`tts.synthesize` collects it: (symbol, unified phones, stress, sample, token)
RawPhone = tuple


def _spoken(events) -> list[str]:
    """espeak-ng's names (stress stripped) of the phoneme events that are phones (no pauses ``_``, no
    language switches ``(xx)``, no lone length marks)."""
    return [split_stress(e.name)[0] for e in events if e.kind == espeak.EVENT_PHONEME and e.name
            and not e.name.startswith("_") and not espeak.not_a_phone(e.name)]


def isolated_phonemes(words: list[str], voice: str, rate: float) -> list[list[str]]:
    """espeak-ng's phonemisation of each word spoken alone (its phone names, in order)."""
    return [_spoken(espeak.synthesize_raw(w, voice, rate).events) for w in words]


def _distance(a: list[str], b: list[str]) -> int:
    """Levenshtein distance between two phone-name sequences."""
    row = list(range(len(b) + 1))
    for i, x in enumerate(a, 1):
        previous, row[0] = row[0], i
        for j, y in enumerate(b, 1):
            previous, row[j] = row[j], min(row[j] + 1, row[j - 1] + 1, previous + (x != y))
    return row[-1]


def allocate(merged: list[str], isolated: list[list[str]]) -> list[int]:
    """How many of the ``merged`` event's phones belong to each word, given each word's own
    phonemisation ``isolated``.

    When the words' phone counts add up to the event's (the usual case: the merged event is the words'
    phonemes run together) the split is exact. Otherwise the split is the one whose pieces are closest
    to the words' own phonemisations (least total edit distance over phone names, dynamic programming
    over the cut points), every word keeping at least one phone while there are phones to give."""
    total, k = len(merged), len(isolated)
    counts = [len(x) for x in isolated]
    if sum(counts) == total and min(counts) > 0:
        return counts
    if total < k:  # fewer phones than words: one each, from the left
        return [1] * total + [0] * (k - total)
    inf = float("inf")
    best = [[inf] * (total + 1) for _ in range(k + 1)]
    cut = [[0] * (total + 1) for _ in range(k + 1)]
    best[0][0] = 0
    for i in range(1, k + 1):
        for j in range(i, total - (k - i) + 1):
            for b in range(i - 1, j):
                cost = best[i - 1][b] + _distance(merged[b:j], isolated[i - 1])
                if cost < best[i][j]:
                    best[i][j], cut[i][j] = cost, b
    shares, j = [], total
    for i in range(k, 0, -1):
        shares.append(j - cut[i][j])
        j = cut[i][j]
    return shares[::-1]


def merge_groups(raw_phones: list[RawPhone], n_tokens: int) -> list[list[int]]:
    """Runs of tokens espeak spoke under one word event: a token with phones followed by the tokens
    after it that received none (they were spoken inside its event)."""
    with_phones = sorted({r[4] for r in raw_phones if r[4] >= 0})
    groups = []
    for n, token in enumerate(with_phones):
        stop = with_phones[n + 1] if n + 1 < len(with_phones) else n_tokens
        if stop - token > 1:
            groups.append(list(range(token, stop)))
    return groups


def split_merged(raw_phones: list[RawPhone], spans: list[tuple[int, int]], text: str, voice: str,
                 rate: float) -> tuple[list[RawPhone], dict[int, int]]:
    """Give the words of every merged word event their own phones.

    The phones of the event (in order) are shared between its words by :func:`allocate`, using
    espeak-ng's phonemisation of each word spoken alone (:func:`isolated_phonemes`) to know which
    belong to each. Returns the phones with their new tokens and ``{merged token: head token}``."""
    out = list(raw_phones)
    head_of: dict[int, int] = {}
    for group in merge_groups(raw_phones, len(spans)):
        indices = [i for i, r in enumerate(out) if r[4] == group[0]]
        isolated = isolated_phonemes([text[a:b] for a, b in (spans[t] for t in group)], voice, rate)
        shares = allocate([out[i][0] for i in indices], isolated)
        position = 0
        for token, share in zip(group, shares):
            for i in indices[position:position + share]:
                out[i] = out[i][:4] + (token,)
            position += share
            head_of[token] = group[0]
    return out, head_of


def _switch(name: str, language: str) -> str | None:
    """The language of a switch marker ``(xx)`` when it is not the voice's own language."""
    if not (name.startswith("(") and name.endswith(")")):
        return None
    other = name[1:-1]
    return None if other.split("-")[0] == language.split("-")[0] else other


def _switches(events, language: str) -> set[str]:
    return {s for e in events if e.kind == espeak.EVENT_PHONEME for s in [_switch(e.name, language)] if s}


def unreadable_characters(events, text: str, voice: str, language: str) -> dict[str, str]:
    """Characters the voice has no rules for: ``{character: the language espeak-ng read it as}``.

    A word event whose phonemes switch to another language (``(en)`` in a ``ja`` text) is examined
    character by character: a character that, spoken alone, also makes espeak-ng switch language is
    one the voice cannot read (espeak spells it out with foreign rules, e.g. kanji as "Chinese
    letter")."""
    suspects: dict[str, None] = {}
    word_span = None
    for e in events:
        if e.kind == espeak.EVENT_WORD:
            word_span = (e.text_position, e.text_position + max(e.length, 1))
        elif e.kind == espeak.EVENT_PHONEME and word_span and _switch(e.name, language):
            suspects.update((c, None) for c in text[word_span[0]:word_span[1]] if not c.isspace())
    found = {}
    for character in suspects:
        other = _switches(espeak.synthesize_raw(character, voice).events, language)
        if other:
            found[character] = sorted(other)[0]
    return found


def unreadable_warning(found: dict[str, str], language: str) -> str | None:
    """One clear line naming the characters of :func:`unreadable_characters` (None when there are none)."""
    if not found:
        return None
    readers = ", ".join(sorted(set(found.values())))
    example = ", e.g. a kanji as the words 'Chinese letter'" if any(
        "CJK" in unicodedata.name(c, "") for c in found) else ""
    return (f"espeak-ng's '{language}' voice cannot read {len(found)} character(s): {' '.join(found)} "
            f"(it read them with its '{readers}' rules{example}); the mouth moves for what espeak said, "
            "not for the text; write them in a script the voice reads")
