# SPDX-License-Identifier: GPL-3.0-or-later
"""``bench/face_sheets.py``'s own geometry (thesis 3.1.2: a head is fitted in whatever axes it comes in):
the OBJ it writes is the head as stored, and the turn it gives the fitted head brings the face to the
sheet camera's front (-Y, top +Z) for every axis convention of the population, through Blender's OBJ
import rotation or none."""
from __future__ import annotations

import importlib.util
import itertools
import json
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[3] / "bench" / "face_sheets.py"


@pytest.fixture(scope="module")
def sheets():
    spec = importlib.util.spec_from_file_location("face_sheets_bench", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _conventions():
    """The 24 (forward, up) pairs of perpendicular signed axes."""
    names = [s + a for a in "XYZ" for s in "+-"]
    return [(f, u) for f, u in itertools.product(names, names) if f[1] != u[1]]


OBJ_IMPORT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # Blender's OBJ import: +90 deg about X


@pytest.mark.parametrize("placed", [np.eye(3), OBJ_IMPORT, 2.54 * OBJ_IMPORT])
def test_the_turn_brings_every_convention_face_on(sheets, placed):
    assert len(_conventions()) == 24
    for forward, up in _conventions():
        turn = sheets.turn_to_front(placed, forward, up)
        assert np.allclose(turn @ turn.T, np.eye(3)) and np.isclose(np.linalg.det(turn), 1.0), (forward, up)
        face = turn @ placed @ sheets.axis(forward)
        top = turn @ placed @ sheets.axis(up)
        assert np.allclose(face / np.linalg.norm(face), [0.0, -1.0, 0.0]), (forward, up)
        assert np.allclose(top / np.linalg.norm(top), [0.0, 0.0, 1.0]), (forward, up)


def test_a_head_already_face_on_is_not_turned(sheets):
    assert np.allclose(sheets.turn_to_front(np.eye(3), "-Y", "+Z"), np.eye(3))


def test_the_obj_is_the_head_as_stored(sheets, tmp_path):
    vertices = np.array([[0.0, 0.0, 0.0], [12.5, -3.0, 7.25], [1e-3, 250.0, -0.5]], np.float32)
    faces = np.array([[0, 1, 2]], np.int32)
    npz = tmp_path / "h99.npz"
    np.savez(npz, vertices=vertices, faces=faces, spec=json.dumps({"units": "mm", "forward": "+Y", "up": "-Z"}))
    spec = sheets.write_obj(npz, tmp_path / "h99.obj")
    lines = (tmp_path / "h99.obj").read_text().splitlines()
    read = np.array([[float(x) for x in line.split()[1:]] for line in lines if line.startswith("v ")])
    triangles = [[int(x) for x in line.split()[1:]] for line in lines if line.startswith("f ")]
    assert spec["units"] == "mm"
    assert np.allclose(read, vertices, rtol=1e-5, atol=1e-6)   # no unit or axis change
    assert triangles == [[1, 2, 3]]                             # OBJ counts from 1
