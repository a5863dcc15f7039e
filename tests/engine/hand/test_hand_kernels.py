"""The compiled hand loops against their numpy references: the finger contact's sweep
(faces_hands_addon/hand/contact_kernel.py against hand/contact.py: the same shortfalls and Jacobian rows on
the poses of a motion in which the fingers touch), the pseudo muscles' joint substeps
(hand/pseudo_kernel.py against hand/pseudo.py: the same angles and speeds after a step from each pose), and
the same joint angles after a whole motion with both compiled."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from faces_hands_addon.hand import motion
from faces_hands_addon.hand.pseudo_kernel import compiled_substeps
from faces_hands_addon.hand.rig import build_hand_rig
from faces_hands_addon.physics import kernel

pytestmark = pytest.mark.skipif(importlib.util.find_spec("numba") is None,
                                reason="numba is not importable here (the numpy path is the only one)")


@pytest.fixture(scope="module")
def rig():
    assert kernel.substep_kernel() is not None, kernel._STATE["error"]
    return build_hand_rig()


def _frames(rig, fps=30.0):
    times, table = motion.motion_table("showcase", rig.muscle_names, fps)
    return [{"ctrl": dict(zip(rig.muscle_names, row))} for row in table]


def _rows(rig, backend, angles):
    rig.contact.backend = backend
    try:
        return rig.contact._rows(angles.copy())
    finally:
        rig.contact.backend = "auto"


def test_compiled_sweep_matches_the_numpy_rows_where_fingers_touch(rig):
    assert rig.contact._compiled() is not None
    rig.reset()
    compared = touching = 0
    for values in _frames(rig)[:90]:
        rig.step(values, 1 / 30)
        angles = rig.pseudo.angles.copy()
        # the settled frame and the fingers turned towards and away from each other
        for turn in (0.0, -0.05, 0.08):
            probe = angles.copy()
            probe[rig.contact._flat_dofs[:, 0]] += turn
            reference, compiled = _rows(rig, "numpy", probe), _rows(rig, "auto", probe)
            assert reference[0].shape == compiled[0].shape
            np.testing.assert_allclose(compiled[0], reference[0], rtol=0, atol=1e-12)
            np.testing.assert_allclose(compiled[1], reference[1], rtol=0, atol=1e-12)
            compared += 1
            touching += len(reference[0])
    assert compared == 270 and touching > 100


def test_compiled_joint_substeps_match_the_numpy_step_from_every_pose_of_a_motion(rig):
    pseudo = rig.pseudo
    rig.reset()
    compared = 0
    for values in _frames(rig)[:60]:
        rig.step(values, 1 / 30)
        contraction = rig.contraction_vector()
        start = pseudo.angles.copy(), pseudo.velocity.copy()
        results = {}
        for backend in ("numpy", "auto"):
            pseudo.backend = backend
            pseudo.angles[:], pseudo.velocity[:] = start
            pseudo.step(contraction, 1 / 30)
            results[backend] = pseudo.angles.copy(), pseudo.velocity.copy()
        pseudo.backend = "auto"
        np.testing.assert_allclose(results["auto"][0], results["numpy"][0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(results["auto"][1], results["numpy"][1], rtol=0, atol=1e-9)
        assert np.abs(results["numpy"][0] - start[0]).max() > 0 or compared < 5
        compared += 1
    assert compared == 60


def test_a_whole_motion_reaches_the_same_joint_angles_with_the_compiled_loops(rig):
    finals = {}
    for backend in ("numpy", "auto"):
        rig.contact.backend = rig.pseudo.backend = backend
        rig.reset()
        for values in _frames(rig):
            rig.step(values, 1 / 30)
        finals[backend] = rig.pseudo.angles.copy()
    rig.contact.backend = rig.pseudo.backend = "auto"
    assert compiled_substeps() is not None
    np.testing.assert_allclose(finals["auto"], finals["numpy"], rtol=0, atol=1e-9)


def test_compiled_contact_turn_matches_the_numpy_turn_with_the_weighted_little_finger(rig):
    # the whole resolve (rows, the weighted smallest turn W J^T lambda, limits, speeds) on both paths, from the
    # frames of a motion with the fingers turned into each other; in some the curled little finger's abduction
    # is weighted down (contact.ABDUCTION_WEIGHT), so a weight dropped on either path shows here
    contact, pseudo = rig.contact, rig.pseudo
    assert contact._compiled() is not None
    rig.reset()
    compared = moved = weighted = 0
    for values in _frames(rig)[:90:3]:
        rig.step(values, 1 / 30)
        angles, velocity = pseudo.angles.copy(), pseudo.velocity.copy()
        weighted += contact.weights(angles).min() < 0.5
        for turn in (0.0, -0.05, 0.08):
            out = []
            for backend in ("numpy", "auto"):
                pseudo.angles[:] = angles
                pseudo.angles[contact._flat_dofs[:, 0]] += turn
                pseudo.velocity[:] = velocity
                contact.backend = backend
                turned = contact.resolve()
                out.append((turned, pseudo.angles.copy(), pseudo.velocity.copy()))
            contact.backend = "auto"
            assert out[0][0] == out[1][0]
            np.testing.assert_allclose(out[1][1], out[0][1], rtol=0, atol=1e-10)
            np.testing.assert_allclose(out[1][2], out[0][2], rtol=0, atol=1e-10)
            compared += 1
            moved += out[0][0]
        pseudo.angles[:], pseudo.velocity[:] = angles, velocity
    assert compared == 90 and moved > 20 and weighted > 5
