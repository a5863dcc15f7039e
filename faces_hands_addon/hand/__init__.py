# SPDX-License-Identifier: GPL-3.0-or-later
"""The anatomical hand (thesis 6.1-6.2): reference skeleton and skin, pseudo muscles (Eqs. 6.1-6.9),
geometric muscles, the spring network, new hands from photographs (6.2.3), minimal-effort contraction
solving, poses and motions.

Importing the package registers the hand rig kind with the rig registry (:mod:`..core.rig`); its module
loads only when a rig of that kind is read.
"""
from ..core.rig import register_rig_kind

HAND_RIG_FORMAT = "faces_hands.hand_rig/1"

register_rig_kind(HAND_RIG_FORMAT, f"{__name__}.rig:HandRig.load")
