# SPDX-License-Identifier: GPL-3.0-or-later
"""The whole character: MakeHuman's MPFB2 body (CC0 1.0, :mod:`.mpfb2`), its skeleton and skin weights
(:mod:`.skeleton`), the face rig fitted to its head and the hand rigs in its hands, one rig of rigs
(:mod:`.rig`); the face rig on an artist's own skinned character (:mod:`.user`); bone-name maps for
retargeting armature animation (:mod:`.retarget`).

Importing the package registers the character rig kinds with the rig registry (:mod:`..core.rig`) and
MPFB2's hand as the hand skin ``mpfb2`` (:mod:`.hand_mesh`).
"""
from ..core.rig import register_rig_kind
from ..hand import register_hand_mesh

CHARACTER_RIG_FORMAT = "faces_hands.character_rig/1"
FITTED_CHARACTER_RIG_FORMAT = "faces_hands.fitted_character_rig/1"

register_rig_kind(CHARACTER_RIG_FORMAT, f"{__name__}.rig:CharacterRig.load")
register_rig_kind(FITTED_CHARACTER_RIG_FORMAT, f"{__name__}.user:FittedCharacterRig.load")
register_hand_mesh("mpfb2", f"{__name__}.hand_mesh:mpfb2_hand_template")
