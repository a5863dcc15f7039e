# SPDX-License-Identifier: GPL-3.0-or-later
"""Timing comparisons between two phone or word sequences (tests and bench/speech.py).

The oracle check: synthesise with espeak-ng (known phone times), align that audio with
pocketsphinx, and compare phone onsets. The two sides spell words differently (espeak's "can" is
/k ae n/, the CMU dictionary's may be /k ah n/), so phones are paired by a Needleman-Wunsch alignment
over the unified inventory, where a mismatch of the same viseme costs little.
"""
from __future__ import annotations

import numpy as np

from .phonemes import PHONES
from .utterance import Phone


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
