"""Mouth cues in Rhubarb Lip Sync's TSV/JSON formats, from the utterance's timed phones."""
from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from faces_hands_addon import UserError
from faces_hands_addon.speech import synthesize
from faces_hands_addon.speech.cues import (SHAPES, cue_format, cue_weights, cues_text, mouth_cues, read_cues,
                                           shape_of_phone)


def _phones(*items):
    return [SimpleNamespace(phone=p, start=s, duration=d) for p, s, d in items]


def test_hand_written_line_gives_rhubarbs_tsv_and_json():
    # "map" after 0.2 s of silence: m a p, then silence to 0.8 s (expected files written by hand)
    phones = _phones(("m", 0.2, 0.08), ("ae", 0.28, 0.15), ("p", 0.43, 0.07), ("sil", 0.5, 0.3))
    cues = mouth_cues(phones, 0.8)
    assert [(round(c.start, 2), round(c.end, 2), c.shape) for c in cues] == [
        (0.0, 0.2, "X"), (0.2, 0.28, "A"), (0.28, 0.43, "C"), (0.43, 0.5, "A"), (0.5, 0.8, "X")]
    # the last line is the end (the rest shape from there on): without it the last cue's end is lost
    assert cues_text(cues, "tsv") == "0.00\tX\n0.20\tA\n0.28\tC\n0.43\tA\n0.50\tX\n0.80\tX\n"
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


@pytest.mark.parametrize("fmt", ["tsv", "json"])
def test_cues_read_back_as_written(tmp_path, fmt):
    """Every format we write, we read back (issue 33): the cues of a synthesised line, to the file's 10 ms."""
    utterance = synthesize("Papa made a map, and Bob bought a bumpy boat by the bay.")
    cues = mouth_cues(utterance.phones, utterance.duration)
    path = tmp_path / f"line.{fmt}"
    path.write_text(cues_text(cues, fmt, "line.wav", utterance.duration))
    back = read_cues(path)
    assert [(c.start, c.end, c.shape) for c in back] == [(round(c.start, 2), round(c.end, 2), c.shape) for c in cues]


def test_rhubarbs_own_tsv_and_bad_cue_files(tmp_path):
    rhubarb = tmp_path / "rhubarb.tsv"
    rhubarb.write_text("0.00\tX\n0.05\tD\n0.27\tC\n0.31\tB\n0.43\tX\n")
    cues = read_cues(rhubarb)
    assert [(c.start, c.end, c.shape) for c in cues] == [(0.0, 0.05, "X"), (0.05, 0.27, "D"), (0.27, 0.31, "C"),
                                                         (0.31, 0.43, "B")]
    frames, weights = cue_weights(cues, 100)
    assert len(frames) == 44 and weights["viseme_aa"][10] == 1.0 and weights["viseme_kk"][35] == 1.0
    assert all(sum(w[k] for w in weights.values()) == 1.0 for k in range(len(frames)))
    for text, message in (("0.00\tX\n0.10\tQ\n0.20\tX\n", "not a mouth shape"), ("0.00\tX\n0.1\n", "start<TAB>"),
                          ("0.30\tX\n0.10\tA\n0.20\tX\n", "not a span"), ("0.00\tX\n0.1\x000\tA\n", "NUL")):
        bad = tmp_path / "bad.tsv"
        bad.write_text(text)
        with pytest.raises(UserError, match=message):
            read_cues(bad)
