"""Mouth cues in Rhubarb Lip Sync's TSV/JSON formats, from the utterance's timed phones."""
from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from faces_hands_addon import UserError
from faces_hands_addon.speech import synthesize
from faces_hands_addon.speech.cues import SHAPES, cue_format, cues_text, mouth_cues, shape_of_phone


def _phones(*items):
    return [SimpleNamespace(phone=p, start=s, duration=d) for p, s, d in items]


def test_hand_written_line_gives_rhubarbs_tsv_and_json():
    # "map" after 0.2 s of silence: m a p, then silence to 0.8 s (expected files written by hand)
    phones = _phones(("m", 0.2, 0.08), ("ae", 0.28, 0.15), ("p", 0.43, 0.07), ("sil", 0.5, 0.3))
    cues = mouth_cues(phones, 0.8)
    assert [(round(c.start, 2), round(c.end, 2), c.shape) for c in cues] == [
        (0.0, 0.2, "X"), (0.2, 0.28, "A"), (0.28, 0.43, "C"), (0.43, 0.5, "A"), (0.5, 0.8, "X")]
    assert cues_text(cues, "tsv") == "0.00\tX\n0.20\tA\n0.28\tC\n0.43\tA\n0.50\tX\n"
    document = json.loads(cues_text(cues, "json", "map.wav", 0.8))
    assert document["metadata"] == {"soundFile": "map.wav", "duration": 0.8}
    assert document["mouthCues"][1] == {"start": 0.2, "end": 0.28, "value": "A"}
    # the last shape is not the rest shape: the TSV closes with the rest shape at the end
    assert cues_text(mouth_cues(phones[:3], 0.5), "tsv").endswith("0.43\tA\n0.50\tX\n")


def test_basic_shapes_only_without_extended():
    phones = _phones(("f", 0.0, 0.1), ("l", 0.1, 0.1), ("sil", 0.2, 0.1))
    assert [c.shape for c in mouth_cues(phones, 0.3)] == ["G", "H", "X"]
    assert set(c.shape for c in mouth_cues(phones, 0.3, extended=False)) <= set("ABCDEF")


def test_shapes_of_the_rhubarb_examples():
    # Rhubarb's shape table: A = P B M, D = AA, E = AO/ER, F = UW/OW/W, G = F V, H = L, B = K S T / EE
    expected = {"p": "A", "b": "A", "m": "A", "aa": "D", "ao": "E", "er": "E", "uw": "F", "ow": "F",
                "w": "F", "f": "G", "v": "G", "l": "H", "k": "B", "s": "B", "t": "B", "iy": "B", "eh": "C",
                "ae": "C", "sil": "X"}
    got = {p: shape_of_phone(p) for p in expected}
    mismatched = {p: (got[p], s) for p, s in expected.items() if got[p] != s}
    assert not mismatched
    assert all(shape_of_phone(p) in SHAPES for p in expected)


def test_every_bilabial_of_a_synthesised_line_gets_a_closed_cue():
    # ground truth: espeak-ng's own segment times of each /p b m/ (the synthesiser, not this module)
    utterance = synthesize("Papa made a map, and Bob bought a bumpy boat by the bay.")
    cues = mouth_cues(utterance.phones, utterance.duration)
    bilabials = [p for p in utterance.phones if p.phone in ("p", "b", "m")]
    assert len(bilabials) >= 12
    for phone in bilabials:
        centre = phone.start + phone.duration / 2
        shape = next(c.shape for c in cues if c.start <= centre < c.end)
        assert shape == "A", (phone, shape)
    assert cues[0].start == 0.0 and cues[-1].end == pytest.approx(utterance.duration)
    assert all(abs(a.end - b.start) < 1e-9 for a, b in zip(cues, cues[1:]))
    assert all(a.shape != b.shape for a, b in zip(cues, cues[1:]))


def test_cue_file_names():
    assert cue_format("a.tsv") == "tsv" and cue_format("a.TXT") == "tsv" and cue_format("b.json") == "json"
    with pytest.raises(UserError, match="tsv"):
        cue_format("c.csv")
    with pytest.raises(UserError, match="format"):
        cues_text([], "xml")
