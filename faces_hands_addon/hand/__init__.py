# SPDX-License-Identifier: GPL-3.0-or-later
"""The anatomical hand (thesis 6.1-6.2): reference skeleton and skin, pseudo muscles (Eqs. 6.1-6.9),
geometric muscles, the spring network, new hands from photographs (6.2.3), minimal-effort contraction
solving, poses and motions.

Importing the package registers the hand rig kind with the rig registry (:mod:`..core.rig`); its module
loads only when a rig of that kind is read. Skins beyond the reference skin are registered here by the
packages that hold them (:func:`register_hand_mesh`; the character registers MPFB2's hand, ``mpfb2``).
"""
from ..core.rig import register_rig_kind

HAND_RIG_FORMAT = "faces_hands.hand_rig/1"

register_rig_kind(HAND_RIG_FORMAT, f"{__name__}.rig:HandRig.load")

#: hand skin name -> "module:function" building a :class:`.template.HandTemplate` on that skin from the
#: reference template (:func:`.template.hand_template` imports it when the skin is first asked for)
HAND_MESHES: dict[str, str] = {}


def register_hand_mesh(name: str, target: str) -> None:
    HAND_MESHES[name] = target
