# SPDX-License-Identifier: GPL-3.0-or-later
"""Does a transcript match its recording? Per-word confidence of a forced alignment (3.1.3).

Lip sync from a recording (3.1.3: "phonemes ... and their durations") is only as good as the
transcript it is aligned to. Three checks, all on pocketsphinx's own scores over the same 10 ms frames:

* **speech or not** -- a recording of silence, hiss, hum or steady noise has a flat level: the frame
  levels' spread (95th minus 10th percentile) stays below ``NONSPEECH_SPREAD_DB``; speech, even at
  10 dB SNR, rises and falls with its syllables and pauses (:func:`refuse_non_speech`);
* **word confidence** -- the acoustic score of each word on the forced path is compared with the score
  of free phone recognition (pocketsphinx ``allphone``: any phone may follow any phone) over the
  *same frames*; both decoders compute all senones (``compallsen``) so their per-frame normalisation
  is the same. The confidence is ``(forced - free) / frames`` in pocketsphinx log-score units per
  frame (0: the words explain the sound as well as free phones do; strongly negative: they do not).
  Because noise lowers every word alike, a word is named as not matching when its confidence is
  below ``WORD_LIMIT`` *and* ``WORD_MARGIN`` below the utterance's median word;
* **whole transcript** -- refused when the words' frame-weighted mean confidence is below
  ``UTTERANCE_LIMIT``, when more than ``MAX_BAD_SHARE`` of the words do not match, or when the
  transcript leaves more than ``UNCOVERED_LIMIT`` of the speech frames to silences and fillers.

Words the transcript has but the recording lacks are named by a **soft transcript**
(:func:`soft_path`): a third decode in which pocketsphinx follows a finite-state grammar of the transcript
where every word may be left out (a null arc) and, between any two words, speech the transcript lacks may
be taken by the context-free speech filler ``[SPEECH]`` (``GARBAGE_P``). Its path says which words the
recording lacks (left out: "not in the recording", named only when the forced path also shows them
:func:`unspoken` -- squeezed to a few frames per phone or scoring ``UNSPOKEN_MARGIN`` below the median
word) and whether there is speech before the first or after the last word. Words the recording has but
the transcript lacks, between two of its words, are named by ``missing_words`` (a calibrated score per
word boundary from durations, free phone recognition and fit): the soft path's filler runs named the wrong
place or nothing for 51 % of such words of 3+ phones (every middle word of the CALIBRATION sentences left
out in turn, clean and 10 dB). Long recordings are decoded in pieces of ``SOFT_CHUNK_FRAMES`` cut at
word ends; only its path is read, not its scores, so it computes only the senones its search reaches (not
``compallsen``: same paths and warnings on the held-out set; 1.6 -> 0.6 s CPU for 36 s of speech). A loop of
the 39 phones
instead of ``[SPEECH]`` named the words as well on Festival speech but was 10-20 times slower and lost
the path on espeak-ng voices; the null arcs' probability is not scaled by the language weight, so
``SKIP_P`` barely matters (1e-3 and 1e-6 gave the same paths on the calibration subset). Tried and
dropped: 14 short function words ("the", "a", "at", ...) as optional grammar words between transcript
words, to name left-out 1-2 phone words the filler is too coarse for; on the CALIBRATION recordings
(clean and 10 dB) they named 21-31 of 48 left-out function words instead of 16, but drew word warnings
on 13-18 of 48 correct transcripts instead of 6. 16 function words as optional self-loops with their
acoustic gain over the forced path as the score did no better: the gain of a true left-out word did not
stand out from the gains of words inserted into correct transcripts (at gains the correct transcripts
reached in 42 % of recordings, 32 % of the left-out words were found).

Calibration (``bench/transcript_check.py --calibrate``): 12 CALIBRATION sentences, each spoken by
Festival's CMU ARCTIC SLT HTS voice and by one espeak-ng voice (24 recordings), clean and with seeded
white noise at 20 and 10 dB SNR; each with its own transcript, another sentence's transcript, one
word left out and one word added; plus 20 silence / noise recordings. On that set the fit score of
correct transcripts was >= -60.1 (median -24.8, 72 recordings), of wrong ones with an alignment path
<= -65.4 (median -121.5; 7 more had no path at all): ``FIT_LIMIT`` = -63 lies between. ``WORD_LIMIT``,
``WORD_MARGIN`` and ``NAME_MIN_FRAMES`` trade named added words against false alarms on correct
transcripts (short function words); ``LONG_WORD_RATIO`` (used only when the soft path fails) raised the
named left-out words from 23 to 28 of 48 without more false alarms (11 of 72). With these values the
calibration set gave: correct 72/72 accepted, wrong 48/48 and silence/noise 20/20 refused, left-out words
named 28/48, added words 36/48. ``RECOGNITION_LW`` was read from the same recordings.
Soft transcript (``UNSPOKEN_*``, ``MISSING_MIN_LOUD``): read off the raw paths of 8 of the
CALIBRATION sentences (16 recordings, clean and 10 dB): added words left out of the path 32/32, but
also 17 of 48 correct transcripts with a word named; the unspoken test and the loud-frame minimum
removed most of those (squeezed below 4.4 frames per phone or 45 below the median separated the
real added words from left-out spoken words of 3+ phones), the duration rule raised left-out words
found from 17 to 26 of 30 at 2 more false alarms of 48 (both before the unspoken test).
Held-out (14 other sentences, 28 recordings, same conditions; ``bench/transcript_check.py``): wrong
transcripts refused 56/56, silence and noise 20/20, correct transcripts accepted 27/28 clean, 28/28 at
20 dB and 27/28 at 10 dB SNR; an added word named in 43/56 (20/28 clean, 23/28 at 10 dB); a left-out
word named by its place in 29/56 (16/28 clean, 13/28 at 10 dB: 19/24 of 3+ phones, 10/32 of 1-2 phone
function words) with the calibrated ``missing_words`` model, 21/56 with the soft path's filler runs and
the duration rule it replaces (7/32 and 14/24); 7 of 82 accepted correct transcripts drew a word warning
(a false alarm), as before. Before :func:`judge_with_soft` (same run otherwise) added words were named in
36/56: a transcript with one added word was often refused as a whole.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError
from .phone_loop import segments

FRAME = 0.01  # pocketsphinx frame length (s)
HOP = 160     # samples per frame at 16 kHz

#: frame-level spread (dB, 95th - 10th percentile) below which a recording is not speech. On the
#: calibration recordings: speech clean >= 35.1, at 10 dB SNR >= 16.9 (median 18.3); hiss, white noise
#: and hum <= 1.4; brown noise 13.2-13.9 passes here and is refused by the transcript or recognition
#: checks. 12 leaves room for speech below 10 dB SNR.
NONSPEECH_SPREAD_DB = 12.0
#: a word's confidence below this (and WORD_MARGIN below the utterance's median word) does not match
WORD_LIMIT = -60.0
WORD_MARGIN = 10.0
#: words shorter than this (frames) are never named: a short function word's score is too noisy
NAME_MIN_FRAMES = 15
#: a word this many times longer per phone than the utterance's median word (and at least
#: LONG_MIN_FRAMES long) has absorbed speech the transcript lacks
LONG_WORD_RATIO = 2.0
LONG_MIN_FRAMES = 20
#: the transcript is refused when FIT_SCORE = mean confidence - UNCOVERED_WEIGHT * uncovered share
#: - BAD_WEIGHT * share of words below WORD_LIMIT falls below FIT_LIMIT
FIT_LIMIT = -63.0
UNCOVERED_WEIGHT = 150.0
BAD_WEIGHT = 50.0
#: ... or when more than this share of its words do not match
MAX_BAD_SHARE = 0.5
#: share of loud frames the transcript may leave to optional silences and fillers
UNCOVERED_LIMIT = 0.3
#: loud frames in a row given to a silence or filler between two words: speech not in the transcript
GAP_FRAMES = 15
#: a frame this far over the noise floor counts as speech for coverage and gaps
LOUD_OVER_FLOOR_DB = 6.0
#: no-transcript mode: the longest phone recognition may report, the share of speech it must cover
MAX_PHONE = 0.6
MIN_RECOGNISED = 0.6
#: no-transcript mode: the phone language model's weight. pocketsphinx's default lets silence win over
#: whole sentences of espeak-ng speech (6 phones of 34); at 1.0 recognition finds 0.68-1.03 of the
#: reference phones and covers >= 71 % of the speech on the calibration recordings
RECOGNITION_LW = 1.0


@dataclass
class WordFit:
    """One transcript word on the forced path: frames ``start..end`` (inclusive), its confidence."""
    token: int
    text: str
    start: int
    end: int
    confidence: float
    phones: int = 1


@dataclass
class TranscriptFit:
    """What :func:`measure` found; :func:`judge` turns it into warnings or a refusal."""
    words: list[WordFit]
    gaps: list[tuple[int, int, int]] = field(default_factory=list)  # (after token, start, end frame)
    uncovered_share: float = 0.0
    spread_db: float = 0.0
    texts: list[str] = field(default_factory=list)

    @property
    def mean_confidence(self) -> float:
        frames = np.array([w.end - w.start + 1 for w in self.words], dtype=float)
        scores = np.array([w.confidence for w in self.words], dtype=float)
        return float((frames * scores).sum() / max(frames.sum(), 1.0)) if len(self.words) else 0.0


def frame_levels(pcm: bytes) -> np.ndarray:
    """Per 10 ms frame of 16 kHz int16 audio: its level in dB."""
    x = np.frombuffer(pcm, dtype=np.int16).astype(np.float64)
    n = len(x) // HOP
    energy = (x[:n * HOP].reshape(n, HOP) ** 2).mean(axis=1) + 1e-3
    return 10 * np.log10(energy)


def loud_frames(pcm: bytes, frames: int) -> np.ndarray:
    """Per frame: is it speech rather than a pause? Within 25 dB of the loudest frames and at least
    ``LOUD_OVER_FLOOR_DB`` over the noise floor (the 10th percentile)."""
    level = frame_levels(pcm)[:frames]
    if len(level):
        floor, top = np.percentile(level, 10), np.percentile(level, 95)
        loud = level > max(top - 25.0, floor + LOUD_OVER_FLOOR_DB)
    else:
        loud = np.zeros(0, dtype=bool)
    return np.concatenate([loud, np.zeros(max(frames - len(loud), 0), dtype=bool)])


def level_spread(pcm: bytes) -> float:
    """95th minus 10th percentile of the frame levels (dB): small for silence and steady noise."""
    level = frame_levels(pcm)
    return float(np.percentile(level, 95) - np.percentile(level, 10)) if len(level) else 0.0


def refuse_non_speech(pcm: bytes) -> float:
    """Raise :class:`UserError` when the level never rises and falls like speech; returns the spread."""
    spread = level_spread(pcm)
    if spread < NONSPEECH_SPREAD_DB:
        raise UserError(f"no speech found in the recording (its level varies by only {spread:.1f} dB, like "
                        "silence or steady noise); give a recording of speech")
    return spread


def span_score(free: list[tuple[str, int, int, float]], start: int, end: int) -> float:
    """The free path's score over frames ``start..end``, each segment counted by its overlap."""
    total = 0.0
    for _, a, b, score in free:
        overlap = min(b, end) - max(a, start) + 1
        if overlap > 0:
            total += score * overlap / (b - a + 1)
    return total


def is_filler(name: str) -> bool:
    """Silences, sentence marks and noise fillers of a pocketsphinx path (not transcript words)."""
    return name.split("(")[0].startswith(("<", "[", "+")) or name.upper() in ("SIL",)


def measure(forced_decoder, free_segments, pcm: bytes, texts: list[str], forced=None) -> TranscriptFit:
    """Per transcript word (``texts`` in order) its frames and confidence on the forced path (``forced``:
    the decoder's word path, :func:`segments`, when it was read before the decoder ran another pass)."""
    forced = segments(forced_decoder) if forced is None else forced
    frames = max(forced_decoder.n_frames(), 1)
    loud = loud_frames(pcm, frames)
    uncovered = np.zeros(frames, dtype=bool)
    words: list[WordFit] = []
    gaps: list[tuple[int, int, int]] = []
    for name, a, b, score in forced:
        a, b = max(a, 0), max(b, a)
        if is_filler(name):
            uncovered[a:b + 1] = True
            after = len(words) - 1
            if loud[a:b + 1].sum() >= GAP_FRAMES:
                gaps.append((after, a, b))
            continue
        token = len(words)
        if token >= len(texts):
            break
        confidence = (score - span_score(free_segments, a, b)) / (b - a + 1)
        pronunciation = forced_decoder.lookup_word(name)
        phones = len(pronunciation.split()) if pronunciation else 1
        words.append(WordFit(token, texts[token], a, b, confidence, phones))
    share = float((loud & uncovered).sum() / max(loud.sum(), 1))
    return TranscriptFit(words, gaps, share, level_spread(pcm), list(texts))


#: soft transcript: speech the transcript lacks is taken by pocketsphinx's context-free "speech"
#: filler (+SPN+); a loop of the 39 phones as words was tried: its cross-word contexts made the search
#: 10-20 times slower and it lost the path on espeak-ng voices
GARBAGE_WORDS = ("[SPEECH]",)
#: probability of leaving a transcript word out of the path, of entering the speech filler between
#: two words, and of staying in it (per filler segment)
SKIP_P = 1e-3
GARBAGE_P = 1e-3
GARBAGE_STAY_P = 0.5
#: loud frames a filler, silence or speech filler must take between two words to name a missing word
MISSING_MIN_LOUD = 12
#: a left-out word is named only when the forced path also shows it unspoken (see :func:`unspoken`)
UNSPOKEN_MIN_PHONES = 3
UNSPOKEN_FRAMES_PER_PHONE = 4.4
UNSPOKEN_MARGIN = 45.0
#: a refused transcript is judged again without at most this many unspoken left-out words
MAX_UNSPOKEN_KEPT = 2
#: the soft pass decodes the recording in pieces of about this many frames, cut at word ends
SOFT_CHUNK_FRAMES = 1500
#: at most this many active HMMs per frame in the soft pass: its garbage loops under the wide beams a
#: hard recording needs took 80 s per 15-s piece (the forced pass keeps its own beams)
SOFT_MAX_HMM_PER_FRAME = 3000
#: the soft pass's beams when the default ones do not reach a piece's end (never wider: the forced pass's
#: 1e-300 beams took 116 s on one 15-s piece; without a soft path fewer words are named, nothing else)
SOFT_RETRY_BEAMS = {"beam": 1e-80, "wbeam": 1e-60, "pbeam": 1e-80}


@dataclass
class SoftPath:
    """The soft transcript's path: transcript tokens it left out, phone-loop runs between words."""
    skipped: list[int] = field(default_factory=list)
    #: (token before, token after, start frame, end frame, loud frames); -1 / len(texts) at the ends
    inserted: list[tuple[int, int, int, int, int]] = field(default_factory=list)


def _soft_decoder(ps, keys: list[str], extra_words, beams: dict):
    """A finite-state grammar over the transcript in which each word may be left out (``SKIP_P``) and
    speech may come between two words (``GARBAGE_P``, then ``GARBAGE_STAY_P`` per segment)."""
    decoder = ps.Decoder(lm=None, loglevel="FATAL", compallsen=False, **beams)
    for word, phones in extra_words:
        decoder.add_word(word, phones, False)
    loop = list(GARBAGE_WORDS)
    n = len(keys)
    transitions = []
    for i, key in enumerate(keys):
        transitions += [(i, i + 1, 1.0 - SKIP_P, key), (i, i + 1, SKIP_P)]
    for i in range(n + 1):
        garbage = n + 1 + i
        for word in loop:
            transitions += [(i, garbage, GARBAGE_P / len(loop), word),
                            (garbage, garbage, GARBAGE_STAY_P / len(loop), word)]
        transitions.append((garbage, i, 1.0 - GARBAGE_STAY_P))
    decoder.add_fsg("soft", decoder.create_fsg("soft", 0, n, transitions))
    decoder.activate_search("soft")
    return decoder


def _soft_piece(ps, pcm: bytes, keys, extra_words, beams) -> list[tuple[str, int, int]] | None:
    """The soft path over one piece, or None when it does not reach the grammar's end (``</s>``)."""
    decoder = _soft_decoder(ps, keys, extra_words, beams)
    decoder.start_utt()
    decoder.process_raw(pcm, full_utt=True)
    decoder.end_utt()
    if decoder.hyp() is None:
        return None
    segs = [(seg.word, seg.start_frame, seg.end_frame) for seg in decoder.seg()]
    return segs if segs and segs[-1][0] == "</s>" else None


def soft_path(ps, pcm: bytes, keys: list[str], extra_words, words: list[WordFit],
              beams: dict | None = None) -> SoftPath | None:
    """Decode the recording against the soft transcript (pieces of about ``SOFT_CHUNK_FRAMES``, cut
    at the forced path's word ends; each with the default beams, then, when the forced pass needed wider
    ``beams``, with ``SOFT_RETRY_BEAMS``; both bounded by ``SOFT_MAX_HMM_PER_FRAME``) and read off
    left-out words and phone-loop runs."""
    frames = len(pcm) // (2 * HOP)
    loud = loud_frames(pcm, frames)
    cuts = [(0, 0)]  # (frame, first token) of each piece
    for w in words[:-1]:
        if w.end + 1 - cuts[-1][0] >= SOFT_CHUNK_FRAMES:
            cuts.append((w.end + 1, w.token + 1))
    cuts.append((frames, len(keys)))
    path = SoftPath()
    for (a, first), (b, last) in zip(cuts, cuts[1:]):
        if last <= first:
            continue
        piece = pcm[a * 2 * HOP:b * 2 * HOP]
        bound = {"maxhmmpf": SOFT_MAX_HMM_PER_FRAME}
        segs = _soft_piece(ps, piece, keys[first:last], extra_words, bound)      # default beams first
        if segs is None and beams:     # the forced pass needed wider beams: a bounded wider retry
            segs = _soft_piece(ps, piece, keys[first:last], extra_words, {**SOFT_RETRY_BEAMS, **bound})
        if segs is None:
            return None
        _read_piece(path, [(w, s + a, e + a) for w, s, e in segs], keys, first, last, loud)
    return path


def _read_piece(path: SoftPath, segs, keys, first: int, last: int, loud) -> None:
    token = first
    run: list[tuple[int, int]] = []

    def close_run(next_token):
        if run:
            a, b = run[0][0], run[-1][1]
            path.inserted.append((token - 1, next_token, a, b, int(loud[a:b + 1].sum())))
            run.clear()

    for name, a, b in segs:
        if is_filler(name):
            if name not in ("<s>", "</s>"):
                run.append((a, b))
            continue
        base = name.split("(")[0]
        match = next((j for j in range(token, last) if keys[j] == base), None)
        if match is None:
            continue
        path.skipped += range(token, match)
        close_run(match)
        token = match + 1
    path.skipped += range(token, last)
    close_run(last)


def unspoken(word: WordFit, median: float) -> bool:
    """Does the forced path look like it forced a word that was not said? Squeezed towards the
    shortest path (fewer than ``UNSPOKEN_FRAMES_PER_PHONE``) or scoring far below the utterance's
    median word (``UNSPOKEN_MARGIN``); never a word of fewer than ``UNSPOKEN_MIN_PHONES`` phones."""
    frames = word.end - word.start + 1
    return word.phones >= UNSPOKEN_MIN_PHONES and (frames / word.phones < UNSPOKEN_FRAMES_PER_PHONE
                                                   or word.confidence <= median - UNSPOKEN_MARGIN)


def soft_findings(path: SoftPath, count: int, words: list[WordFit] | None = None,
                  interior_gaps: bool = True) -> tuple[set[int], set[int], list[tuple[int, int, int, int]]]:
    """What the soft path says: the tokens it left out (those the forced path also finds :func:`unspoken`,
    when ``words`` are given), the left-out tokens with other speech in their place that score far below
    the rest, and the places (token before, token after, frames) where it needed speech the transcript
    lacks (at least ``MISSING_MIN_LOUD`` loud frames; between two of the ``count`` tokens only with
    ``interior_gaps``)."""
    left_out = set(path.skipped)
    skipped = set(left_out)
    scored = {w.token: w for w in words or []}
    median = float(np.median([w.confidence for w in words])) if words else 0.0
    if words:
        skipped = {t for t in left_out if t in scored and unspoken(scored[t], median)}
    covered: set[int] = set()  # left-out words with speech in their place
    gaps = []
    for before, after, a, b, loud in path.inserted:
        if loud < MISSING_MIN_LOUD:  # a pause, or noise in one
            continue
        inside = set(range(before + 1, after)) & left_out
        covered |= inside
        if not inside and (interior_gaps or before < 0 or after >= count):
            gaps.append((before, after, a, b))
    # speech in place of transcript words: named only when they score far below the rest
    replaced = {t for t in covered
                if not words or (t in scored and scored[t].confidence <= median - UNSPOKEN_MARGIN)}
    return (skipped - covered) - replaced, replaced, gaps


def soft_warnings(path: SoftPath, texts: list[str], words: list[WordFit] | None = None,
                  interior_gaps: bool = True) -> list[str]:
    """Warnings naming what :func:`soft_findings` found: words not in the recording, words that do not
    match, speech the transcript lacks."""
    added, replaced, gaps = soft_findings(path, len(texts), words, interior_gaps)
    warnings = []
    if added:
        warnings.append("these words are not in the recording (added to the transcript?): "
                        + _quoted(texts[t] for t in sorted(added)))
    if replaced:
        warnings.append("these words do not match the audio (other words spoken there?): "
                        + _quoted(texts[t] for t in sorted(replaced)))
    for before, after, a, b in gaps:
        if before < 0:
            where = f"before '{texts[0]}'"
        elif after >= len(texts):
            where = f"after '{texts[before]}'"
        else:
            where = f"between '{texts[before]}' and '{texts[after]}'"
        warnings.append(f"speech not in the transcript {where} ({a * FRAME:.2f}-{(b + 1) * FRAME:.2f} s): "
                        "a missing word?")
    return warnings


def named_tokens(fit: TranscriptFit, soft: SoftPath | None) -> set[int]:
    """The transcript tokens :func:`named_warnings` names as not in the recording or not matching."""
    if soft is None:
        return set()
    added, replaced, _ = soft_findings(soft, len(fit.texts), fit.words, interior_gaps=False)
    return added | replaced


def judge_with_soft(fit: TranscriptFit, soft: SoftPath | None) -> None:
    """:func:`judge`, except that a transcript refused only because of at most ``MAX_UNSPOKEN_KEPT``
    words the soft path left out (and the forced path finds :func:`unspoken`) is judged without them:
    one added word should be named, not make the whole transcript fail."""
    try:
        judge(fit)
    except UserError:
        if soft is None or not fit.words:
            raise
        median = float(np.median([w.confidence for w in fit.words]))
        left = {w.token for w in fit.words if w.token in set(soft.skipped) and unspoken(w, median)}
        if not left or len(left) > MAX_UNSPOKEN_KEPT or len(fit.words) - len(left) < 3:
            raise
        judge(TranscriptFit([w for w in fit.words if w.token not in left], fit.gaps, fit.uncovered_share,
                            fit.spread_db, fit.texts))


def named_warnings(fit: TranscriptFit, soft: SoftPath | None) -> list[str]:
    """The warnings that name transcript words the recording lacks (and speech before the first or after
    the last word), from the soft transcript; when its path failed, those of :func:`judge`. Words the
    transcript lacks between two of its words are named by ``missing_words``."""
    return soft_warnings(soft, fit.texts, fit.words, interior_gaps=False) if soft is not None else judge(fit)


def check_recognised(free, pcm: bytes) -> None:
    """Free phone recognition must cover the speech with phones, never hold one phone for long."""
    frames = max((b for _, _, b, _ in free), default=-1) + 1
    loud = loud_frames(pcm, frames)
    covered = np.zeros(frames, dtype=bool)
    for name, a, b, _ in free:
        if not is_filler(name):
            covered[max(a, 0):b + 1] = True
            if (b - a + 1) * FRAME > MAX_PHONE:
                raise UserError(f"phone recognition failed: one phone ({name}) would last "
                                f"{(b - a + 1) * FRAME:.2f} s at {a * FRAME:.2f} s; give the transcript")
    share = (loud & covered).sum() / max(loud.sum(), 1)
    if share < MIN_RECOGNISED:
        raise UserError(f"phone recognition found phones in only {share:.0%} of the speech; give the "
                        "transcript, or a clearer recording")


def _quoted(words) -> str:
    return ", ".join(f"'{w}'" for w in words)


def fit_score(fit: TranscriptFit) -> float:
    """One number for the whole transcript (higher: better), compared with ``FIT_LIMIT``."""
    low = float(np.mean([w.confidence < WORD_LIMIT for w in fit.words])) if fit.words else 1.0
    return fit.mean_confidence - UNCOVERED_WEIGHT * fit.uncovered_share - BAD_WEIGHT * low


def judge(fit: TranscriptFit) -> list[str]:
    """Warnings that name the words that do not match; :class:`UserError` for a wrong transcript."""
    advice = "check the words, or leave the transcript empty for phone recognition"
    if fit.uncovered_share > UNCOVERED_LIMIT:
        raise UserError(f"the transcript does not match the audio ({fit.uncovered_share:.0%} of the speech "
                        f"is not covered by its words); {advice}")
    if not fit.words:
        raise UserError(f"the transcript does not match the audio (no word was aligned); {advice}")
    scores = np.array([w.confidence for w in fit.words])
    median = float(np.median(scores))
    low = float(np.mean(scores < WORD_LIMIT))
    score = fit_score(fit)
    bad = [w for w in fit.words if w.confidence < WORD_LIMIT and w.confidence < median - WORD_MARGIN
           and w.end - w.start + 1 >= NAME_MIN_FRAMES]
    if score < FIT_LIMIT or low > MAX_BAD_SHARE:
        raise UserError(f"the transcript does not match the audio (fit {score:.0f} against free phone "
                        f"recognition, limit {FIT_LIMIT:.0f}; {low:.0%} of the words fit badly); {advice}")
    per_phone = np.array([(w.end - w.start + 1) / max(w.phones, 1) for w in fit.words])
    long = [w for w, q in zip(fit.words, per_phone) if q > LONG_WORD_RATIO * np.median(per_phone)
            and w.end - w.start + 1 >= LONG_MIN_FRAMES and w not in bad]
    warnings = []
    if long:
        warnings.append("these words last far longer than their sounds need (a word missing next to "
                        f"them?): {_quoted(w.text for w in long)}")
    if bad:
        warnings.append("these words do not match the audio (not spoken, misspelt, or a word is missing "
                        f"next to them): {_quoted(w.text for w in bad)}")
    for after, a, b in fit.gaps:
        if after < 0:
            where = f"before '{fit.texts[0]}'"
        elif after + 1 >= len(fit.texts):
            where = f"after '{fit.texts[after]}'"
        else:
            where = f"between '{fit.texts[after]}' and '{fit.texts[after + 1]}'"
        warnings.append(f"speech not in the transcript {where} ({a * FRAME:.2f}-{(b + 1) * FRAME:.2f} s): "
                        "a missing word?")
    return warnings
