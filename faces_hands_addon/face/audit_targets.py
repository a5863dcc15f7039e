# SPDX-License-Identifier: GPL-3.0-or-later
"""Targets of the shape audit (:mod:`.audit`) and the audit itself: per ARKit shape, viseme and named
emotion, the figures it must reach (mm, degrees, counts). Where the numbers come from and how sure each is:
``bench/shape_targets.md`` (FACS action units as in presets/SOURCES.md; brow excursion Cruz & Cruz 2004;
smile width and corner angle; interincisal opening; incisor show at rest).

A check is ``(key, low, high, relative)``: the figure ``key`` (``{S}`` = the shape's own side, ``{O}`` the
other) must lie in [low, high]; ``relative`` True compares it to the settled neutral's value, ``REST`` to the
mesh as modelled: the figure may not exceed ``max(high, modelled + REST_STEP)``. Silence is the face at
rest (its articulation sets every muscle to 0) and fitting keeps the artist's mesh as the rest (3.1.2), so a
head modelled with parted lips shows that opening in silence; the check asks that the rig open the lips and
show the teeth no further than modelled (within the audit's 0.5 mm sampling step) and is never laxer than
``high`` (a head modelled with its lips together is held to the same 1 mm). Every shape also
has no inverted triangle and no lip node inside a tooth, moves (unless it is the neutral), and is
left/right symmetric (symmetric shapes: its own mirror; one-sided shapes: against its other side's shape).
"""
from __future__ import annotations

import numpy as np

from .audit import Probe, measure, pair_asymmetry, settle_expression

__all__ = ["TARGETS", "shape_targets", "audit_shapes", "check"]

INF = float("inf")
REST = "rest"                # a check against the rest mesh as modelled (module docstring)
REST_STEP = 0.5              # mm: the teeth-shown sample spacing (audit._shown), the tolerance over the modelled rest
ASYM_MM = 1.0                # 95th percentile of the left/right displacement difference


def _one_sided() -> dict[str, list]:
    """Targets of the Left shapes ({S} = L, {O} = R); the Right ones are their mirror images."""
    return {
        "eyeBlink": [("gap_{S}", -INF, 0.3, False), ("iris_{S}", -INF, 0, False), ("gap_{O}", -1.0, INF, True)],
        "eyeSquint": [("gap_{S}", -INF, -1.5, True), ("gap_{S}", 1.0, INF, False)],
        "eyeWide": [("gap_{S}", 1.0, INF, True)],
        "browDown": [("brow_in_{S}", -INF, -2.5, False), ("brow_in_{O}", -1.5, INF, False)],
        "browOuterUp": [("brow_out_{S}", 5.0, INF, False), ("brow_out_{O}", -INF, 1.5, False)],
        "cheekSquint": [("lowlid_up_{S}", 1.0, INF, False)],
        "mouthSmile": [("corner_{S}", 6.0, INF, False), ("corner_up_{S}", 2.5, INF, False),
                       ("corner_out_{S}", 2.5, INF, False), ("corner_{O}", -INF, 2.0, False)],
        "mouthFrown": [("corner_up_{S}", -INF, -2.0, False)],
        "mouthStretch": [("corner_out_{S}", 3.0, INF, False)],
        "mouthDimple": [("corner_{S}", 2.0, INF, False)],
        "mouthLowerDown": [("lower_lip_up", -INF, -1.0, False)],
        "mouthUpperUp": [("upper_lip_up", 1.0, INF, False)],
        "mouthPress": [("lip_gap", -INF, 0.5, False)],
        "noseSneer": [("nose_up_{S}", 1.5, INF, False)],
    }


def _gaze() -> dict[str, list]:
    """Each look key turns its own eye >= 15 deg the right way and leaves the other eye still."""
    out = {}
    for eye, other in (("L", "R"), ("R", "L")):
        side = "Left" if eye == "L" else "Right"
        inward = -1.0 if eye == "L" else 1.0            # towards the nose
        for key, axis, sign in (("In", "yaw", inward), ("Out", "yaw", -inward), ("Up", "pitch", 1.0),
                                ("Down", "pitch", -1.0)):
            own = (f"{axis}_{eye}", 15.0, INF, False) if sign > 0 else (f"{axis}_{eye}", -INF, -15.0, False)
            out[f"eyeLook{key}{side}"] = [own, (f"yaw_{other}", -0.5, 0.5, False),
                                          (f"pitch_{other}", -0.5, 0.5, False)]
    return out


SYMMETRIC = {
    "browInnerUp": [("brow_in_L", 5.0, INF, False), ("brow_in_R", 5.0, INF, False)],
    "cheekPuff": [("cheek_L", 2.0, INF, False), ("cheek_R", 2.0, INF, False), ("lip_gap", -INF, 1.0, False)],
    "jawOpen": [("incisal", 38.0, 52.0, False)],
    "jawForward": [("jaw_y", -INF, -3.0, False)],
    "mouthClose": [("lip_gap", -INF, 0.5, False)],
    "mouthFunnel": [("protrusion", 3.0, INF, False), ("lip_gap", 3.0, INF, False), ("width", -INF, -5.0, True)],
    "mouthPucker": [("protrusion", 4.0, INF, False), ("width", -INF, -8.0, True), ("lip_gap", -INF, 2.0, False)],
    "mouthRollLower": [("lower_back", 1.0, INF, False)],
    "mouthRollUpper": [("upper_back", 1.0, INF, False)],
    "mouthShrugLower": [("lower_lip_up", 1.5, INF, False)],
    "mouthShrugUpper": [("upper_lip_up", 1.0, INF, False)],
    "tongueOut": [("tongue_out", 0.0, INF, False)],
    "viseme_sil": [("lip_gap", -INF, 1.0, REST), ("upper_show", -INF, 0.5, REST),
                   ("lower_show", -INF, 0.5, REST)],
    "viseme_PP": [("lip_gap", -INF, 0.3, False)],
    "viseme_FF": [("ff_dist", -INF, 2.5, False), ("upper_show", 1.0, INF, False)],
    "viseme_TH": [("tongue_front", 0.0, INF, False)],
    "viseme_DD": [("lip_gap", 1.0, INF, False), ("incisal", 2.0, 12.0, False)],
    "viseme_kk": [("lip_gap", 1.0, INF, False), ("incisal", 4.0, 15.0, False)],
    "viseme_CH": [("protrusion", 2.0, INF, False)],
    "viseme_SS": [("incisal", -INF, 4.0, False), ("width", 1.0, INF, True)],
    "viseme_nn": [("lip_gap", 1.0, INF, False)],
    "viseme_RR": [("protrusion", 1.5, INF, False)],
    "viseme_aa": [("incisal", 12.0, 30.0, False), ("lip_gap", 10.0, INF, False), ("upper_show", 1.0, INF, False),
                  ("lower_show", -INF, 4.0, False)],
    "viseme_E": [("width", 3.0, INF, True), ("lip_gap", 3.0, INF, False)],
    "viseme_ih": [("width", 2.0, INF, True)],
    "viseme_oh": [("width", -INF, -4.0, True), ("lip_gap", 4.0, INF, False), ("protrusion", 2.0, INF, False)],
    "viseme_ou": [("width", -INF, -8.0, True), ("protrusion", 3.0, INF, False), ("lip_gap", 1.5, 8.0, False)],
    "smile": [("corner_up_L", 2.5, INF, False), ("corner_up_R", 2.5, INF, False)],
    "frown": [("corner_up_L", -INF, -1.5, False), ("corner_up_R", -INF, -1.5, False)],
    "surprise": [("brow_mid_L", 5.0, INF, False), ("brow_mid_R", 5.0, INF, False), ("incisal", 15.0, INF, False)],
    "sadness": [("brow_in_L", 2.0, INF, False), ("brow_in_R", 2.0, INF, False), ("corner_up_L", -INF, -1.0, False)],
    "anger": [("brow_in_L", -INF, -2.0, False), ("brow_in_R", -INF, -2.0, False)],
    "disgust": [("nose_up_L", 1.5, INF, False), ("nose_up_R", 1.5, INF, False)],
    "fear": [("brow_in_L", 3.0, INF, False), ("brow_in_R", 3.0, INF, False), ("corner_out_L", 1.5, INF, False)],
}
ONE_SIDED_JAW = {"jawLeft": [("jaw_x", 3.0, INF, False)], "jawRight": [("jaw_x", -INF, -3.0, False)],
                 "mouthLeft": [("corner_out_L", 2.0, INF, False), ("corner_out_R", -INF, -2.0, False)],
                 "mouthRight": [("corner_out_R", 2.0, INF, False), ("corner_out_L", -INF, -2.0, False)]}


def shape_targets() -> dict[str, list]:
    """Shape name -> its checks (keys resolved to sides)."""
    out = {}
    for base, checks in _one_sided().items():
        for side, own, other in (("Left", "L", "R"), ("Right", "R", "L")):
            out[base + side] = [(k.format(S=own, O=other), lo, hi, rel) for k, lo, hi, rel in checks]
    out.update(_gaze())
    out.update(SYMMETRIC)
    out.update(ONE_SIDED_JAW)
    return out


TARGETS = shape_targets()


def mirror_name(name: str) -> str | None:
    """The other side's shape (``mouthSmileLeft`` -> ``mouthSmileRight``); None for symmetric ones."""
    for a, b in (("Left", "Right"), ("Right", "Left")):
        if name.endswith(a):
            return name[: -len(a)] + b
    return None


def check(name: str, m: dict, neutral: dict, pair_asym: float | None, rest: dict | None = None) -> list[str]:
    """Failed checks of shape ``name`` (empty: the shape meets its targets), as readable strings; ``rest``:
    the figures of the rest mesh as modelled (checks marked ``REST``; without it they count from 0, a head
    modelled with its lips together and its teeth hidden)."""
    failed = []
    for key, lo, hi, rel in TARGETS.get(name, []):
        if rel == REST:
            value = m[key]
            hi = hi if rest is None else max(hi, rest[key] + REST_STEP)
        else:
            value = m[key] - neutral[key] if rel else m[key]
        if not lo <= value <= hi:
            bound = f">={lo:g}" if value < lo else f"<={hi:g}"
            failed.append(f"{'d' if rel is True else ''}{key}={value:.1f} (want {bound})")
    if m["inverted"] > 0:
        failed.append(f"inverted={m['inverted']:.0f}")
    if m["lip_in_teeth"] > 0:
        failed.append(f"lip_in_teeth={m['lip_in_teeth']:.0f}")
    if name != "viseme_sil" and m["move99"] < 1.0 and not name.startswith(("eyeLook", "jaw", "tongue")):
        failed.append(f"move99={m['move99']:.1f} (want >=1)")
    asym = m["asym95"] if pair_asym is None else pair_asym
    if asym > ASYM_MM:
        failed.append(f"asym95={asym:.1f} (want <={ASYM_MM:g})")
    return failed


def audit_shapes(rig, expressions: dict[str, dict[str, float]], names=None, progress=None) -> dict:
    """Settle and measure ``names`` (default: every expression with targets) on ``rig``; returns
    ``{"neutral": figures, "rows": {name: (figures, failed checks)}}``."""
    probe = Probe(rig)
    rig.reset()                        # the rest mesh with the jaw, eyes and tongue at rest
    modelled = {k: v for k, v in measure(probe, probe.rest, probe.rest).items() if k != "_disp"}
    base = settle_expression(rig, {})
    neutral = measure(probe, base, probe.rest)
    figures = {"__neutral__": neutral}
    wanted = [n for n in (names or TARGETS) if n in expressions and n in TARGETS]
    for i, name in enumerate(wanted):
        pos = settle_expression(rig, expressions[name])
        figures[name] = measure(probe, pos, base)
        if progress:
            progress(i + 1, len(wanted), name)
    rows = {}
    for name in wanted:
        other = mirror_name(name)
        pair = None
        if other and other in figures:
            pair = pair_asymmetry(probe, figures[name]["_disp"], figures[other]["_disp"])
        rows[name] = (figures[name], check(name, figures[name], neutral, pair, modelled))
    neutral_failed = check("viseme_sil", measure(probe, base, base), neutral, None, modelled)
    return {"neutral": neutral, "rest": modelled, "rows": rows, "neutral_failed": neutral_failed, "probe": probe,
            "blink": np.array([figures.get(n, neutral)[f"gap_{s}"] for n, s in
                               (("eyeBlinkLeft", "L"), ("eyeBlinkRight", "R"))])}
