"""Lip sync on the face rig (thesis 3.1.3 "MEDUSA Rises to Speak").

The whole engine pipeline -- espeak-ng speech, Cohen-Massaro coarticulation with the shipped
``presets/speech/articulation.json``, the default MEDUSA head settled from rest with the coarticulated
controls -- must give the visemes as geometry, at the frames the contact sheet shows (phone centres,
read from the tracks like the sheet and Blender's F-curves do) and at the closure key frames of 3.1.3:
/p b m/ closed, open vowels open, /u/ narrow and protruded against a spread /i/, /f v/ lower lip at the
upper teeth, and a short vowel undershot against a long one. The 15 viseme expression presets
(``presets/expressions/visemes.json``) are checked the same way.

Measured on the skin's canonical nodes (the skin keeps the MediaPipe canonical indices): 13 / 14 are the
upper / lower inner lip at the mouth centre, 61 / 291 the mouth corners, 0 / 17 the outer lip centres.
Axes (CONTRIBUTING.md): metres, Z up, the face looks along -Y.
"""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.face.audit import Probe, measure
from faces_hands_addon.face.expressions import expression_controls, load_expressions
from faces_hands_addon.face.rig import build_default_rig
from faces_hands_addon.speech import coarticulate, load_articulation, synthesize

MM = 1000.0
UPPER_INNER, LOWER_INNER = 13, 14
CORNERS = (61, 291)
LIP_PROFILE = (0, 13, 14, 17)
SETTLE = 1.2  # s, as the contact sheet settles each cell
FPS = 30.0

SENTENCES = (
    "Can you show me the way to the conference hall?",   # the thesis' example: /m/, /f/, /aa/, /uw/
    "Peter Piper picked a peck.",                         # /p/ closures between vowels
    "Five very fine violins.",                            # /f v/ away from bilabials
    "Who would go to the zoo? Old blue boots.",           # long /uw/, /b/
    "Father saw a large hot car.",                        # /aa/ short and long
    "Sit, see, eat.",                                     # long /iy/
)
WANTED = {"p", "b", "m", "f", "v", "aa", "uw", "iy"}


@pytest.fixture(scope="module")
def rig():
    return build_default_rig("default")


@pytest.fixture(scope="module")
def mouth(rig):
    """Rest geometry and the upper incisal edge (lowest point of the upper front teeth)."""
    teeth = rig.template.organs.parts["teeth_upper"].vertices
    front = teeth[np.abs(teeth[:, 0]) < 0.005]
    skin = rig.template.skin
    upper, lower = skin.contours["lips_inner_upper"], skin.contours["lips_inner_lower"]
    third = len(upper) // 3
    return {"rest": rig.template.skin.vertices.astype(float), "edge": float(front[:, 2].min()),
            "upper": upper[third:len(upper) - third], "lower": lower[third:len(lower) - third],
            "probe": Probe(rig)}


def geometry(positions: np.ndarray, mouth: dict) -> dict[str, float]:
    """Lip measures in mm: ``gap`` the vertical inner-lip opening at the centre, ``gap_central`` its largest
    value over the central third of the inner contour, ``width`` corner to corner, ``forward`` how far the
    lip profile moved along -Y from rest, ``lower_to_edge`` / ``upper_to_edge`` the inner lips' height
    above the upper incisal edge, ``lower_back`` how far the lower lip moved back (+Y) from rest."""
    p, rest = np.asarray(positions, dtype=float), mouth["rest"]
    profile = list(LIP_PROFILE)
    return {
        "gap": (p[UPPER_INNER, 2] - p[LOWER_INNER, 2]) * MM,
        "gap_central": float((p[mouth["upper"], 2] - p[mouth["lower"], 2]).max()) * MM,
        "width": (p[CORNERS[1], 0] - p[CORNERS[0], 0]) * MM,
        "forward": -(p[profile, 1].mean() - rest[profile, 1].mean()) * MM,
        "lower_to_edge": (p[LOWER_INNER, 2] - mouth["edge"]) * MM,
        "upper_to_edge": (p[UPPER_INNER, 2] - mouth["edge"]) * MM,
        "lower_back": (p[LOWER_INNER, 1] - rest[LOWER_INNER, 1]) * MM,
    }


def settled(rig, mouth, controls: dict[str, float]) -> dict[str, float]:
    """:func:`geometry` of the settled face, plus what the shape audit sees (``face.audit.measure``):
    ``teeth_shown`` the incisor height (mm) visible from the front, upper plus lower, and ``lip_to_incisor``
    the lower lip's distance to the upper incisal edge."""
    positions = rig.settled({"ctrl": controls}, SETTLE).positions["skin"]
    seen = measure(mouth["probe"], np.asarray(positions, dtype=float))
    return {**geometry(positions, mouth), "teeth_shown": seen["upper_show"] + seen["lower_show"],
            "lip_to_incisor": seen["ff_dist"]}


@pytest.fixture(scope="module")
def frames(rig, mouth):
    """phone -> list of frames {sentence, word, duration, at ("centre" | "closure" | "release"), geometry}."""
    targets = load_articulation()
    out: dict[str, list[dict]] = {p: [] for p in WANTED}
    for sentence in SENTENCES:
        utterance = synthesize(sentence)
        result = coarticulate(utterance, targets, fps=FPS)
        for index, phone in enumerate(utterance.phones):
            if phone.phone not in WANTED or phone.is_pause:
                continue
            times = {"centre": phone.start + phone.duration / 2}
            phase = targets.phase(phone.phone)
            if phase != "normal":
                times["closure"] = phone.start   # the closure key frame (3.1.3)
                if phase == "closure_release":
                    times["release"] = phone.start + phone.duration * targets.closure_fraction
            neighbours = {p.phone for p in utterance.phones[max(index - 1, 0):index + 2]} - {phone.phone}
            for at, t in times.items():
                assert at == "centre" or np.isclose(result.key_times, t).any()
                controls = {track.name: float(track.sample(t)) for track in result.tracks}
                out[phone.phone].append({"sentence": sentence, "duration": phone.duration, "at": at,
                                         "next_to_closure": any(targets.phase(n) != "normal" for n in neighbours),
                                         "geometry": settled(rig, mouth, controls)})
    missing = [p for p, found in out.items() if not found]
    assert not missing, f"espeak-ng gave none of {missing} in the test sentences"
    return out


def _describe(frame) -> str:
    g = ", ".join(f"{k}={v:.1f}" for k, v in frame["geometry"].items())
    return f"{frame['sentence']!r} at {frame['at']} ({frame['duration'] * 1000:.0f} ms): {g}"


def test_rest_mouth_is_closed_and_hides_the_teeth(rig, mouth):
    """Issue 10: the neutral is a closed, relaxed mouth (lips touching, no tooth visible), as settled."""
    rest = settled(rig, mouth, {})
    assert rest["gap_central"] < 1.0 and rest["teeth_shown"] == 0.0, rest


@pytest.mark.parametrize("phone", ["p", "b", "m"])
def test_bilabials_close_the_lips_completely(frames, phone):
    """3.1.3: "it is vital that the lips are fully closed" -- at the closure key frame and at the phone
    centre the contact sheet shows (a closure right after /f v/ shares its first key frame with it)."""
    for frame in frames[phone]:
        if frame["at"] == "closure" and frame["next_to_closure"]:
            continue
        if frame["at"] in ("closure", "centre"):
            assert frame["geometry"]["gap_central"] < 1.0, _describe(frame)
            assert frame["geometry"]["teeth_shown"] == 0.0, _describe(frame)   # the lips cover the teeth


def test_open_vowels_open_the_jaw(frames):
    for frame in frames["aa"]:
        assert frame["geometry"]["gap"] > 10.0, _describe(frame)


def test_short_vowels_are_undershot_on_the_rig(frames):
    """Coarticulation still blends: the shortest /aa/ opens less than the longest one."""
    ordered = sorted((f for f in frames["aa"] if f["sentence"].startswith("Father")), key=lambda f: f["duration"])
    assert ordered[0]["duration"] < 0.6 * ordered[-1]["duration"]
    assert ordered[0]["geometry"]["gap"] < ordered[-1]["geometry"]["gap"] - 2.0


def test_u_is_rounded_and_protruded_i_is_spread(frames, mouth):
    rest = geometry(mouth["rest"], mouth)
    long_u = [f for f in frames["uw"] if f["duration"] >= 0.08]
    long_i = [f for f in frames["iy"] if f["duration"] >= 0.1]
    assert long_u and long_i
    widest_u = max(f["geometry"]["width"] for f in long_u)
    narrowest_i = min(f["geometry"]["width"] for f in long_i)
    assert widest_u < narrowest_i - 4.0
    assert widest_u < rest["width"] - 2.0 < rest["width"] + 2.0 < narrowest_i
    for frame in long_u:
        assert frame["geometry"]["forward"] > 3.0, _describe(frame)       # lips forward (-Y)
        assert frame["geometry"]["gap"] < 6.0, _describe(frame)           # a small opening
    for frame in long_i:
        assert frame["geometry"]["forward"] < 0.5, _describe(frame)


@pytest.mark.parametrize("phone", ["f", "v"])
def test_labiodentals_put_the_lower_lip_to_the_upper_teeth(rig, frames, mouth, phone):
    """3.1.3: "for the fricatives /f/ and /v/, the lower lip must touch the teeth"."""
    rest = settled(rig, mouth, {})
    for frame in frames[phone]:
        if frame["next_to_closure"] and frame["at"] == "closure":
            continue
        g = frame["geometry"]
        assert -2.0 < g["lower_to_edge"] < 1.5, _describe(frame)            # at the incisal edge
        # brought to the upper incisors (the closed neutral's lower lip lies in front of and over them)
        assert g["lip_to_incisor"] < min(3.0, rest["lip_to_incisor"] - 1.0), _describe(frame)
        assert g["lower_back"] > 0.5, _describe(frame)                        # slightly retracted
        if frame["sentence"].startswith("Five"):
            assert g["upper_to_edge"] > 1.0, _describe(frame)   # upper teeth visible above the lower lip


def test_viseme_expression_presets_render_their_visemes(rig, mouth):
    visemes = load_expressions("visemes")
    specs = rig.control_specs()
    shape = {name: settled(rig, mouth, expression_controls(visemes[name], specs))
             for name in ("viseme_sil", "viseme_PP", "viseme_FF", "viseme_aa", "viseme_E", "viseme_ih",
                          "viseme_oh", "viseme_ou")}
    rest = geometry(mouth["rest"], mouth)
    assert abs(shape["viseme_sil"]["gap"] - rest["gap"]) < 0.1                 # neutral
    assert shape["viseme_PP"]["gap_central"] < 1.0                             # closed
    ff = shape["viseme_FF"]
    assert -2.0 < ff["lower_to_edge"] < 1.5 and ff["upper_to_edge"] > 1.0      # lower lip to the upper teeth
    assert shape["viseme_aa"]["gap"] > 20.0                                    # open
    for spread in ("viseme_E", "viseme_ih"):
        assert shape[spread]["width"] > rest["width"] + 2.0
    for rounded in ("viseme_oh", "viseme_ou"):
        assert shape[rounded]["forward"] > 3.0
        assert shape[rounded]["width"] < rest["width"] - 2.0 < shape["viseme_ih"]["width"] - 4.0
