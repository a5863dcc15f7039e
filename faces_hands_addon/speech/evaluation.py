# SPDX-License-Identifier: GPL-3.0-or-later
"""Timing comparisons between two phone or word sequences (tests, bench/speech.py and
bench/lipsync_alignment.py).

References come from a synthesiser that reports where it placed each phone: espeak-ng (the extension's
own, ``synthesize``) or Festival's HTS voice (label files, see ``read_labels``). Aligned phones are
compared with them; the two sides spell words differently (espeak's "can" is /k ae n/, the CMU
dictionary's may be /k ah n/), so phones are paired by a Needleman-Wunsch alignment over the unified
inventory, where a mismatch of the same viseme costs little. Festival's phone set (the "radio" set of
its US voices: ARPAbet in lower case, ``pau`` for pauses, syllabic ``el em en``, flap ``dx``) is mapped
onto the unified phones by ``festival_phone``.
"""
from __future__ import annotations

import os
import re

import numpy as np

from .phonemes import PHONES, from_arpabet
from .utterance import Phone

# Festival radio phones whose unified spelling is not ARPAbet's: a syllabic consonant becomes the
# consonant alone (its onset is the consonant's, whether or not the other side writes a schwa before it).
_FESTIVAL = {"pau": "sil", "h#": "sil", "brth": "sil", "hv": "hh", "nx": "n", "el": "l", "em": "m", "en": "n"}


def _cost(a: str, b: str) -> float:
    if a == b:
        return 0.0
    pa, pb = PHONES[a], PHONES[b]
    if pa.viseme == pb.viseme:
        return 0.5
    if pa.kind == pb.kind:
        return 1.0
    return 2.0


def pair_phones(reference: list[Phone], measured: list[Phone]) -> list[tuple[int, int]]:
    """Index pairs ``(i_reference, j_measured)`` of corresponding non-pause phones."""
    ref = [i for i, p in enumerate(reference) if not p.is_pause]
    mes = [j for j, p in enumerate(measured) if not p.is_pause]
    n, m = len(ref), len(mes)
    gap = 1.0
    score = np.zeros((n + 1, m + 1))
    score[:, 0] = np.arange(n + 1) * gap
    score[0, :] = np.arange(m + 1) * gap
    move = np.zeros((n + 1, m + 1), dtype=np.int8)
    move[1:, 0], move[0, 1:] = 1, 2
    for i in range(1, n + 1):
        a = reference[ref[i - 1]].phone
        for j in range(1, m + 1):
            options = (score[i - 1, j - 1] + _cost(a, measured[mes[j - 1]].phone),
                       score[i - 1, j] + gap, score[i, j - 1] + gap)
            k = int(np.argmin(options))
            score[i, j], move[i, j] = options[k], k
    pairs = []
    i, j = n, m
    while i > 0 or j > 0:
        if i > 0 and j > 0 and move[i, j] == 0:
            if _cost(reference[ref[i - 1]].phone, measured[mes[j - 1]].phone) <= 0.5:
                pairs.append((ref[i - 1], mes[j - 1]))
            i, j = i - 1, j - 1
        elif i > 0 and (j == 0 or move[i, j] == 1):
            i -= 1
        else:
            j -= 1
    return pairs[::-1]


def compare_phone_onsets(reference: list[Phone], measured: list[Phone]) -> np.ndarray:
    """Absolute onset differences (s) of the paired phones of two utterances."""
    pairs = pair_phones(reference, measured)
    return np.array([abs(reference[i].start - measured[j].start) for i, j in pairs])


def festival_phone(name: str) -> str:
    """The unified phone of one Festival radio phone (``pau`` -> ``sil``, ``ax`` -> ``ax``, ...)."""
    name = name.lower()
    return _FESTIVAL[name] if name in _FESTIVAL else from_arpabet(name)[0]


def labelled_phones(rows) -> list[Phone]:
    """``Phone`` objects from label rows ``(festival_phone, start, end)``."""
    return [Phone(symbol=name, phone=festival_phone(name), start=float(a), duration=float(b) - float(a))
            for name, a, b in rows]


def _key(word: str) -> str:
    return re.sub(r"[^\w']", "", word.lower())


def word_timing_errors(reference, measured) -> tuple[np.ndarray, np.ndarray]:
    """Signed (measured - reference) onset and end errors (s) of word pairs. ``reference`` holds
    ``(text, start, end)`` rows, ``measured`` ``Word`` objects; the words must be the same (case and
    punctuation aside), else ``ValueError``."""
    ref_keys = [_key(text) for text, _, _ in reference]
    got_keys = [_key(w.text) for w in measured]
    if ref_keys != got_keys:
        raise ValueError(f"different words: {ref_keys} vs {got_keys}")
    onsets = np.array([w.start - float(r[1]) for w, r in zip(measured, reference)])
    ends = np.array([w.end - float(r[2]) for w, r in zip(measured, reference)])
    return onsets, ends


def signed_phone_onsets(reference: list[Phone], measured: list[Phone]) -> np.ndarray:
    """Signed onset differences (measured - reference, s) of the paired phones."""
    return np.array([measured[j].start - reference[i].start for i, j in pair_phones(reference, measured)])


def error_summary(errors) -> dict[str, float]:
    """Median and 90th percentile of |error| in ms, shares within 20 and 50 ms in percent."""
    ms = np.abs(np.asarray(errors, dtype=float)) * 1000.0
    if ms.size == 0:
        return {"n": 0, "p50_ms": float("nan"), "p90_ms": float("nan"),
                "within20_pct": float("nan"), "within50_pct": float("nan")}
    return {"n": int(ms.size), "p50_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)),
            "within20_pct": float(100 * np.mean(ms <= 20)), "within50_pct": float(100 * np.mean(ms <= 50))}


def read_labels(path: str | os.PathLike) -> tuple[str, list, list]:
    """A label TSV (as scripts/speech_fixtures.py writes them: ``# comment`` lines,
    ``text<TAB>...``, ``phone|word<TAB>label<TAB>start<TAB>end``): the text, phone rows ``(phone, start, end)`` and word rows
    ``(word, start, end)``."""
    text, phones, words = "", [], []
    with open(path, encoding="utf-8") as handle:
        for line in handle:
            parts = line.rstrip("\n").split("\t")
            if parts[0] == "text":
                text = parts[1]
            elif parts[0] in ("phone", "word"):
                (phones if parts[0] == "phone" else words).append((parts[1], float(parts[2]), float(parts[3])))
    return text, phones, words

