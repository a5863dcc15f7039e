# SPDX-License-Identifier: GPL-3.0-or-later
"""Heads someone else made (issue 10 item 4; thesis 3.1.2): the MakeHuman base mesh and NVIDIA's SOMA-X
topology (tests/data/heads, written by scripts/extract_test_heads.py; CC0 / Apache-2.0, see NOTICE), in
their own axes (Y up, face along +Z, decimetres / metres), turned and rescaled: found, fitted and passed by
the quality gate, with the landmarks on the features."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from faces_hands_addon.face.audit_targets import audit_shapes
from faces_hands_addon.face.expressions import load_expressions
from faces_hands_addon.face.fitted import build_fitted_rig, fit_head
from faces_hands_addon.face.skin import LIP_OVERLAP
from faces_hands_addon.face.template import CLOSED_LIP_COVER
from faces_hands_addon.fitting import locate_landmarks
from faces_hands_addon.fitting.template import NOSE_TIP, face_template

HEADS = Path(__file__).resolve().parents[2] / "data" / "heads"


def _head(name):
    data = np.load(HEADS / f"{name}.npz")
    return data["vertices"].astype(np.float64), data["faces"].astype(np.int64)


def _failed_targets(name, shapes, rig=None):
    """The shape audit's failed checks of ``shapes`` (ARKit, viseme or named) on head ``name`` fitted with
    seed 0, or on ``rig`` (empty: every target met)."""
    if rig is None:
        vertices, faces = _head(name)
        rig = build_fitted_rig(vertices, faces, seed=0)
    expressions = {key: value for kind in ("arkit", "visemes", "named")
                   for key, value in load_expressions(kind).items()}
    report = audit_shapes(rig, expressions, shapes)
    return {shape: report["rows"][shape][1] for shape in shapes if report["rows"][shape][1]}


@pytest.fixture(scope="module")
def neutral():
    vertices, faces = _head("makehuman_neutral")
    return vertices, faces, locate_landmarks(vertices, faces, seed=0)


def _features_in_place(fit, forward, up):
    """Nose tip in front, eyes above the mouth, the character's left eye on its left."""
    forward, up = np.asarray(forward, float), np.asarray(up, float)
    left = np.cross(up, forward)
    p = fit.positions
    contours = face_template().contours
    assert (p @ forward).argmax() in set(contours["nose_lower_outline"]) | {NOSE_TIP, 4, 5, 195, 197, 19, 94}
    eyes = 0.5 * (p[contours["eye_L"]].mean(0) + p[contours["eye_R"]].mean(0))
    mouth = p[[13, 14]].mean(0)
    assert (eyes - mouth) @ up > 0.2 * fit.face_width
    assert (p[contours["eye_L"]].mean(0) - p[contours["eye_R"]].mean(0)) @ left > 0.3 * fit.face_width


def test_makehuman_head_in_its_own_axes(neutral):
    _, _, fit = neutral
    assert fit.orientation["orientation"] == "forward +Z, up +Y" and fit.orientation["margin"] > 1.5
    assert all(c["ok"] for c in fit.checks)
    _features_in_place(fit, (0, 0, 1), (0, 1, 0))


def test_makehuman_head_turned_and_rescaled_gets_the_same_landmarks(neutral):
    vertices, faces, fit = neutral
    turn = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])       # 90 degrees about X: face -Y, top +Z
    moved = locate_landmarks(0.01 * vertices @ turn.T, faces, seed=0)
    assert moved.orientation["orientation"] == "forward -Y, up +Z"
    same = np.linalg.norm(moved.positions - 0.01 * fit.positions @ turn.T, axis=1) / moved.face_width
    # 1.5 % / 8 % of the face width: on a real head the inner lip and upper lid landmarks (over the mouth
    # and eye openings, placed by the template's stiffness) settle up to ~7 % apart from another start
    assert np.median(same) < 0.015 and same.max() < 0.08, (np.median(same), same.max())


@pytest.mark.parametrize("name", ["makehuman_african_female_old", "soma"])
def test_other_real_heads(name):
    vertices, faces = _head(name)
    fit = locate_landmarks(vertices, faces, seed=0)
    assert fit.orientation["orientation"] == "forward +Z, up +Y"
    assert all(c["ok"] for c in fit.checks), [c for c in fit.checks if not c["ok"]]
    _features_in_place(fit, (0, 0, 1), (0, 1, 0))


def test_makehuman_lid_landmarks_span_its_eye_opening(neutral):
    """The MakeHuman lids fold back into an eye socket (no hole): the registration alone put the upper
    lid landmarks on the lower lid's margin (159-145 4.7 mm and 386-374 3.0 mm apart, the opening is
    ~10 mm tall); they are moved onto the edges of the opening seen from the front."""
    _, _, fit = neutral
    p = fit.positions
    for upper, lower in ((159, 145), (386, 374)):
        height = (p[upper] - p[lower]) @ np.array([0.0, 1.0, 0.0])
        assert height > 0.06 * fit.face_width, (upper, lower, height / fit.face_width)


@pytest.mark.parametrize("name, unfolded", [("makehuman_neutral", True), ("soma", False)])
def test_fitted_real_heads_blink_closed(name, unfolded):
    """Issue 10: the eyes of a rig fitted to a head made by someone else close on eyeBlink (no 'eyelids
    cannot open or close' warning, open at rest, the lid gap gone and no iris seen from the front). On the
    MakeHuman head, whose lids fold back into a socket, the closed lids do not fold either: no inverted
    triangle beyond a few (10 and 13 when the eyeball sat in front of the mesh's lid margins and the socket
    lining was lifted over it; 0 or 2 now, depending on the machine's floating-point rounding). SOMA keeps 3
    on its right inner canthus (not asked yet)."""
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    assert not [w for w in rig.warnings if "eyelids" in w], rig.warnings
    report = audit_shapes(rig, load_expressions("arkit"), ("eyeBlinkLeft", "eyeBlinkRight"))
    for shape, side in (("eyeBlinkLeft", "L"), ("eyeBlinkRight", "R")):
        figures, _ = report["rows"][shape]
        assert report["neutral"][f"gap_{side}"] > 6.0, report["neutral"][f"gap_{side}"]
        assert figures[f"gap_{side}"] < 0.5 and figures[f"iris_{side}"] == 0, (shape, figures[f"gap_{side}"],
                                                                                figures[f"iris_{side}"])
        if unfolded:
            assert figures["inverted"] <= 3, (shape, figures["inverted"])


@pytest.mark.parametrize("name, shapes", [
    ("soma", ("mouthSmileLeft", "mouthSmileRight", "mouthStretchLeft", "mouthStretchRight", "mouthLeft",
              "mouthRight")),
    ("makehuman_african_female_old", ("mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight")),
])
def test_fitted_mouth_lining_is_not_face_skin(name, shapes):
    """Both heads model the mouth as a pocket behind the lips. Before the lining was found
    (``transfer._mouth_lining``), the pocket's skin at the commissures took the template's outer-skin
    groups; it was pulled with the face and folded: 1-6 inverted triangles in each of these shapes, which
    failed on that alone (the pairs are audited together for their symmetry). Now each meets every target."""
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    assert rig.fitted.transfer.lining is not None and len(rig.fitted.transfer.lining)
    failed = _failed_targets(name, shapes, rig)
    assert not failed, failed


def test_landmarks_do_not_depend_on_the_machines_core_count():
    """The same head gives the same landmarks (and so the same rig) with one or two BLAS threads. Before
    the fitting ran on one BLAS thread (``core.blas``), the MakeHuman head's landmarks moved by up to
    8.8 mm between the two, and its lips protruded 0.6 mm less in mouthPucker with two."""
    from threadpoolctl import ThreadpoolController
    vertices, faces = _head("makehuman_neutral")
    runs = []
    for threads in (1, 2):
        with ThreadpoolController().limit(limits=threads, user_api="blas"):
            runs.append(locate_landmarks(vertices, faces, seed=0).positions)
    assert np.array_equal(runs[0], runs[1]), np.abs(runs[0] - runs[1]).max()


@pytest.mark.parametrize("name, wanted", [
    ("soma", {"mouthPucker": 4.0, "viseme_RR": 1.5, "viseme_ou": 3.0, "mouthFunnel": 3.0, "viseme_CH": 2.0,
              "viseme_oh": 2.0}),
    ("makehuman_neutral", {"viseme_RR": 1.5, "viseme_CH": 2.0}),
])
def test_fitted_lips_protrude_as_far_as_their_targets(name, wanted):
    """An artist's head keeps its parted lips, and at an open lip margin the skin normal turns into the
    mouth: the orbicularis oris grid sunk along it ended inside the lip body (SOMA's inner fibre 4 mm below
    the lower margin), most lip vertices met the sheet at its inner border and took a reduced muscle weight,
    so the lips protruded 20-35 % less than on the default head (SOMA pucker 3.7, RR 1.4, ou 2.8 mm; MakeHuman
    RR 1.4). Sunk along the grid's own normal (``muscle_layout._sheet_normals``), these rounding shapes
    protrude at least as far as the audit asks (thesis 3.1.2, the oris' protrusion). The lip's middle rows
    follow the lip muscles' connections further (``muscles.BETWEEN_SCREEN``) and so give up some of their
    travel to them (SOMA mouthFunnel 2.99, viseme_CH 1.99-2.0, viseme_oh 1.9-2.0 mm with the oris' 8 mm
    forward travel); its 8.5 mm (presets/face/muscles.json) gives it back."""
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    report = audit_shapes(rig, load_expressions("arkit") | load_expressions("visemes"), tuple(wanted))
    got = {shape: round(report["rows"][shape][0]["protrusion"], 2) for shape in wanted}
    assert all(got[shape] >= wanted[shape] for shape in wanted), (got, wanted)


def test_parted_rest_lips_close_under_a_partial_oris():
    """The oris grid laid along its own surface (above) sits at the parted lip margins, nearer the ring's
    centre than when it sank into the lip body, so scaling towards the centre closed less of the rest
    opening: cheekPuff's 0.4 oris left the African head's lips 2.5 mm apart and anger folded the commissures.
    The ring now closes the rest opening at twice the rate of its squeeze (``MuscleSystem.set_rest_closing``;
    the same at full contraction), and both meet every target again."""
    shapes = ("cheekPuff", "anger")
    failed = _failed_targets("makehuman_african_female_old", shapes)
    assert not failed, failed


def test_fitted_brows_lower_without_folding():
    """The muscle field a fitted head takes over from the template kept the template's spread, steep for an
    artist's finer mesh at the brow's lower edge: SOMA nodes ~4 mm apart were pulled 1.0 and 4.7 mm by
    browDown and 4 triangles between brow and lid folded on each side (anger 10, fear and disgust 2). The
    field is spread further on the mesh itself away from the lips (``mesh_template._spread_over_the_brows``,
    thesis 3.1.2 Fig. 3.4): these shapes meet every target, the inverted-triangle count included."""
    shapes = ("browDownLeft", "browDownRight", "browInnerUp", "fear", "disgust")
    failed = _failed_targets("soma", shapes)
    assert not failed, failed


def test_fitted_disgust_keeps_the_nasolabial_crease_from_folding():
    """SOMA models a crease beside the ala; disgust's levator labii superioris raises the upper lip beside it
    and the compressed skin buckles there. At 0.4 (with the oris' middle following the lip muscles,
    ``muscles.BETWEEN_SCREEN``) its worst triangle kept 0.008 of its rest normal here and turned over under
    another numpy build (bpy 5.2.3); at 0.3 (presets/expressions/named.json) it keeps 0.22 and the nose still
    rises 5.8 mm (target 1.5). Every outer triangle keeps at least 0.1 of its rest normal."""
    from faces_hands_addon.face.audit import Probe, _face_normals, settle_expression
    vertices, faces = _head("soma")
    rig = build_fitted_rig(vertices, faces, seed=0)
    probe = Probe(rig)
    pos = settle_expression(rig, load_expressions("named")["disgust"])
    kept = np.einsum("ij,ij->i", _face_normals(pos, probe.faces), probe.rest_normals)[probe.outside]
    assert kept.min() > 0.1, f"worst outer triangle keeps {kept.min():.3f} of its rest normal"


def test_fitted_canthus_slivers_do_not_flip():
    """SOMA's inner canthus has sliver triangles: two vertices 0.2 mm apart (one edge 0.2 mm), and flat caps
    whose corner lies 0.1-0.2 mm from the opposite edge.
    - The canthus nodes' lid targets barely move (the canthal tie), but their attachment was the weakest
      around the eye (its gain falls with the lid weight), so the closing upper lid dragged one node 0.1 mm
      past its neighbour and the triangle flipped in blink and eyeWide. The canthal tendons now hold those
      nodes firmly (``LidRig.canthus_tie``, thesis 3.1.2 "Eyes, Teeth, Tongue").
    - However firmly the canthus is held, a sub-millimetre difference in how a sliver's nodes are pulled turned
      it over when the eyes looked up or down. The apex of every sliver now follows its edge
      (``network.SliverTies``).
    These shapes fold no triangle (audited without their mirror partners, their asymmetry is not checked here;
    the full bench checks it)."""
    vertices, faces = _head("soma")
    rig = build_fitted_rig(vertices, faces, seed=0)
    shapes = ("eyeBlinkRight", "eyeWideLeft", "eyeWideRight", "eyeLookUpLeft", "eyeLookDownLeft", "eyeLookDownRight")
    report = audit_shapes(rig, load_expressions("arkit"), shapes)
    inverted = {shape: report["rows"][shape][0]["inverted"] for shape in shapes}
    assert not any(inverted.values()), inverted


@pytest.mark.parametrize("name, shape", [("makehuman_neutral", "eyeLookDownRight"), ("soma", "eyeBlinkLeft")])
def test_fitted_lid_skin_by_the_canthus_does_not_turn_past_it(name, shape):
    """The lid skin's weight falls to 0 on a canthus (the canthal tendons, ``LidRig``). On an artist's mesh
    the canthus node is often the lowest corner of triangles whose other corners lie 1-2 mm away; within
    3.5 mm the weight rose from 0.14 on MakeHuman's canthus to 0.56 on a node 1.2 mm from it, which turned
    down past it when the eye looked down (SOMA: the upper margin 3 mm from its canthus, past the still
    skin beside the canthus, in a blink). On a fitted head the tie reaches ``FITTED_CANTHUS_RADIUS``: these
    shapes fold no triangle."""
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    report = audit_shapes(rig, load_expressions("arkit"), (shape,))
    assert report["rows"][shape][0]["inverted"] == 0, report["rows"][shape][1]


@pytest.mark.parametrize("name", ["soma", "makehuman_neutral"])
def test_fitted_brows_rise_without_the_orbits_roof_holding_them(name):
    """On SOMA the closest skull point of the lower brow's skin is the orbit's roof 5 mm above it, facing
    down: the skull guard's plane there held those nodes down when the brow rose, while their neighbours
    (not guarded: a little lid weight) rose 8 mm, and the skin between folded. On a fitted head the skull
    guard only holds skin that lies over its bone (``network.OVER_BONE``), and not skin hanging below a
    ledge (``network.LEDGE_DOWN``: MakeHuman neutral's outer brow node 171, bone normal z -0.98, skin
    normal . bone normal 0.31, held browOuterUpRight and surprise to 4 folded triangles each)."""
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    expressions = {**load_expressions("arkit"), **load_expressions("named")}
    shapes = ("browOuterUpLeft", "browOuterUpRight", "surprise")
    report = audit_shapes(rig, expressions, shapes)
    inverted = {shape: report["rows"][shape][0]["inverted"] for shape in shapes}
    assert not any(inverted.values()), inverted


@pytest.mark.parametrize("name", ["makehuman_neutral", "makehuman_african_female_old"])
def test_fitted_lip_margins_are_where_the_closed_lips_meet(name):
    """Both MakeHuman heads are modelled with their lips together, but the inner lip landmarks keep the
    canonical face's ~5.5 mm opening: the margins nearest the template's inner lip contours lay on the front
    of a lip (the neutral head's upper margin on the upper lip's red, 5.7 mm above the line where the lips
    meet; the African head's lower margin 5.5 mm down the lower lip's front), so the rig read a closed mouth
    as open and pressed that lip's red onto the other to close it (``transfer._lip_contact``). The margins
    now lie where the lips touch: less than 1.5 mm apart at rest."""
    vertices, faces = _head(name)
    rig = build_fitted_rig(vertices, faces, seed=0)
    assert abs(rig.lip_gap()) < 0.0015, rig.lip_gap()


def test_fitted_upper_incisors_sit_behind_the_meshs_own_lips():
    """The template placed the upper incisal edge 1 mm above the registered landmarks' stomion, which on a
    head modelled with its lips together is not where they meet: on MakeHuman neutral the edge lay above the
    upper lip's free edge, and the upper lip hid the teeth in /a/ (viseme_aa: upper teeth 0.0 mm shown, want
    >= 1). It now lies ``CLOSED_LIP_COVER`` below the free edge of the mesh's own upper lip at the midline (the
    margin that meets the lower lip), as on the default head, and /a/ shows them."""
    vertices, faces = _head("makehuman_neutral")
    rig = build_fitted_rig(vertices, faces, seed=0)
    head = rig.fitted
    margin = head.transfer.lip_margins["lips_inner_upper"]
    x, z = head.head_vertices[margin, 0], head.head_vertices[margin, 2]
    lip = np.interp(0.0, np.sort(x), z[np.argsort(x)])
    edge = head.template.organs.arches["upper"][0][:, 2].min() + 0.001
    assert abs(lip - edge - CLOSED_LIP_COVER) < 0.0003, (lip - edge) * 1000
    assert not _failed_targets("makehuman_neutral", ("viseme_aa",), rig)


def test_fitted_upper_lip_margin_row_stays_with_the_upper_lip():
    """MakeHuman neutral's lips are modelled together; the outer lower lip contour's third landmark from each
    corner lay on the line where they meet, level with the upper lip's margin row, and seeded the lower
    side (``transfer.SEED_SKIP``): the row from 4 mm beside the midline outwards took the lower lip's data
    (jaw weight 0.97), so closing or moving the jaw dragged the upper lip's edge with it: mouthClose,
    viseme_PP, jawLeft and jawRight folded 8, 9, 4 and 4 triangles. Now each meets its targets."""
    shapes = ("mouthClose", "viseme_PP", "jawLeft", "jawRight")
    failed = _failed_targets("makehuman_neutral", shapes)
    assert not failed, failed


def test_fitted_mouth_corner_slivers_keep_their_shape():
    """MakeHuman neutral's commissure has a small triangle (x 29.7 mm, edges 0.8 / 1.6 / 1.0 mm) among
    slivers whose nodes lie in the mouth region, which ``SliverTies`` used to leave untied entirely, and
    mouthFrownLeft/Right turned it over (1 inverted each). Only the lip nodes (which lip contact and the
    teeth guard place) are left untied now: both frowns meet their targets."""
    shapes = ("mouthFrownLeft", "mouthFrownRight")
    failed = _failed_targets("makehuman_neutral", shapes)
    assert not failed, failed


@pytest.mark.parametrize("name", ["makehuman_neutral", "makehuman_african_female_old"])
def test_fitted_oris_closes_only_the_meshs_own_rest_opening(name):
    """The orbicularis oris first closes the rest lips' opening (``MuscleSystem.rest_closing``). On a fitted
    head that opening was the landmarks' (the canonical face's parted lips: up to 5.7 mm of closing on the
    African head, whose lips touch), so mouthClose, PP and press pressed the lips into each other. No oris
    point now closes more than the mesh's own inner-lip opening at its x (plus the closure's overlap)."""
    vertices, faces = _head(name)
    head = fit_head(vertices, faces, seed=0)
    muscles, skin = head.template.muscles, head.template.skin
    upper, lower = (np.asarray(skin.contours[k]) for k in ("lips_inner_upper", "lips_inner_lower"))
    upper, lower = upper[np.argsort(skin.vertices[upper, 0])], lower[np.argsort(skin.vertices[lower, 0])]
    x = muscles.rest[:, 0]
    opening = (np.interp(x, skin.vertices[upper, 0], skin.vertices[upper, 2])
               - np.interp(x, skin.vertices[lower, 0], skin.vertices[lower, 2]))
    excess = np.abs(muscles.rest_closing[:, 2]) - (np.maximum(opening, 0.0) + LIP_OVERLAP)
    assert excess.max() < 1e-6, f"{excess.max() * 1000:.2f} mm more than the mesh's opening"


def test_fitted_lip_midline_follows_a_one_sided_lip_muscle():
    """mouthUpperUp / mouthLowerDown contract one levator labii superioris / depressor labii inferioris; the
    orbicularis oris' middle rows between the left and right lip connections were screened back to rest as
    hard as its rows beside them, so the lip's midline rose or fell 8-13 % of the lip's peak: 0.7-0.9 mm on
    MakeHuman neutral, under the audit's 1 mm, and mouthShrugUpper 0.9 mm. With the middle segment
    elongated (``muscles.BETWEEN_SCREEN``, thesis 3.1.2 "intermediate segments are elongated") all five meet
    their targets (1.1-1.3 mm)."""
    shapes = ("mouthUpperUpLeft", "mouthUpperUpRight", "mouthLowerDownLeft", "mouthLowerDownRight",
              "mouthShrugUpper")
    failed = _failed_targets("makehuman_neutral", shapes)
    assert not failed, failed


def test_thick_flat_lip_midline_follows_a_one_sided_lip_muscle():
    """The African head's lips are thick and their outer contour flat at the midline (no cupid's-bow dip for
    the rising neighbours to drag up, as on MakeHuman): with the oris' middle rows screened 0.5 its midline
    rose 0.7 mm for mouthUpperUp and mouthShrugUpper and fell 0.4-0.5 mm for mouthLowerDown. Screened 0.3
    (``muscles.BETWEEN_SCREEN``) and the lower lip's middle rows 0.2 (``middle_screen``, presets/face/
    muscles.json), the grid's middle follows the one-sided pull further (thesis 3.1.2, "intermediate
    segments are elongated") and these four meet the audit's 1 mm (1.00-1.09 mm)."""
    vertices, faces = _head("makehuman_african_female_old")
    rig = build_fitted_rig(vertices, faces, seed=0)
    shapes = ("mouthUpperUpLeft", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthShrugUpper")
    report = audit_shapes(rig, load_expressions("arkit"), shapes + ("mouthUpperUpRight",))   # its pair's asymmetry
    failed = {shape: report["rows"][shape][1] for shape in shapes if report["rows"][shape][1]}
    assert not failed, failed


def test_fitted_commissure_moves_as_one_piece_when_the_lips_press():
    """The African head's lip margins stop 5 mm short of its mouth corners (where its lips stop touching); the
    commissure knot around the margins' ends (``lip_contact.CORNER``) left the triangles between them and the
    corner to muscles pulling a millimetre apart the opposite ways: mouthPressLeft/Right, mouthClose and
    viseme_PP folded 2, 2, 6 and 6 of them. On a fitted head the knot covers the mesh's own commissure
    (``lip_contact._commissures``): each meets every target."""
    shapes = ("mouthPressLeft", "mouthPressRight", "mouthClose", "viseme_PP")
    failed = _failed_targets("makehuman_african_female_old", shapes)
    assert not failed, failed
