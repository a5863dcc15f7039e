# SPDX-License-Identifier: GPL-3.0-or-later
"""Heads nobody here tuned on (issue 33 items 1-2; thesis 3.1.2 "Creating New Animatable Head Models from the
Template"). ``population_h29`` is a head of the held-out set of ``bench/population.py`` (written by
scripts/population_heads.py: MPFB2 with its macro and face-region targets, CC0; a face mask in centimetres,
face along -X, top along +Z), never looked at while tuning; ``makehuman_neutral`` the MPFB2 base head the
whole-person character is made from. Their shape-audit totals (of the 52 ARKit shapes and 15 visemes) are a
ratchet: they may rise, never fall. A head without its face is refused, not fitted."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from faces_hands_addon.core.errors import UserError
from faces_hands_addon.face.audit_targets import audit_shapes
from faces_hands_addon.face.expressions import load_expressions
from faces_hands_addon.face.fitted import build_fitted_rig

HEADS = Path(__file__).resolve().parents[2] / "data" / "heads"
# shapes of 67 meeting every target, measured when pinned (raise them when a change adds shapes; a change that
# loses one needs its reason in the commit): population_h29 11 before its eye openings were found on a narrow
# face (eye_openings.DEPTH_STEPS). The pin is the lowest over the Blender lines: makehuman_neutral meets 63 with
# numpy 1.26 (Python 3.11) and with numpy 2.5 (Python 3.13) since six shapes' contraction levels were chosen on the
# tuning heads (presets/SOURCES.md; 59 and 58 before)
PINNED = {"population_h29": 46, "makehuman_neutral": 63}


def _head(name):
    data = np.load(HEADS / f"{name}.npz")
    return data["vertices"].astype(np.float64), data["faces"].astype(np.int64)


def _audit(name):
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    expressions = {**load_expressions("arkit"), **load_expressions("visemes")}
    return rig, audit_shapes(rig, expressions)


@pytest.fixture(scope="module")
def heldout():
    return _audit("population_h29")


def test_the_heldout_head_is_what_the_population_script_writes():
    """The committed head is the held-out set's h29 (its spec says so), a face mask in its own units and axes."""
    spec = json.loads(str(np.load(HEADS / "population_h29.npz")["spec"]))
    assert (spec["set"], spec["name"], spec["crop"], spec["units"], spec["forward"], spec["up"]) == \
        ("heldout", "h29", "mask", "cm", "-X", "+Z")


@pytest.mark.parametrize("name", sorted(PINNED))
def test_shape_audit_totals_never_fall(name, heldout):
    """Every head keeps at least as many of the 67 shapes meeting all their targets as when it was pinned."""
    _, report = heldout if name == "population_h29" else _audit(name)
    rows = report["rows"]
    assert len(rows) == 67
    met = sum(1 for _, failed in rows.values() if not failed)
    assert met >= PINNED[name], (met, {shape: failed for shape, (_, failed) in rows.items() if failed})


def test_heldout_head_blinks_closed(heldout):
    """eyeBlinkLeft/Right close their eye on the held-out head: the lid gap under 0.5 mm and no iris seen from
    the front. Its eye openings are found (before, the hollow behind its lids ran off the view through the outer
    canthus of its narrow face: both eyes 'cannot open or close', blink 5.1 mm open)."""
    rig, report = heldout
    assert not [w for w in rig.warnings if "eyelids" in w], rig.warnings
    for shape, side in (("eyeBlinkLeft", "L"), ("eyeBlinkRight", "R")):
        figures, _ = report["rows"][shape]
        assert report["neutral"][f"gap_{side}"] > 5.0, report["neutral"][f"gap_{side}"]
        assert figures[f"gap_{side}"] <= 0.5 and figures[f"iris_{side}"] == 0, (shape, figures[f"gap_{side}"])


@pytest.mark.parametrize("part", ["back of the head", "neck"])
def test_a_head_without_its_face_is_refused(part):
    """The back half of the MPFB2 head, or its neck alone, is no face: fitting refuses it with a message that
    says why, instead of building a rig on whatever looked most like a face."""
    vertices, faces = _head("makehuman_neutral")
    depth, height = vertices[:, 2], vertices[:, 1]           # Y up, face along +Z
    if part == "back of the head":
        keep = depth < depth.min() + 0.45 * np.ptp(depth)
    else:
        keep = height < height.min() + 0.3 * np.ptp(height)
    faces = faces[keep[faces].all(axis=1)]
    used, faces = np.unique(faces, return_inverse=True)
    with pytest.raises(UserError, match="does not look like a human face|could not"):
        build_fitted_rig(vertices[used], faces.reshape(-1, 3), seed=0)
