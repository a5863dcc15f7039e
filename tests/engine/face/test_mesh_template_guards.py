# SPDX-License-Identifier: GPL-3.0-or-later
"""Fitting on meshes whose lips the contour search could not trace (a subdivided scan with parted lips gave
an empty inner lower-lip contour and the fit stopped with numpy's "array of sample points is empty")."""
from types import SimpleNamespace

import numpy as np

from faces_hands_addon.face.mesh_template import _rest_closing_of_the_mesh


def test_an_empty_inner_lip_contour_keeps_the_landmarks_closing():
    closing = np.ones((4, 3))
    muscles = SimpleNamespace(rest=np.zeros((4, 3)), rest_closing=closing.copy(), set_rest_closing=None)
    set_to = []
    muscles.set_rest_closing = set_to.append
    skin = SimpleNamespace(vertices=np.zeros((6, 3)),
                           contours={"lips_inner_upper": np.array([0, 1, 2]), "lips_inner_lower": np.array([], int)})
    landmarks = np.zeros((6, 3))
    contours = {"lips_inner_upper": np.array([0, 1]), "lips_inner_lower": np.array([2, 3])}
    _rest_closing_of_the_mesh(muscles, skin, landmarks, contours)
    assert set_to == [] and np.array_equal(muscles.rest_closing, closing)
