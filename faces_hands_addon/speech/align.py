# SPDX-License-Identifier: GPL-3.0-or-later
"""Recorded audio -> :class:`Utterance`: forced alignment with pocketsphinx 5 (en-us model + CMU dict).

The thesis drives lip sync from "phonemes ... and their durations" (3.1.3); for a recording they are
measured: pocketsphinx aligns the transcript word by word (first pass, which also places optional
silences), then phone by phone (second pass, ``set_alignment``), exactly as its ``pocketsphinx align
-phone_align yes`` command does (``bestpath`` off). Frames are 10 ms.

* Words missing from the CMU dictionary get espeak-ng's pronunciation (IPA -> unified phones ->
  ARPAbet) and are added to the decoder's dictionary; they are listed in ``Utterance.warnings``.
  For a non-English ``language`` every word is pronounced by espeak-ng in that language (the acoustic
  model stays English, which the warnings say).
* Lexical stress (for accented syllables) comes from espeak-ng's pronunciation of each word when its
  vowels match the aligned ones, else the longest vowel of a content word carries the accent.
* Without a transcript, phones are recognised with pocketsphinx's phone loop (``allphone``, the
  bundled en-us phone model, phone-LM weight ``transcript_check.RECOGNITION_LW``) and the result has
  no words; a warning says that this is less accurate. Recognition that leaves most of the speech to
  silence or would hold one phone for long is refused (``transcript_check.check_recognised``).
* Corrupt, zero-length, too short, silent or non-speech audio (a flat level:
  ``transcript_check.refuse_non_speech``) raise :class:`UserError`. The transcript is checked word
  by word against free phone recognition over the same frames (``transcript_check``): an unrelated
  transcript is refused; words that do not match, words the recording lacks and, per word boundary,
  words the transcript lacks (``missing_words``) are named in ``Utterance.warnings``. The two free phone
  decodes this needs run in a second process beside the forced passes (``phone_loop``).
"""
from __future__ import annotations

import os
import re

import numpy as np

from ..core.errors import UserError
from .audio import as_mono, load_audio, to_analysis_rate, to_int16
from .emoticons import extract_emoticons
from .phonemes import SILENCE, from_arpabet, is_vowel, to_arpabet
from . import missing_words, phone_loop, transcript_check
from .pitch import track_pitch
from .utterance import Phone, Utterance, WordDraft, assemble_utterance, token_spans

FRAME = 0.01  # pocketsphinx frame length (s)
MIN_DURATION = 0.1
PHRASE_PAUSE = 0.15  # a silence this long inside a sentence ends an intonational phrase
_SENTENCE_END = re.compile(r"[.?!？！…]")
_PHRASE_END = re.compile(r"[,;:—–]")
#: below this peak (-80 dBFS, under any microphone's noise floor) a recording holds no speech
SILENT_PEAK = 1e-4


def _pocketsphinx():
    try:
        import pocketsphinx  # noqa: PLC0415 - optional wheel, imported lazily
    except Exception as exc:
        raise UserError("audio alignment needs the pocketsphinx module; install the add-on with its "
                        f"bundled wheels ({exc})") from None
    return pocketsphinx


def _decode(decoder, pcm: bytes) -> None:
    decoder.start_utt()
    decoder.process_raw(pcm, full_utt=True)
    decoder.end_utt()


def _normalise(word: str) -> str:
    return word.lower().replace("’", "'").replace("‘", "'")


def _load(audio, sample_rate) -> tuple[np.ndarray, int]:
    if isinstance(audio, (str, os.PathLike)):
        return load_audio(audio)
    if sample_rate is None:
        raise UserError("give the sample rate of the audio samples")
    samples = as_mono(audio)
    if samples.size == 0:
        raise UserError("the audio has no samples (zero length)")
    if not np.all(np.isfinite(samples)):
        raise UserError("the audio contains invalid (NaN/inf) samples")
    return samples, int(sample_rate)


def align_audio(audio, transcript: str | None = None, *, sample_rate: int | None = None,
                language: str = "en-us") -> Utterance:
    """Time the phones (and, with a transcript, the words) of recorded speech.

    ``audio`` is a file path (WAV/FLAC/OGG) or a sample array with ``sample_rate``. The transcript
    may contain emoticons (Table 4.1), which become emotion tags like in :func:`synthesize`."""
    samples, rate = _load(audio, sample_rate)
    if len(samples) / rate < MIN_DURATION:
        raise UserError(f"the audio is too short ({len(samples) / rate * 1000:.0f} ms) to align; "
                        f"give at least {MIN_DURATION * 1000:.0f} ms")
    peak = float(np.max(np.abs(samples)))
    if peak < SILENT_PEAK:
        level = f"{20 * np.log10(peak):.0f} dBFS" if peak > 0 else "digital silence"
        raise UserError(f"the recording is silent (peak {level}): there is no speech to lip-sync")
    pcm = to_int16(to_analysis_rate(samples, rate)).tobytes()
    transcript_check.refuse_non_speech(pcm)
    duration = len(samples) / rate
    ps = _pocketsphinx()
    text = transcript if isinstance(transcript, str) else ""
    cleaned, tags = extract_emoticons(text)
    if not any(ch.isalnum() for ch in cleaned):
        return _recognise_phones(ps, pcm, samples, rate, duration, track_pitch(samples, rate), text, tags, language)
    # the two free phone decodes (confidence reference, recognition) need only the audio: their second
    # process starts first and runs beside everything else the alignment does, pitch tracking included
    with phone_loop.PhoneLoops(ps, pcm, [{}, {"lw": transcript_check.RECOGNITION_LW}]) as loops:
        pitch = track_pitch(samples, rate)
        return _force_align(ps, pcm, loops, samples, rate, duration, pitch, text, cleaned, tags, language)


def _recognise_phones(ps, pcm, samples, rate, duration, pitch, text, tags, language) -> Utterance:
    free = phone_loop.decode(ps, pcm, lw=transcript_check.RECOGNITION_LW)
    transcript_check.check_recognised(free, pcm)
    phones, _ = _tile([(name, a * FRAME, (b + 1) * FRAME, 0, -1) for name, a, b, _ in free], duration)
    warnings = ["no transcript: phones were recognised without words, which is less accurate; "
                "give the transcript for better lip sync"]
    return assemble_utterance(text=text, language=language, samples=samples, sample_rate=rate,
                              phones=phones, words=[], emotions=tags, pitch=pitch,
                              source="phone_recognition", warnings=warnings)


def _tile(entries, duration: float) -> tuple[list[Phone], list[int]]:
    """Phones from ``(ARPAbet, start, end, stress, token)``: pauses merged, gaps filled with
    silence, the last phone stretched to the end of the audio. Returns the phones and, per phone,
    its token index (-1 for pauses)."""
    phones: list[Phone] = []
    tokens: list[int] = []
    cursor = 0.0
    for name, start, end, stress, token in entries:
        start, end = max(start, cursor), min(max(end, start), duration)
        if end <= start:
            continue
        try:
            units = from_arpabet(name)
        except UserError:  # a filler or noise model pocketsphinx may report
            units = (SILENCE,)
        if start > cursor + 1e-9:
            phones.append(Phone("SIL", SILENCE, cursor, start - cursor))
            tokens.append(-1)
        for j, unit in enumerate(units):
            a = start + (end - start) * j / len(units)
            b = start + (end - start) * (j + 1) / len(units)
            symbol = name.split("(")[0].upper().rstrip("012")
            if unit == SILENCE and phones and phones[-1].phone == SILENCE:
                last = phones[-1]
                phones[-1] = Phone(last.symbol, SILENCE, last.start, b - last.start)
                continue
            phones.append(Phone(symbol, unit, a, b - a, stress if j == 0 else 0))
            tokens.append(-1 if unit == SILENCE else token)
        cursor = end
    if cursor < duration - 1e-9:
        if phones and phones[-1].phone == SILENCE:
            last = phones[-1]
            phones[-1] = Phone(last.symbol, SILENCE, last.start, duration - last.start)
        else:
            phones.append(Phone("SIL", SILENCE, cursor, duration - cursor))
            tokens.append(-1)
    return phones, tokens


# default search beams first (identical to `pocketsphinx align`), then wider ones: synthetic or
# unusual voices can fall out of the default beams before the end of the utterance
_BEAMS = ({}, {"beam": 1e-80, "wbeam": 1e-60, "pbeam": 1e-80}, {"beam": 1e-300, "wbeam": 1e-300, "pbeam": 1e-300})


def _decoder_with_words(ps, beams: dict, words: list[tuple[str, str]]):
    decoder = ps.Decoder(lm=None, bestpath=False, loglevel="FATAL", compallsen=True, **beams)
    for word, phones in words:
        decoder.add_word(word, phones, True)
    return decoder


def _alignment_entries(alignment, word_count: int) -> list[tuple]:
    """(phone, start s, end s, 0, word index or -1 for silence, first frame, frames, score) of
    pocketsphinx's phone alignment."""
    entries = []
    token = 0
    for entry in alignment:
        name = entry.name.split("(")[0]
        if name in ("<s>", "</s>", "<sil>") or token >= word_count:
            for phone_entry in entry:
                entries.append(("SIL", phone_entry.start * FRAME,
                                (phone_entry.start + phone_entry.duration) * FRAME, 0, -1,
                                phone_entry.start, phone_entry.duration, float(phone_entry.score)))
            continue
        for phone_entry in entry:
            entries.append((phone_entry.name, phone_entry.start * FRAME,
                            (phone_entry.start + phone_entry.duration) * FRAME, 0, token,
                            phone_entry.start, phone_entry.duration, float(phone_entry.score)))
        token += 1
    return entries


def _force_align(ps, pcm, loops, samples, rate, duration, pitch, text, cleaned, tags, language) -> Utterance:
    decoder = ps.Decoder(lm=None, bestpath=False, loglevel="FATAL", compallsen=True)
    english = language.lower().startswith("en")
    voice = language if language else "en-us"
    warnings: list[str] = []
    if not english:
        warnings.append(f"the acoustic model is English; {language!r} words were pronounced by "
                        "espeak-ng and mapped to English phones, so timing is less accurate")
    spans = [s for s in token_spans(cleaned) if any(ch.isalnum() for ch in cleaned[s[0]:s[1]])]
    spoken = _espeak_pronunciations(cleaned, "en-us" if english else voice)
    keys: list[str] = []
    added: list[str] = []
    decoder_words: list[tuple[str, str]] = []
    for k, (a, b) in enumerate(spans):
        word = _normalise(cleaned[a:b])
        if english and decoder.lookup_word(word) is not None:
            keys.append(word)
            continue
        arpabet = to_arpabet([p for p, _ in spoken.get((a, b), [])])
        if not arpabet:
            raise UserError(f"cannot find a pronunciation for {cleaned[a:b]!r}; spell it out in the transcript")
        key = word if english and word.isascii() and not any(c.isspace() for c in word) else f"fh{k}_w"
        decoder.add_word(key, " ".join(arpabet), True)
        decoder_words.append((key, " ".join(arpabet)))
        added.append(cleaned[a:b])
        keys.append(key)
    if added and english:
        warnings.append("not in the dictionary, pronounced by espeak-ng: " + ", ".join(added))

    texts = [cleaned[a:b] for a, b in spans]
    # ``loops``: the two free phone decodes (confidence reference, recognition), beside the forced passes
    entries, fit, soft, free = _checked_alignment(ps, pcm, decoder, keys, decoder_words, texts, loops)
    expected = _expected_durations(cleaned, spans, "en-us" if english else voice)
    warnings.extend(transcript_check.named_warnings(fit, soft))
    warnings.extend(_missing_words(pcm, fit, soft, entries, free, loops.result(1), expected))

    phones, tokens = _tile([entry[:5] for entry in entries], duration)
    token_phones: dict[int, list[int]] = {}
    for i, t in enumerate(tokens):
        if t >= 0:
            token_phones.setdefault(t, []).append(i)
    _apply_stress(phones, token_phones, spans, spoken)

    drafts = _drafts(spans, cleaned, token_phones, phones)
    return assemble_utterance(text=text, language=language, samples=samples, sample_rate=rate,
                              phones=phones, words=drafts, emotions=tags, pitch=pitch,
                              source="alignment", warnings=warnings)


def _checked_alignment(ps, pcm: bytes, decoder, keys: list[str], decoder_words, texts: list[str], loops):
    """The word-level forced alignment with ``decoder`` (default beams), then wider beams, checked against
    free phone recognition (``loops.result(0)``; ``transcript_check``: refuses a transcript that does not
    match). The phone pass (``set_alignment``) follows the word pass at once: it needs no free decode, so
    it runs while the second process is still decoding. Returns the phone alignment (``_alignment_entries``),
    the words' fit, the soft transcript's path and the free phone path."""
    for beams in _BEAMS:
        if beams:
            decoder = _decoder_with_words(ps, beams, decoder_words)
        try:
            decoder.set_align_text(" ".join(keys))
        except RuntimeError as exc:
            raise UserError(f"pocketsphinx cannot align this transcript ({exc})") from None
        _decode(decoder, pcm)
        if decoder.hyp() is not None:
            words = phone_loop.segments(decoder)       # the word path, before the phone pass replaces it
            decoder.set_alignment()
            _decode(decoder, pcm)
            alignment = decoder.get_alignment()
            entries = None if alignment is None else _alignment_entries(alignment, len(texts))
            free = loops.result(0)
            fit = transcript_check.measure(decoder, free, pcm, texts, forced=words)
            soft = transcript_check.soft_path(ps, pcm, keys, decoder_words, fit.words, beams)
            transcript_check.judge_with_soft(fit, soft)
            if entries is None:
                raise UserError("the transcript does not match the audio (phone alignment failed)")
            return entries, fit, soft, free
    raise UserError("the transcript does not match the audio (no alignment reaches the end of the "
                    "audio); check the words, or leave the transcript empty for phone recognition")


def _missing_words(pcm: bytes, fit, soft, entries, free, recognition, expected) -> list[str]:
    """Warnings naming the word boundaries where the transcript seems to lack a word (``missing_words``:
    the calibrated model over the phone alignment ``entries``, the ``free`` phone path, phone
    ``recognition`` and durations), except next to words the ``soft`` path names as not spoken."""
    phones = [missing_words.PhoneSeg(token, name, start, frames, score)
              for name, _, _, _, token, start, frames, score in entries if token >= 0]
    recognised = [name for name, _, _, _ in recognition if not transcript_check.is_filler(name)]
    loud = transcript_check.loud_frames(pcm, len(pcm) // (2 * transcript_check.HOP))
    features = missing_words.boundary_features(fit.words, phones, free, recognised, expected, loud)
    return missing_words.missing_word_warnings(fit.words, fit.texts, features, missing_words.load_model(),
                                               transcript_check.named_tokens(fit, soft))


def _expected_durations(text: str, spans, voice: str) -> list[float | None]:
    """Per token span, how long espeak-ng takes to say it (s; None where it merged or lacks the word)."""
    from .tts import synthesize  # noqa: PLC0415 - espeak is optional for dictionary words
    try:
        spoken = synthesize(text, voice=voice)
    except UserError:
        return [None] * len(spans)
    by_start = {w.text_start: w.end - w.start for w in spoken.words}
    return [by_start.get(a) for a, _ in spans]


def _espeak_pronunciations(text: str, voice: str) -> dict:
    """Per token span, espeak-ng's ``[(unified phone, stress), ...]`` ({} without espeak-ng)."""
    from .tts import pronounce  # noqa: PLC0415 - espeak is optional for dictionary words
    try:
        return pronounce(text, voice)
    except UserError:
        return {}


def _apply_stress(phones, token_phones, spans, spoken) -> None:
    """Lexical stress onto the aligned vowels: espeak's when its vowels line up, else the longest."""
    for token, indices in token_phones.items():
        vowels = [i for i in indices if is_vowel(phones[i].phone)]
        if not vowels:
            continue
        stresses = [s for p, s in spoken.get(spans[token], []) if is_vowel(p)]
        if len(stresses) != len(vowels) or not any(s == 1 for s in stresses):
            stresses = [0] * len(vowels)
            longest = max(range(len(vowels)), key=lambda j: phones[vowels[j]].duration)
            stresses[longest] = 1
        for i, s in zip(vowels, stresses):
            p = phones[i]
            phones[i] = Phone(p.symbol, p.phone, p.start, p.duration, s, p.word, p.syllable)


def _drafts(spans, cleaned, token_phones, phones) -> list[WordDraft]:
    """Words with sentence numbers (from . ? ! after a word) and phrase ends (, ; : or a pause)."""
    drafts = []
    sentence = 0
    for token, (a, b) in enumerate(spans):
        indices = token_phones.get(token, [])
        following = cleaned[b:spans[token + 1][0]] if token + 1 < len(spans) else cleaned[b:]
        ends_sentence = bool(_SENTENCE_END.search(following))
        ends_phrase = bool(_PHRASE_END.search(following))
        if indices and token + 1 < len(spans) and token_phones.get(token + 1):
            gap = phones[token_phones[token + 1][0]].start - phones[indices[-1]].end
            ends_phrase = ends_phrase or gap >= PHRASE_PAUSE
        drafts.append(WordDraft(a, b, indices, sentence, ends_phrase))
        if ends_sentence:
            sentence += 1
    return drafts
