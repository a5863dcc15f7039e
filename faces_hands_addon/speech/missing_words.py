# SPDX-License-Identifier: GPL-3.0-or-later
"""Where does a transcript lack a word? A calibrated score per word boundary of a forced alignment.

Lip sync from a recording (3.1.3) times the transcript's phones; a word the speaker says but the
transcript leaves out leaves its sound to the neighbours, and the mouth is wrong there. Such a word
leaves three kinds of trace at the boundary where it belongs:

* **time** -- the forced alignment stretches the two words around it, or puts a loud "silence" between
  them: they last longer than espeak-ng says they take at this speaker's rate (``excess`` seconds, and
  each word's stretch; the rate is the median over the words of aligned / espeak-ng duration);
* **phones** -- free phone recognition (pocketsphinx's phone loop at the phone-LM weight of the
  no-transcript mode) finds phones there the transcript's pronunciation lacks: insertions of a weighted
  edit alignment of the recognised phones against the transcript's aligned phones (:func:`insertions`),
  at the boundary and at the boundaries next to it;
* **fit** -- the words and the phones on either side fit worse than the utterance's median (per-frame
  score against free phone recognition over the same frames, as ``transcript_check.measure``) and the
  boundary phones last longer than the median phone.

A quiet pause between the two words (``PAUSE_FRAMES`` or more) is a phrase break, before which speakers
lengthen the last word; the pause and that stretch are features of their own, so a phrase break is not
taken for a missing word.

:func:`boundary_features` gives these per boundary; a logistic score (weights, feature scaling and the
threshold in ``presets/speech/transcript_check.json``) names a boundary when it reaches the threshold.
``bench/transcript_check.py --calibrate`` fits the weights on the CALIBRATION recordings (every middle word
left out in turn) and sets the threshold at a share of correct transcripts' boundaries it may name.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format
from .transcript_check import span_score

__all__ = ["PhoneSeg", "FEATURES", "insertions", "boundary_features", "MissingWordModel", "load_model"]

FRAME = 0.01
FORMAT = register_format(PresetFormat(
    "faces_hands.transcript_check", 1, required=("missing_word",),
    shape={"missing_word": {"features": [str], "mean": [NUMBER], "scale": [NUMBER], "weights": [NUMBER],
                            "bias": NUMBER, "threshold": NUMBER}}))
#: feature names, in the order of the model's weights
FEATURES = ("excess_s", "excess_pos_s", "stretch_left", "stretch_right", "log_stretch_left", "log_stretch_right",
            "loud_gap_frames", "conf_left", "conf_right", "conf_left_low", "conf_right_low", "inserted",
            "inserted_near", "phone_conf_left", "phone_conf_right", "phone_dur_left", "phone_dur_right",
            "pause_frames", "log_stretch_left_at_pause")
#: a quiet stretch this long between two words is a phrase break (the word before it is lengthened)
PAUSE_FRAMES = 10

_VOWELS = frozenset("AA AE AH AO AW AY EH ER EY IH IY OW OY UH UW".split())
_CLASSES = (_VOWELS, frozenset("P B T D K G".split()), frozenset("F V TH DH S Z SH ZH HH".split()),
            frozenset("M N NG".split()))


@dataclass(frozen=True)
class PhoneSeg:
    """One phone of the phone-level forced alignment: its word (token), ARPAbet name, first frame, frames,
    acoustic score."""
    token: int
    phone: str
    start: int
    frames: int
    score: float


def _phone_class(phone: str) -> int:
    return next((k for k, members in enumerate(_CLASSES) if phone in members), len(_CLASSES))


def _substitution(a: str, b: str) -> float:
    return 0.0 if a == b else (0.6 if _phone_class(a) == _phone_class(b) else 1.0)


def _substitutions(rows: list[str], columns: list[str]) -> np.ndarray:
    """The (rows, columns) matrix of :func:`_substitution`, from each distinct phone's class."""
    classes = {phone: _phone_class(phone) for phone in {*rows, *columns}}
    row_class = np.array([classes[p] for p in rows])
    column_class = np.array([classes[p] for p in columns])
    same = np.array(rows)[:, None] == np.array(columns)[None, :]
    return np.where(same, 0.0, np.where(row_class[:, None] == column_class[None, :], 0.6, 1.0))


def insertions(recognised: list[str], transcript: list[tuple[str, int]], words: int) -> np.ndarray:
    """Per boundary (after word ``j``, ``j`` in ``0..words-2``): recognised phones the transcript lacks
    there. A weighted edit alignment (substitution 0 for the same phone, 0.6 within a class -- vowels,
    stops, fricatives, nasals -- 1 otherwise; insertion and deletion 1) of ``recognised`` against the
    transcript's phones (``(phone, word)``); an inserted phone belongs to the boundary after the word of
    the transcript phone before it. Rows are computed with a running minimum, so the cost is O(n m) in
    numpy with one small loop per recognised phone."""
    n, m = len(recognised), len(transcript)
    out = np.zeros(max(words - 1, 0))
    if n == 0 or m == 0:
        return out
    cost = _substitutions(recognised, [t for t, _ in transcript])
    moves = np.zeros((n + 1, m + 1), np.int8)        # 0 diagonal, 1 insertion (recognised only), 2 deletion
    moves[1:, 0], moves[0, 1:] = 1, 2
    row = np.arange(m + 1, dtype=np.float64)
    steps = np.arange(m + 1, dtype=np.float64)
    for i in range(1, n + 1):
        diagonal = row[:-1] + cost[i - 1]
        up = row[1:] + 1.0
        best = np.concatenate([[row[0] + 1.0], np.minimum(diagonal, up)])
        choice = np.concatenate([[1], np.where(diagonal <= up, 0, 1)])
        running = np.minimum.accumulate(best - steps) + steps           # deletions along the row
        moves[i] = np.where(running < best, 2, choice)
        row = np.minimum(best, running)
    i, j = n, m
    while i > 0 or j > 0:
        move = moves[i, j]
        if move == 0:
            i, j = i - 1, j - 1
        elif move == 1:
            word = transcript[j - 1][1] if j > 0 else -1
            if 0 <= word < len(out):
                out[word] += 1
            i -= 1
        else:
            j -= 1
    return out


def boundary_features(words, phones: list[PhoneSeg], free, recognised: list[str], expected, loud) -> np.ndarray:
    """(boundaries, len(FEATURES)): the features of each boundary between consecutive ``words``
    (``transcript_check.WordFit``: frames and confidence on the forced path), from the phone-level
    alignment ``phones``, the free phone path ``free`` (``(phone, start, end, score)``, the confidence
    reference), the ``recognised`` phone names (free phone recognition, silences left out), espeak-ng's
    ``expected`` duration per token (seconds or None) and the per-frame speech flags ``loud``."""
    if len(words) < 3 or not phones:
        return np.zeros((0, len(FEATURES)))
    observed = np.array([(w.end - w.start + 1) * FRAME for w in words])
    wanted = np.array([expected[w.token] if w.token < len(expected) and expected[w.token] else np.nan
                       for w in words], np.float64)
    ratios = observed / wanted
    rate = float(np.nanmedian(ratios)) if np.isfinite(ratios).any() else 1.0
    need = np.where(np.isfinite(wanted), wanted * rate, observed)
    confidence = np.array([w.confidence for w in words])
    confidence = confidence - np.median(confidence)
    per_phone = np.array([(p.score - span_score(free, p.start, p.start + p.frames - 1)) / max(p.frames, 1)
                          for p in phones])
    per_phone -= np.median(per_phone)
    durations = np.array([p.frames for p in phones], np.float64)
    durations /= max(float(np.median(durations)), 1.0)
    index = {w.token: k for k, w in enumerate(words)}
    first_phone, last_phone = {}, {}
    for i, p in enumerate(phones):
        if p.token in index:
            first_phone.setdefault(index[p.token], i)
            last_phone[index[p.token]] = i
    inserted = insertions(recognised, [(p.phone, index[p.token]) for p in phones if p.token in index], len(words))
    rows = []
    for j in range(len(words) - 1):
        left, right = words[j], words[j + 1]
        gap = int(np.sum(loud[left.end + 1:right.start])) if right.start > left.end + 1 else 0
        pause = max(right.start - left.end - 1, 0) - gap
        excess = observed[j] + observed[j + 1] + gap * FRAME - need[j] - need[j + 1]
        stretch = observed[j] / need[j], observed[j + 1] / need[j + 1]
        a, b = last_phone.get(j), first_phone.get(j + 1)
        near = inserted[max(j - 1, 0):j + 2].sum()
        rows.append([excess, max(excess, 0.0), *stretch, *np.log(np.maximum(stretch, 0.1)), min(gap, 20),
                     confidence[j], confidence[j + 1], min(confidence[j], 0.0), min(confidence[j + 1], 0.0),
                     inserted[j], near,
                     per_phone[a] if a is not None else 0.0, per_phone[b] if b is not None else 0.0,
                     durations[a] if a is not None else 1.0, durations[b] if b is not None else 1.0,
                     min(pause, 50), np.log(max(stretch[0], 0.1)) if pause >= PAUSE_FRAMES else 0.0])
    return np.asarray(rows, np.float64)


@dataclass(frozen=True)
class MissingWordModel:
    """The calibrated logistic score: ``(features - mean) / scale @ weights + bias``, naming a boundary at
    ``threshold`` or above."""
    mean: np.ndarray
    scale: np.ndarray
    weights: np.ndarray
    bias: float
    threshold: float

    def scores(self, features: np.ndarray) -> np.ndarray:
        if not len(features):
            return np.zeros(0)
        return (features - self.mean) / self.scale @ self.weights + self.bias

    def named(self, features: np.ndarray) -> np.ndarray:
        """Indices of the boundaries whose score reaches the threshold."""
        return np.flatnonzero(self.scores(features) >= self.threshold)


def load_model() -> MissingWordModel:
    """The model of ``presets/speech/transcript_check.json`` (the user's copy first)."""
    doc, source = read_preset("speech/transcript_check.json", FORMAT.name)
    block = doc["missing_word"]
    if list(block.get("features", [])) != list(FEATURES):
        raise UserError(f"{source}: the missing-word model's features must be {', '.join(FEATURES)}")
    arrays = [np.asarray(block[k], np.float64) for k in ("mean", "scale", "weights")]
    if any(a.shape != (len(FEATURES),) or not np.all(np.isfinite(a)) for a in arrays) or np.any(arrays[1] <= 0):
        raise UserError(f"{source}: mean, scale and weights need {len(FEATURES)} finite numbers each "
                         "(scale positive)")
    return MissingWordModel(*arrays, float(block["bias"]), float(block["threshold"]))


def missing_word_warnings(words, texts: list[str], features: np.ndarray, model: MissingWordModel,
                          named: set[int] = frozenset()) -> list[str]:
    """One warning naming the boundaries the model names (``features`` from :func:`boundary_features`),
    except those next to a token already ``named`` as not spoken (a transcript word the recording lacks
    disturbs the boundaries on both sides of it)."""
    places = [f"between '{texts[words[j].token]}' and '{texts[words[j + 1].token]}' "
              f"({(words[j].end + 1) * FRAME:.2f} s)" for j in model.named(features)
              if words[j].token not in named and words[j + 1].token not in named]
    if not places:
        return []
    return ["a word seems to be missing from the transcript (spoken, but not written) " + "; ".join(places)]
