# SPDX-License-Identifier: GPL-3.0-or-later
"""One phone inventory for the whole speech engine, and the ways into and out of it.

Every source of phonemes maps onto the same unified phones (lower-case, ARPAbet-like names, extended
for German and other languages): ARPAbet (the CMU dictionary and pocketsphinx), espeak-ng's own
phoneme names (English and German tables, SAMPA-like fallback for other voices), SAMPA and IPA.
espeak-ng voices for any language are read through their IPA names, so one IPA table serves them all.

From a unified phone one gets its Meta/Oculus viseme (the 15 shape-key names that are a contract,
CONTRIBUTING.md), its nearest ARPAbet pronunciation (to add unknown words to pocketsphinx's
dictionary) and its articulation class (``presets/speech/articulation.json``; thesis 3.1.3, 4.3.3:
"for each phoneme, the muscle contractions ... can simply be re-used").
"""
from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass

from ..core.errors import UserError

#: The 15 Oculus/Meta visemes with the names of the Oculus Lipsync reference (sil PP FF TH DD kk CH SS nn
#: RR aa E ih oh ou), prefixed ``viseme_`` as shape keys.
VISEMES = ("viseme_sil", "viseme_PP", "viseme_FF", "viseme_TH", "viseme_DD", "viseme_kk", "viseme_CH",
           "viseme_SS", "viseme_nn", "viseme_RR", "viseme_aa", "viseme_E", "viseme_ih", "viseme_oh",
           "viseme_ou")

#: Other spellings of the same visemes found on characters (Ready Player Me avatars, and the table labels
#: I/O/U of the Oculus reference): lip sync drives these shape keys when the canonical name is absent.
VISEME_ALIASES = {"viseme_ih": ("viseme_I",), "viseme_oh": ("viseme_O",), "viseme_ou": ("viseme_U",)}

SILENCE = "sil"


@dataclass(frozen=True)
class PhoneInfo:
    """One unified phone. ``glide_to`` names the end point of a diphthong (the coarticulation gives
    a diphthong two targets); ``arpabet`` is the nearest pronunciation in the CMU phone set."""

    name: str
    ipa: str
    kind: str  # "vowel", "consonant" or "pause"
    viseme: str
    arpabet: tuple[str, ...]
    glide_to: str | None = None


_TABLE_LABEL_TO_NAME = {"I": "ih", "O": "oh", "U": "ou"}  # the reference table labels I/O/U as ih/oh/ou


def _p(name, ipa, kind, viseme, arpabet, glide_to=None):
    viseme = _TABLE_LABEL_TO_NAME.get(viseme, viseme)
    return PhoneInfo(name, ipa, kind, "viseme_" + viseme, tuple(arpabet.split()), glide_to)


_INVENTORY = [
    _p("sil", "", "pause", "sil", "SIL"),
    # vowels (monophthongs)
    _p("iy", "iː", "vowel", "I", "IY"), _p("ih", "ɪ", "vowel", "I", "IH"), _p("ix", "ɨ", "vowel", "I", "IH"),
    _p("e", "e", "vowel", "E", "EY"), _p("eh", "ɛ", "vowel", "E", "EH"), _p("ae", "æ", "vowel", "aa", "AE"),
    _p("a", "a", "vowel", "aa", "AA"), _p("aa", "ɑ", "vowel", "aa", "AA"), _p("ah", "ʌ", "vowel", "aa", "AH"),
    _p("ax", "ə", "vowel", "E", "AH"), _p("er", "ɜ", "vowel", "E", "ER"), _p("ao", "ɔ", "vowel", "O", "AO"),
    _p("o", "o", "vowel", "O", "OW"), _p("uh", "ʊ", "vowel", "U", "UH"), _p("uw", "u", "vowel", "U", "UW"),
    _p("ue", "y", "vowel", "U", "UW"), _p("oe", "ø", "vowel", "O", "ER"),
    # diphthongs
    _p("ey", "eɪ", "vowel", "E", "EY", "ih"), _p("ay", "aɪ", "vowel", "aa", "AY", "ih"),
    _p("aw", "aʊ", "vowel", "aa", "AW", "uh"), _p("oy", "ɔɪ", "vowel", "O", "OY", "ih"),
    _p("ow", "oʊ", "vowel", "O", "OW", "uh"),
    # consonants
    _p("p", "p", "consonant", "PP", "P"), _p("b", "b", "consonant", "PP", "B"),
    _p("m", "m", "consonant", "PP", "M"), _p("pf", "pf", "consonant", "PP", "P F"),
    _p("f", "f", "consonant", "FF", "F"), _p("v", "v", "consonant", "FF", "V"),
    _p("th", "θ", "consonant", "TH", "TH"), _p("dh", "ð", "consonant", "TH", "DH"),
    _p("t", "t", "consonant", "DD", "T"), _p("d", "d", "consonant", "DD", "D"),
    _p("n", "n", "consonant", "nn", "N"), _p("l", "l", "consonant", "nn", "L"),
    _p("s", "s", "consonant", "SS", "S"), _p("z", "z", "consonant", "SS", "Z"),
    _p("ts", "ts", "consonant", "SS", "T S"),
    _p("sh", "ʃ", "consonant", "CH", "SH"), _p("zh", "ʒ", "consonant", "CH", "ZH"),
    _p("ch", "tʃ", "consonant", "CH", "CH"), _p("jh", "dʒ", "consonant", "CH", "JH"),
    _p("k", "k", "consonant", "kk", "K"), _p("g", "ɡ", "consonant", "kk", "G"),
    _p("ng", "ŋ", "consonant", "kk", "NG"), _p("x", "x", "consonant", "kk", "HH"),
    _p("xj", "ç", "consonant", "kk", "HH"), _p("hh", "h", "consonant", "kk", "HH"),
    _p("q", "ʔ", "consonant", "sil", ""), _p("r", "ɹ", "consonant", "RR", "R"),
    _p("rx", "ʁ", "consonant", "kk", "R"), _p("w", "w", "consonant", "U", "W"),
    _p("y", "j", "consonant", "I", "Y"),
]

PHONES: dict[str, PhoneInfo] = {p.name: p for p in _INVENTORY}
VISEME_OF_PHONE: dict[str, str] = {p.name: p.viseme for p in _INVENTORY}

# --- ARPAbet (CMU dictionary, pocketsphinx; stress digits are stripped) ---------------------------
_ARPABET = {
    "AA": "aa", "AE": "ae", "AH": "ah", "AO": "ao", "AW": "aw", "AY": "ay", "EH": "eh", "ER": "er",
    "EY": "ey", "IH": "ih", "IY": "iy", "OW": "ow", "OY": "oy", "UH": "uh", "UW": "uw", "AX": "ax",
    "AXR": "er", "IX": "ix", "UX": "uw", "B": "b", "CH": "ch", "D": "d", "DH": "dh", "F": "f", "G": "g",
    "HH": "hh", "H": "hh", "JH": "jh", "K": "k", "L": "l", "M": "m", "N": "n", "NG": "ng", "P": "p",
    "R": "r", "S": "s", "SH": "sh", "T": "t", "TH": "th", "V": "v", "W": "w", "Y": "y", "Z": "z",
    "ZH": "zh", "DX": "d", "EL": ("ax", "l"), "EM": ("ax", "m"), "EN": ("ax", "n"), "Q": "q",
    "SIL": "sil", "SP": "sil", "+NSN+": "sil", "+SPN+": "sil", "+BREATH+": "sil", "+COUGH+": "sil",
    "+NOISE+": "sil", "+SMACK+": "sil", "+UM+": ("ah", "m"), "+UH+": "ah",
}

# --- IPA (also what espeak-ng reports for any voice with phoneme events in IPA mode) --------------
_IPA = {
    "iː": "iy", "i": "iy", "ɪ": "ih", "ɨ": "ix", "ɯ": "ix", "ᵻ": "ix", "e": "e", "eː": "e", "ɛ": "eh",
    "ɛː": "eh", "æ": "ae", "a": "a", "aː": "a", "ä": "a", "ɐ": "ah", "ɑ": "aa", "ɑː": "aa", "ɒ": "ao",
    "ʌ": "ah", "ə": "ax", "ɚ": "er", "ɜ": "er", "ɜː": "er", "ɝ": "er", "ɔ": "ao", "ɔː": "ao",
    "o": "o", "oː": "o", "ɤ": "ax", "ʊ": "uh", "u": "uw", "uː": "uw", "y": "ue", "yː": "ue", "ʏ": "ue",
    "ʉ": "uw", "ø": "oe", "øː": "oe", "œ": "oe", "ɵ": "oe", "ɘ": "ax", "ɞ": "oe",
    "eɪ": "ey", "aɪ": "ay", "aʊ": "aw", "ɔɪ": "oy", "ɔʏ": "oy", "ɔø": "oy", "oʊ": "ow", "əʊ": "ow",
    "oɪ": "oy", "ɑɪ": "ay", "ɑʊ": "aw", "ɛɪ": "ey", "aɛ": "ay", "aɔ": "aw",
    "p": "p", "b": "b", "m": "m", "ɱ": "m", "β": "b", "ɸ": "f", "f": "f", "v": "v", "ʋ": "v",
    "θ": "th", "ð": "dh", "t": "t", "d": "d", "ʈ": "t", "ɖ": "d", "ɾ": "d", "ɽ": "d", "n": "n",
    "ɳ": "n", "ɲ": "n", "l": "l", "ɫ": "l", "ɭ": "l", "ʎ": "l", "ɬ": "l", "s": "s", "z": "z",
    "ʃ": "sh", "ʒ": "zh", "ʂ": "sh", "ʐ": "zh", "ɕ": "sh", "ʑ": "zh", "tʃ": "ch", "dʒ": "jh",
    "tɕ": "ch", "dʑ": "jh", "ʈʂ": "ch", "ɖʐ": "jh", "ts": "ts", "dz": "z", "pf": "pf",
    "k": "k", "ɡ": "g", "g": "g", "c": "k", "ɟ": "g", "q": "k", "ɢ": "g", "ŋ": "ng", "ɴ": "ng",
    "x": "x", "ɣ": "g", "χ": "x", "ç": "xj", "ʝ": "y", "h": "hh", "ɦ": "hh", "ħ": "hh", "ʕ": "hh",
    "ʔ": "q", "ɹ": "r", "r": "r", "ɻ": "r", "ʀ": "rx", "ʁ": "rx", "w": "w", "ʍ": "w", "ɥ": "w",
    "ɰ": "w", "j": "y", "ʲ": "y",
}

#: letters espeak-ng prints in IPA mode that are not the IPA letters: Greek look-alikes (Danish ε, Lule
#: Sami Φ) and the ts ligature ʦ (Luxembourgish)
_IPA_EXTRA = {"ε": "eh", "Φ": "f", "ɸ": "f", "ʦ": "ts", "ʣ": "z", "ʧ": "ch", "ʤ": "jh"}
_IPA.update(_IPA_EXTRA)

#: Languages whose espeak-ng IPA writes the palatal stops c ɟ for the affricates ch / jh (Hindi च ज and
#: the other Indic scripts): they reach the CH viseme, not kk
_PALATAL_AFFRICATES = {"hi", "bn", "as", "gu", "kn", "ml", "mr", "ne", "or", "pa", "sd", "ta", "te",
                       "ur", "si", "kok", "bpy"}

# --- SAMPA (English and German conventions, and most of what espeak prints for other voices) ------
_SAMPA = {
    "i": "iy", "i:": "iy", "I": "ih", "e": "e", "e:": "e", "E": "eh", "E:": "eh", "{": "ae",
    "a": "a", "a:": "a", "A": "aa", "A:": "aa", "Q": "ao", "V": "ah", "@": "ax", "6": "ah",
    "3": "er", "3:": "er", "O": "ao", "O:": "ao", "o": "o", "o:": "o", "U": "uh", "u": "uw",
    "u:": "uw", "y": "ue", "y:": "ue", "Y": "ue", "2": "oe", "2:": "oe", "9": "oe", "1": "ix",
    "eI": "ey", "aI": "ay", "aU": "aw", "OI": "oy", "OY": "oy", "@U": "ow", "oU": "ow",
    "I@": ("ih", "ax"), "e@": ("eh", "ax"), "U@": ("uh", "ax"),
    "p": "p", "b": "b", "t": "t", "d": "d", "k": "k", "g": "g", "m": "m", "n": "n", "N": "ng",
    "f": "f", "v": "v", "T": "th", "D": "dh", "s": "s", "z": "z", "S": "sh", "Z": "zh", "h": "hh",
    "tS": "ch", "dZ": "jh", "l": "l", "r": "r", "R": "rx", "w": "w", "j": "y", "C": "xj", "x": "x",
    "?": "q", "pf": "pf", "ts": "ts", "4": "d", "B": "b", "G": "g", "J": "n", "L": "l", "X": "x",
}

# --- espeak-ng's own names (stress marks stripped) where they differ from SAMPA ------------------
_ESPEAK_EN = {
    "a": "ae", "a#": "ax", "aa": "aa", "A@": ("aa", "r"), "aI@": ("ay", "ax"), "aI3": ("ay", "er"),
    "aU@": ("aw", "ax"), "@2": "ax", "@5": "ax", "@L": ("ax", "l"), "3": "er", "3:": "er",
    "e@": ("eh", "r"), "E2": "eh", "E3": "eh", "i": "iy", "i@": ("iy", "ax"), "i@3": ("iy", "er"),
    "I2": "ih", "I#": "ih", "0": "ao", "0#": "ao", "O@": ("ao", "r"), "o@": ("ao", "r"), "oU#": "ow",
    "U@": ("uh", "r"), "t#": "d", "d#": "d", "n-": "n", "l/": "l", "r-": "r", "w#": "w", "z#": "z",
    "?": "q", "IR": ("ih", "r"), "VR": ("ah", "r"), "aI": "ay", "aU": "aw", "eI": "ey", "OI": "oy",
    "oU": "ow",
}
_ESPEAK_DE = {
    "a": "a", "a:": "a", "A:": "aa", "6": "ah", "3": "er", "@": "ax", "Y:": "oe", "E": "eh", "E:": "eh", "e:": "e",
    "I": "ih", "i:": "iy", "O": "ao", "o:": "o", "U": "uh", "u:": "uw", "Y": "ue", "y:": "ue",
    "9": "oe", "W": "oe", "2:": "oe", "aI": "ay", "aU": "aw", "OY": "oy", "C": "xj", "x": "x", "R": "r",
    "R2": "r", "r": "r", "?": "q", "pf": "pf", "pF": "pf", "ts": "ts", "tS": "ch", "dZ": "jh", "l": "l",
}

_ESPEAK_COMMON = {";": "y", "@-": "ax", "a#": "a", "I#": "ih", "E#": "eh", "0": "ao"}

#: espeak-ng names that come through its IPA mode unconverted (Kyrgyz N S tS dZ, Icelandic l# r# tl#,
#: Amharic t`, Hakka n^, Irish A, Danish ?a): IPA, else SAMPA
_ESPEAK_IPA_FALLBACK = {**_SAMPA, **_IPA}

_STRESS_PRIMARY = ("'", "ˈ", '"')
_STRESS_SECONDARY = (",", "ˌ", "%")
_STRESS_CHARACTERS = "'ˈ\",ˌ%="


def phone(name: str) -> PhoneInfo:
    """The inventory entry of a unified phone name (UserError for an unknown name)."""
    try:
        return PHONES[name]
    except KeyError:
        raise UserError(f"unknown phone {name!r}; known phones: {', '.join(PHONES)}") from None


def is_vowel(name: str) -> bool:
    return PHONES[name].kind == "vowel"


def is_pause(name: str) -> bool:
    return PHONES[name].kind == "pause"


def viseme_of(name: str) -> str:
    """Meta/Oculus viseme of a unified phone (published viseme table, presets/SOURCES.md)."""
    return PHONES[name].viseme


def split_stress(symbol: str) -> tuple[str, int]:
    """Strip stress marks (espeak ' and ,; IPA ˈ and ˌ; SAMPA " and %; ARPAbet digits) from a
    symbol and return ``(bare symbol, stress)`` with stress 1 primary, 2 secondary, 0 none."""
    stress = 0
    if any(m in symbol for m in _STRESS_PRIMARY):
        stress = 1
    elif any(m in symbol for m in _STRESS_SECONDARY):
        stress = 2
    bare = symbol.translate({ord(c): None for c in _STRESS_CHARACTERS})
    return bare, stress


def _as_tuple(value) -> tuple[str, ...]:
    return value if isinstance(value, tuple) else (value,)


def from_arpabet(symbol: str) -> tuple[str, ...]:
    """Unified phones of one ARPAbet symbol (``"AH0"``, ``"hh"``, ``"+NSN+"`` ...)."""
    bare = symbol.strip().upper().rstrip("012")
    bare = bare.split("(")[0]
    if bare not in _ARPABET:
        raise UserError(f"{symbol!r} is not an ARPAbet phone")
    return _as_tuple(_ARPABET[bare])


def _strip_ipa_marks(text: str) -> str:
    """Drop diacritics (combining marks, tie bars, aspiration, syllabicity, the labialisation ᵝ of
    Japanese ɯᵝ ...) but keep letters of the table such as ç whole and the length mark ː; a letter
    that only precomposes a base with a mark (nasal ã õ ũ ẽ ĩ of Portuguese, Hindi, Guarani) is
    its base."""
    kept = []
    for ch in unicodedata.normalize("NFC", text):
        if unicodedata.combining(ch) or ch in "͡‿ˑʰʱʷˠˤᵝ-.|‖":
            continue
        if ch not in _IPA and ch not in _IPA_EXTRA:
            ch = "".join(c for c in unicodedata.normalize("NFD", ch) if not unicodedata.combining(c))
        kept.append(ch)
    return "".join(kept)


def _greedy(text: str, table: dict, longest: int) -> tuple[str, ...] | None:
    """Segment ``text`` into the longest table entries, left to right; None if something is left."""
    out: list[str] = []
    i = 0
    while i < len(text):
        for size in range(min(longest, len(text) - i), 0, -1):
            piece = text[i:i + size]
            if piece in table:
                out.extend(_as_tuple(table[piece]))
                i += size
                break
        else:
            if text[i] in "ː:":  # a length mark that did not attach to its vowel
                i += 1
                continue
            return None
    return tuple(out)


def from_ipa(symbol: str, language: str = "") -> tuple[str, ...]:
    """Unified phones of an IPA string (one phoneme such as ``"ˈaɪ"`` or a word such as ``"həˈloʊ"``).
    Empty input (espeak's IPA name for a pause) gives ``("sil",)``. The tap ɾ is a flapped /t d/ in
    English and an /r/ elsewhere; a palatalisation mark on a consonant (``dʲ``) is dropped."""
    bare, _ = split_stress(symbol)
    bare = _strip_ipa_marks(bare).replace(" ", "")
    if not bare:
        return (SILENCE,)
    if len(bare) > 1:
        bare = bare.replace("ʲ", "")
    if "ɾ" in bare and not language.lower().startswith("en"):
        bare = bare.replace("ɾ", "r")
    if language.lower().split("-")[0] in _PALATAL_AFFRICATES:
        bare = bare.replace("c", "tʃ").replace("ɟ", "dʒ")
    result = _greedy(bare, _IPA, 3)
    if result is None:  # espeak prints its own (SAMPA-like) name where a phoneme has no IPA name
        result = _greedy(re.sub(r"[#\[\]`^;/]", "", bare), _ESPEAK_IPA_FALLBACK, 3)
    if not result:
        raise UserError(f"cannot read the IPA symbol {symbol!r}")
    return result


def from_sampa(symbol: str) -> tuple[str, ...]:
    """Unified phones of a SAMPA symbol or string (English and German SAMPA)."""
    bare, _ = split_stress(symbol)
    result = _greedy(bare.replace(" ", ""), _SAMPA, 2)
    if result is None:
        raise UserError(f"cannot read the SAMPA symbol {symbol!r}")
    return result


def from_espeak(name: str, language: str = "en") -> tuple[str, ...]:
    """Unified phones of one espeak-ng phoneme name (as in phoneme events and ``espeak-ng -x``).

    Names starting with ``_`` are pauses. English and German have their own tables; other languages
    fall back to SAMPA conventions after dropping espeak's variant markers (``#``, digits, ``;`` for
    palatalisation, ``-``, ``/``)."""
    bare, _ = split_stress(name.strip())
    if not bare or bare.startswith("_") or bare in ("||", "|"):
        return (SILENCE,)
    lang = language.lower()
    tables = [_ESPEAK_DE] if lang.startswith("de") else [_ESPEAK_EN] if lang.startswith("en") else []
    tables += [_ESPEAK_COMMON, _SAMPA]
    for candidate in (bare, re.sub(r"[#;/\-^~]", "", bare), re.sub(r"[#;/\-^~0-9]", "", bare)):
        for table in tables:
            if candidate in table:
                return _as_tuple(table[candidate])
        if candidate:
            result = _greedy(candidate, _SAMPA, 2)
            if result:
                return result
    raise UserError(f"cannot read the espeak phoneme name {name!r} for language {language!r}")


def to_arpabet(phones: tuple[str, ...] | list[str]) -> list[str]:
    """The nearest CMU/ARPAbet pronunciation of a sequence of unified phones (pauses and glottal
    stops are dropped), as needed to add a word to pocketsphinx's dictionary."""
    out: list[str] = []
    for name in phones:
        info = PHONES[name]
        if info.kind == "pause":
            continue
        out.extend(a for a in info.arpabet if a)
    return out
