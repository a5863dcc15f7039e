# SPDX-License-Identifier: GPL-3.0-or-later
"""Emoticons of thesis Table 4.1, taken out of the text before synthesis and kept as emotion tags.

Table 4.1 lists ``:-)`` happy, ``;-)`` kidding, ``:-(`` sad, ``>:-<`` angry, ``:-o`` surprised and a
sixth emoticon for *disgusted* whose mouth character the thesis' text extraction lost (the cell reads
``: -``). The original table (Albrecht et al. 2002, "May I talk to you? :-)") could not be found in
the stored public material, so this module uses ``:-|``: a vertical bar is exactly the character a
table extraction drops as a column separator, and the flat mouth is the usual "unimpressed" face.

Accepted spellings: the compact form (``:-)``), the spaced form the thesis prints (``: - )``, with any
spaces or tabs around the nose), and the nose-less ``:)``, ``:(``, ``;)``. A mouth letter (``o``) must
not be followed by a letter or digit, so ``:-on`` is not an emoticon.

Emoticon-like tokens that are not in Table 4.1 (``:-P``, ``:D``, ``XD``, ``<3``, ``^_^``, ...) have no
emotion in the thesis; :func:`blank_unknown_emoticons` blanks them too (espeak-ng would otherwise read
``:-P`` as the letter "P") and names them, so the take says what it left out.

Emoticons are *blanked* (replaced by spaces of the same length), not deleted, so character offsets in
the cleaned text equal offsets in the original text and words on both sides stay separate.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

# (canonical emoticon, emotion) in the order of thesis Table 4.1
TABLE_4_1 = (
    (":-)", "happy"),
    (";-)", "kidding"),
    (":-(", "sad"),
    (">:-<", "angry"),
    (":-o", "surprised"),
    (":-|", "disgusted"),
)

_GAP = r"[ \t]*"
_PATTERNS = [
    (">:-<", "angry", rf">{_GAP}:{_GAP}-{_GAP}<"),
    (":-)", "happy", rf":{_GAP}-{_GAP}\)|:\)"),
    (";-)", "kidding", rf";{_GAP}-{_GAP}\)|;\)"),
    (":-(", "sad", rf":{_GAP}-{_GAP}\(|:\((?![^\s)]*\))"),
    (":-o", "surprised", rf":{_GAP}-{_GAP}[oO0](?![\w])"),
    (":-|", "disgusted", rf":{_GAP}-{_GAP}\|"),
]
_REGEX = re.compile("|".join(f"(?P<e{i}>{p})" for i, (_, _, p) in enumerate(_PATTERNS)))


@dataclass(frozen=True)
class EmotionTag:
    """An emoticon found in the input (thesis 4.3.2, 4.3.5): ``emotion`` is the Table 4.1 name,
    ``text_start``/``text_end`` its span in the ORIGINAL text, ``time`` (seconds) the apex once the
    words are timed (None before that), and ``previous_word``/``next_word`` the indices of the words
    around it in the utterance (-1 if none)."""

    emotion: str
    emoticon: str
    text_start: int
    text_end: int
    time: float | None = None
    previous_word: int = -1
    next_word: int = -1


def extract_emoticons(text: str) -> tuple[str, list[EmotionTag]]:
    """Return ``(text with every emoticon blanked to spaces, emotion tags in text order)``."""
    tags: list[EmotionTag] = []
    pieces: list[str] = []
    last = 0
    for match in _REGEX.finditer(text):
        index = int(match.lastgroup[1:])
        emoticon, emotion, _ = _PATTERNS[index]
        tags.append(EmotionTag(emotion, emoticon, match.start(), match.end()))
        pieces.append(text[last:match.start()])
        pieces.append(" " * (match.end() - match.start()))
        last = match.end()
    pieces.append(text[last:])
    return "".join(pieces), tags


_UNKNOWN = re.compile(
    r"(?<!\S)(?:>?[:;=][-^'o]?[()\[\]{}|/\\DPpSsOo0*@$&#Xx3<>]+|[xX][dD]+|<+/?3+|\^+_*\^+|[Tt]_+[Tt]"
    r"|[oO]_+[oO]|-_+-)(?=[\s.,!?]|$)")


def blank_unknown_emoticons(text: str) -> tuple[str, list[str]]:
    """``text`` with every emoticon-like token that Table 4.1 does not list blanked to spaces (run it after
    :func:`extract_emoticons`), and those tokens in text order."""
    found = [m.group(0) for m in _UNKNOWN.finditer(text)]
    return _UNKNOWN.sub(lambda m: " " * len(m.group(0)), text), found


def unknown_emoticon_warning(tokens: list[str]) -> str:
    """One line naming the emoticons that were left out and the ones that are known."""
    known = " ".join(e for e, _ in TABLE_4_1)
    return (f"not emoticons of Table 4.1, left out (not spoken, no emotion): {' '.join(dict.fromkeys(tokens))}; "
            f"known: {known}")
