# SPDX-License-Identifier: GPL-3.0-or-later
"""ctypes bridge to libespeak-ng: synchronous synthesis with phoneme, word and sentence events.

This is the "MARY" role of thesis 4.3.2: the text-to-speech system that returns, with the audio, the
exact timing of every phoneme ("exact timing information of the individual sound segments produced
... is needed for a proper synchronization of lip movement with the sound").

The library comes from the ``espeakng-loader`` wheel (``get_library_path()`` / ``get_data_path()``),
else from a system ``libespeak-ng``. espeak-ng is one global state machine, so every call holds the
module lock. ``AUDIO_OUTPUT_SYNCHRONOUS`` makes ``espeak_Synth`` return only after the callback has
received all audio; phoneme events are enabled at initialisation (option 0x1). Each event's ``sample``
is the absolute index of the sample where it starts (22050 Hz for the bundled voices).

``espeak_TextToPhonemes`` is deliberately not used: after a few dozen calls it corrupts the event
list of the next synthesis (events of the first audio block go missing, seen with espeak-ng 1.52);
pronunciations come from a synthesis with IPA phoneme events instead (``tts.pronounce``).

Repeatability: espeak-ng keeps state in static variables from one synthesis to the next (the same text
spoken twice in one process came out a few samples longer, phone boundaries shifted), and neither
``espeak_Terminate`` nor a new ``espeak_Initialize`` clears it. Every synthesis therefore runs in a fresh
instance: a private copy of the wheel's library is loaded, initialised, used once and unloaded, so the same
text gives the same samples in every call (~15 ms per synthesis). Its random generator is seeded on every
call. (A system libespeak-ng, which cannot be copied, is shared and keeps the old behaviour.)
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import shutil
import tempfile
import threading
from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError

_AUDIO_OUTPUT_SYNCHRONOUS = 2
_INITIALIZE_PHONEME_EVENTS = 0x1
_CHARS_UTF8 = 1
_ENDPAUSE = 0x1000
_POS_CHARACTER = 1
_RATE, _VOLUME, _PITCH = 1, 2, 3

EVENT_WORD, EVENT_SENTENCE, EVENT_END, EVENT_MSG_TERMINATED, EVENT_PHONEME = 1, 2, 5, 6, 7

RATE_RANGE = (80, 450)      # words per minute
PITCH_RANGE = (0, 100)      # espeak's 0..100 base pitch
VOLUME_RANGE = (0, 200)     # percent

_LOCK = threading.RLock()


class _EventId(ctypes.Union):
    _fields_ = [("number", ctypes.c_int), ("name", ctypes.c_char_p), ("string", ctypes.c_char * 8)]


class _Event(ctypes.Structure):
    """``espeak_EVENT`` of speak_lib.h."""
    _fields_ = [("type", ctypes.c_int), ("unique_identifier", ctypes.c_uint),
                ("text_position", ctypes.c_int), ("length", ctypes.c_int),
                ("audio_position", ctypes.c_int), ("sample", ctypes.c_int),
                ("user_data", ctypes.c_void_p), ("id", _EventId)]


class _Voice(ctypes.Structure):
    """``espeak_VOICE`` of speak_lib.h."""
    _fields_ = [("name", ctypes.c_char_p), ("languages", ctypes.c_void_p),
                ("identifier", ctypes.c_char_p), ("gender", ctypes.c_ubyte), ("age", ctypes.c_ubyte),
                ("variant", ctypes.c_ubyte), ("xx1", ctypes.c_ubyte), ("score", ctypes.c_int),
                ("spare", ctypes.c_void_p)]


_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int,
                             ctypes.POINTER(_Event))


@dataclass(frozen=True)
class SynthEvent:
    """One espeak event: ``kind`` (EVENT_* constant), 0-based character ``text_position`` into the
    synthesised text, ``length`` (words), ``sample`` index, ``name`` (phoneme) or ``number``."""

    kind: int
    text_position: int
    length: int
    sample: int
    name: str = ""
    number: int = 0


@dataclass(frozen=True)
class RawSynthesis:
    samples: np.ndarray  # int16
    sample_rate: int
    events: list[SynthEvent]
    language: str = ""  # first language of the voice that spoke ("en-us", "de", ...)


@dataclass(frozen=True)
class VoiceInfo:
    name: str
    identifier: str
    languages: tuple[str, ...]


class _Engine:
    lib = None
    sample_rate = 0
    source = ""
    path = ""
    data = None
    callback = None
    chunks: list[bytes] = []
    events: list[SynthEvent] = []


def _load_library():
    """Load and initialise libespeak-ng once: the wheel first, the system library as fallback."""
    if _Engine.lib is not None:
        return _Engine.lib
    candidates = []
    try:
        import espeakng_loader  # noqa: PLC0415 - optional wheel, imported lazily
        candidates.append((espeakng_loader.get_library_path(), espeakng_loader.get_data_path(), "wheel"))
    except Exception:  # missing wheel or missing data folder
        pass
    system = ctypes.util.find_library("espeak-ng")
    if system:
        candidates.append((system, None, "system"))
    errors = []
    for library_path, data_path, source in candidates:
        try:
            lib = ctypes.CDLL(library_path)
        except OSError as exc:
            errors.append(str(exc))
            continue
        _declare(lib)
        data = data_path.encode() if data_path else None
        rate = lib.espeak_Initialize(_AUDIO_OUTPUT_SYNCHRONOUS, 0, data, _INITIALIZE_PHONEME_EVENTS)
        if rate <= 0:
            errors.append(f"{library_path}: espeak_Initialize failed")
            continue
        _Engine.callback = _CALLBACK(_collect)
        lib.espeak_SetSynthCallback(_Engine.callback)
        _Engine.lib, _Engine.sample_rate, _Engine.source = lib, int(rate), source
        _Engine.path, _Engine.data = library_path, data
        return lib
    detail = f" ({'; '.join(errors)})" if errors else ""
    raise UserError("espeak-ng is not available: install the add-on with its bundled wheels "
                    f"(espeakng-loader) or the system package libespeak-ng{detail}")


def _unload(handle) -> None:
    import _ctypes  # noqa: PLC0415 - the platform's dlclose / FreeLibrary
    (_ctypes.FreeLibrary if os.name == "nt" else _ctypes.dlclose)(handle)


@contextlib.contextmanager
def _fresh_engine():
    """libespeak-ng in its initial state for one synthesis (module docstring, "Repeatability")."""
    shared = _load_library()
    if _Engine.source != "wheel":
        yield shared
        return
    folder = tempfile.mkdtemp(prefix="fh-espeak-")
    lib = None
    try:
        copy = os.path.join(folder, os.path.basename(_Engine.path))
        shutil.copyfile(_Engine.path, copy)
        lib = ctypes.CDLL(copy)
        _declare(lib)
        if lib.espeak_Initialize(_AUDIO_OUTPUT_SYNCHRONOUS, 0, _Engine.data, _INITIALIZE_PHONEME_EVENTS) <= 0:
            raise UserError("espeak-ng could not be initialised for this synthesis")
        callback = _CALLBACK(_collect)
        lib.espeak_SetSynthCallback(callback)
        yield lib
        lib.espeak_Terminate()
        del callback
    finally:
        if lib is not None:
            handle = lib._handle
            del lib
            _unload(handle)
        shutil.rmtree(folder, ignore_errors=True)


def _declare(lib) -> None:
    lib.espeak_Terminate.argtypes = []
    lib.espeak_Terminate.restype = ctypes.c_int
    lib.espeak_Initialize.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]
    lib.espeak_Initialize.restype = ctypes.c_int
    lib.espeak_SetSynthCallback.argtypes = [_CALLBACK]
    lib.espeak_SetSynthCallback.restype = None
    lib.espeak_SetVoiceByName.argtypes = [ctypes.c_char_p]
    lib.espeak_SetVoiceByName.restype = ctypes.c_int
    lib.espeak_SetParameter.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int]
    lib.espeak_SetParameter.restype = ctypes.c_int
    lib.espeak_Synth.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int,
                                 ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p]
    lib.espeak_Synth.restype = ctypes.c_int
    lib.espeak_GetCurrentVoice.argtypes = []
    lib.espeak_GetCurrentVoice.restype = ctypes.POINTER(_Voice)
    lib.espeak_ListVoices.argtypes = [ctypes.c_void_p]
    lib.espeak_ListVoices.restype = ctypes.POINTER(ctypes.POINTER(_Voice))
    if hasattr(lib, "espeak_ng_SetPhonemeEvents"):
        lib.espeak_ng_SetPhonemeEvents.argtypes = [ctypes.c_int, ctypes.c_int]
        lib.espeak_ng_SetPhonemeEvents.restype = ctypes.c_int
    if hasattr(lib, "espeak_ng_SetRandSeed"):
        lib.espeak_ng_SetRandSeed.argtypes = [ctypes.c_long]
        lib.espeak_ng_SetRandSeed.restype = ctypes.c_int


def _collect(wav, count, events) -> int:
    """espeak's synth callback: keep the audio block and every event of this call."""
    if count > 0 and wav:
        _Engine.chunks.append(ctypes.string_at(wav, count * 2))
    i = 0
    while events[i].type != 0:
        event = events[i]
        if event.type == EVENT_PHONEME:
            raw = bytes(event.id.string)
            name = raw.split(b"\0", 1)[0].decode("utf-8", errors="ignore")
            _Engine.events.append(SynthEvent(EVENT_PHONEME, event.text_position - 1, 0, event.sample, name))
        elif event.type in (EVENT_WORD, EVENT_SENTENCE, EVENT_END, EVENT_MSG_TERMINATED):
            _Engine.events.append(SynthEvent(event.type, event.text_position - 1, event.length,
                                             event.sample, number=event.id.number))
        i += 1
    return 0


def not_a_phone(name: str) -> bool:
    """A phoneme event that is no phone of its own: a language switch such as ``(en)``, or a bare length
    mark (``ː`` / ``:``, reported by some voices after a vowel), which lengthens the phone before it."""
    return name.startswith("(") or (bool(name) and set(name) <= set("ː:ˈˌ'ˌ,"))


def available() -> bool:
    """True when libespeak-ng can be loaded."""
    try:
        with _LOCK:
            _load_library()
        return True
    except UserError:
        return False


def library_source() -> str:
    """``"wheel"`` or ``"system"``: where the loaded libespeak-ng came from."""
    with _LOCK:
        _load_library()
        return _Engine.source


def _languages(voice: _Voice) -> list[str]:
    """Decode ``espeak_VOICE.languages``: (priority byte, NUL-terminated language) pairs, then 0."""
    languages = []
    address, offset = voice.languages, 0
    while address and ctypes.string_at(address + offset, 1) != b"\0":
        language = ctypes.string_at(address + offset + 1)
        languages.append(language.decode("utf-8", errors="replace"))
        offset += len(language) + 2
    return languages


def list_voices() -> list[VoiceInfo]:
    """All espeak-ng voices (for a voice menu): name, identifier (e.g. ``gmw/en-US``) and languages."""
    with _LOCK:
        lib = _load_library()
        array = lib.espeak_ListVoices(None)
        voices = []
        i = 0
        while array and array[i]:
            voice = array[i].contents
            languages = _languages(voice)
            voices.append(VoiceInfo((voice.name or b"").decode("utf-8", errors="replace"),
                                    (voice.identifier or b"").decode("utf-8", errors="replace"),
                                    tuple(languages)))
            i += 1
    return voices


_VOICE_NAMES: list[str] = []


def voice_names() -> list[str]:
    """Every name a voice can be chosen by (identifiers and languages, sorted), read once per session;
    ``["en-us"]`` when espeak-ng is missing (a voice menu then offers the default only)."""
    if not _VOICE_NAMES:
        try:
            voices = list_voices()
            _VOICE_NAMES.extend(sorted({v.identifier for v in voices} | {lang for v in voices for lang in v.languages}))
        except UserError:
            _VOICE_NAMES.append("en-us")
    return list(_VOICE_NAMES)


def _check_range(label: str, value, bounds) -> int:
    try:
        number = int(round(float(value)))
    except (TypeError, ValueError):
        raise UserError(f"{label} must be a number, not {value!r}") from None
    if not bounds[0] <= number <= bounds[1]:
        raise UserError(f"{label} {value} is out of range; use {bounds[0]}..{bounds[1]}")
    return number


def _dictionary_name(data: bytes, identifier: str, languages: list[str]) -> str:
    """The dictionary a voice loads: its file's ``dictionary`` line, else its language up to the first
    ``-`` ("en-us" -> "en"), as espeak-ng's voice loader does."""
    path = os.path.join(data.decode(), "lang", *identifier.split("/"))
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            for line in handle:
                parts = line.split()
                if len(parts) >= 2 and parts[0] == "dictionary":
                    return parts[1]
    except OSError:
        pass
    return (languages[0] if languages else identifier.rsplit("/", 1)[-1]).split("-")[0].lower()


def _check_dictionary(lib, voice: str) -> None:
    """A voice whose ``<language>_dict`` is missing from the data folder (the wheel ships Faroese and
    Karakalpak without theirs) crashes libespeak-ng in the synthesis: refuse it before that."""
    if not _Engine.data:
        return
    current = lib.espeak_GetCurrentVoice()
    if not current or not current.contents.identifier:
        return
    identifier = current.contents.identifier.decode("utf-8", errors="replace")
    name = _dictionary_name(_Engine.data, identifier, _languages(current.contents))
    if not os.path.exists(os.path.join(_Engine.data.decode(), f"{name}_dict")):
        raise UserError(f"espeak-ng voice {voice!r} has no pronunciation dictionary ({name}_dict) in "
                        "this espeak-ng data; choose another voice (speech.list_voices() lists them)")


def _select_voice(lib, voice: str) -> None:
    if not isinstance(voice, str) or not voice.strip():
        raise UserError("no voice given; use an espeak-ng voice such as 'en-us' or 'de'")
    if lib.espeak_SetVoiceByName(voice.strip().encode("utf-8")) != 0:
        raise UserError(f"unknown espeak-ng voice {voice!r}; use a language code such as 'en-us', "
                        "'de', 'ru' or 'el' (speech.list_voices() lists them all)")
    _check_dictionary(lib, voice)


def check_voice(voice: str) -> None:
    """Refuse a voice espeak-ng lacks or cannot speak, before any synthesis (a jobs manifest checks each of
    its voices once, up front)."""
    with _LOCK, _fresh_engine() as lib:
        _select_voice(lib, voice)


def synthesize_raw(text: str, voice: str = "en-us", rate: float = 175, pitch: float = 50,
                   volume: float = 100, ipa_names: bool = False) -> RawSynthesis:
    """Synthesise ``text`` and return its int16 audio with every phoneme/word/sentence event.

    ``ipa_names`` reports phoneme names in IPA instead of espeak's ASCII names (same events)."""
    rate = _check_range("rate (words per minute)", rate, RATE_RANGE)
    pitch = _check_range("pitch", pitch, PITCH_RANGE)
    volume = _check_range("volume", volume, VOLUME_RANGE)
    data = text.encode("utf-8") + b"\0"
    with _LOCK, _fresh_engine() as lib:
        _select_voice(lib, voice)
        lib.espeak_SetParameter(_RATE, rate, 0)
        lib.espeak_SetParameter(_PITCH, pitch, 0)
        lib.espeak_SetParameter(_VOLUME, volume, 0)
        if hasattr(lib, "espeak_ng_SetPhonemeEvents"):
            lib.espeak_ng_SetPhonemeEvents(1, 1 if ipa_names else 0)
        elif ipa_names:
            raise UserError("this libespeak-ng cannot report IPA phoneme names; update espeak-ng")
        if hasattr(lib, "espeak_ng_SetRandSeed"):
            lib.espeak_ng_SetRandSeed(1)
        _Engine.chunks, _Engine.events = [], []
        try:
            status = lib.espeak_Synth(data, len(data), 0, _POS_CHARACTER, 0, _CHARS_UTF8 | _ENDPAUSE,
                                      None, None)
            chunks, events = _Engine.chunks, _Engine.events
        finally:
            _Engine.chunks, _Engine.events = [], []
            if ipa_names and hasattr(lib, "espeak_ng_SetPhonemeEvents"):
                lib.espeak_ng_SetPhonemeEvents(1, 0)
        if status != 0:
            raise UserError(f"espeak-ng could not synthesise the text (status {status})")
        sample_rate = _Engine.sample_rate
        current = lib.espeak_GetCurrentVoice()
        spoken = _languages(current.contents) if current else []
    samples = np.frombuffer(b"".join(chunks), dtype=np.int16).copy()
    return RawSynthesis(samples, sample_rate, events, spoken[0] if spoken else "")
