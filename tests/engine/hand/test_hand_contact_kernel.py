"""The compiled sweep of the finger contact (faces_hands_addon/hand/contact_kernel.py) against the numpy
reference of faces_hands_addon/hand/contact.py: the same shortfalls and Jacobian rows on the poses of a motion
in which the fingers touch, and the same joint angles after a whole motion."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from faces_hands_addon.hand import motion
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


def test_a_whole_motion_reaches_the_same_joint_angles_with_the_compiled_sweep(rig):
    finals = {}
    for backend in ("numpy", "auto"):
        rig.contact.backend = backend
        rig.reset()
        for values in _frames(rig):
            rig.step(values, 1 / 30)
        finals[backend] = rig.pseudo.angles.copy()
    rig.contact.backend = "auto"
    np.testing.assert_allclose(finals["auto"], finals["numpy"], rtol=0, atol=1e-9)
