"""Unified phone inventory (ARPAbet, espeak, SAMPA, IPA -> one set -> visemes) and the emoticons of
thesis Table 4.1."""
from __future__ import annotations

import pytest

from faces_hands_addon import UserError
from faces_hands_addon.speech import (TABLE_4_1, VISEMES, extract_emoticons, from_arpabet, from_espeak,
                                      from_ipa, from_sampa, synthesize, to_arpabet, viseme_of)
from faces_hands_addon.speech.phonemes import PHONES

CMU_39 = ("AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R S SH T TH UH UW "
          "V W Y Z ZH").split()


def test_every_phone_has_a_viseme_and_an_arpabet_pronunciation():
    assert len(VISEMES) == 15 and VISEMES[0] == "viseme_sil"
    for name, info in PHONES.items():
        assert info.viseme in VISEMES
        assert all(a in CMU_39 for a in to_arpabet([name])), name
        if info.glide_to:
            assert PHONES[info.glide_to].kind == "vowel"


def test_arpabet_round_trip():
    for symbol in CMU_39:
        (unified,) = from_arpabet(symbol + ("1" if symbol in ("AA", "IY") else ""))
        assert to_arpabet([unified]) == [symbol]
    assert from_arpabet("+NSN+") == ("sil",) and from_arpabet("SIL") == ("sil",)
    with pytest.raises(UserError):
        from_arpabet("QQ")


@pytest.mark.parametrize("phone, viseme", [
    ("p", "viseme_PP"), ("b", "viseme_PP"), ("m", "viseme_PP"), ("f", "viseme_FF"), ("v", "viseme_FF"),
    ("th", "viseme_TH"), ("t", "viseme_DD"), ("k", "viseme_kk"), ("ch", "viseme_CH"), ("sh", "viseme_CH"),
    ("s", "viseme_SS"), ("n", "viseme_nn"), ("l", "viseme_nn"), ("r", "viseme_RR"), ("aa", "viseme_aa"),
    ("eh", "viseme_E"), ("ih", "viseme_ih"), ("ow", "viseme_oh"), ("uh", "viseme_ou"), ("sil", "viseme_sil"),
])
def test_published_viseme_table(phone, viseme):
    assert viseme_of(phone) == viseme


@pytest.mark.parametrize("reader, symbol, expected", [
    (from_ipa, "ˈaɪ", ("ay",)), (from_ipa, "t͡ʃ", ("ch",)), (from_ipa, "ç", ("xj",)), (from_ipa, "ʁ", ("rx",)),
    (from_ipa, "həˈloʊ", ("hh", "ax", "l", "ow")), (from_ipa, "yː", ("ue",)), (from_ipa, "", ("sil",)),
    (from_sampa, "tS", ("ch",)), (from_sampa, "\"aI", ("ay",)), (from_sampa, "2:", ("oe",)),
    (from_sampa, "{", ("ae",)), (from_sampa, "OY", ("oy",)),
    (from_espeak, "'aI", ("ay",)), (from_espeak, ",i:", ("iy",)), (from_espeak, "@2", ("ax",)),
    (from_espeak, "_:", ("sil",)), (from_espeak, "t#", ("d",)), (from_espeak, "a", ("ae",)),
])
def test_symbol_readers(reader, symbol, expected):
    assert reader(symbol) == expected


def test_german_espeak_names_use_the_german_table():
    assert from_espeak("a", "de") == ("a",)
    assert from_espeak("C", "de") == ("xj",)
    assert from_espeak("y:", "de") == ("ue",)
    assert from_espeak("d;", "ru") == ("d",)  # palatalisation mark dropped for other languages


@pytest.mark.parametrize("voice, text", [
    ("en-us", "Can you show me the way to the conference hall? Thought, judge, pleasure, boy, cow."),
    ("de", "Es gingen zwei Parallelen ins Endlose hinaus. Bücher, Häuser, Lichtjahre, ach, Pferd."),
])
def test_espeak_names_and_ipa_names_agree(voice, text):
    """Both ways into the inventory (espeak's names, used as symbols, and its IPA, used for mapping)
    land on the same viseme for nearly every phone espeak produces."""
    u = synthesize(text, voice=voice)
    same = [viseme_of(from_espeak(p.symbol, voice)[0]) == viseme_of(p.phone) for p in u.phones if not p.is_pause]
    assert sum(same) / len(same) > 0.85


def test_table_4_1_emoticons():
    text = ":-) a ;-) b :-( c >:-< d :-o e :-| f"
    cleaned, tags = extract_emoticons(text)
    assert [t.emotion for t in tags] == [e for _, e in TABLE_4_1]
    assert len(cleaned) == len(text) and cleaned.split() == list("abcdef")
    for tag in tags:
        assert text[tag.text_start:tag.text_end].replace(" ", "") == tag.emoticon


def test_spaced_and_noseless_emoticons():
    text = "ins ; - ) Endlose : - ( Grab: : - ( ) nicht : - o irdisch :) x :( ;)"
    cleaned, tags = extract_emoticons(text)
    assert [t.emotion for t in tags] == ["kidding", "sad", "sad", "surprised", "happy", "sad", "kidding"]
    assert "Grab:" in cleaned and "irdisch" in cleaned


def test_text_that_only_looks_like_emoticons_is_kept():
    for text in ["Sie wußtens selber nicht, -", "ratio 3:-2", "turn :-on now", "see (a):(b) ok"]:
        cleaned, tags = extract_emoticons(text)
        assert tags == [] and cleaned == text


def test_unknown_emoticons_are_blanked_and_named():
    from faces_hands_addon.speech.emoticons import blank_unknown_emoticons, extract_emoticons
    text = "Hi! :-P Can you XD see <3 the hall? :-D ;-) items 1) and 8) stay, so do :-o and x-ray."
    cleaned, tags = extract_emoticons(text)
    cleaned, unknown = blank_unknown_emoticons(cleaned)
    assert unknown == [":-P", "XD", "<3", ":-D"]
    assert [t.emoticon for t in tags] == [";-)", ":-o"]
    assert len(cleaned) == len(text) and "1) and 8) stay" in cleaned and "x-ray" in cleaned
    assert "P" not in cleaned.split() and "XD" not in cleaned
