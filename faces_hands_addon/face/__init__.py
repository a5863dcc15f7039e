# SPDX-License-Identifier: GPL-3.0-or-later
"""The MEDUSA head (thesis 3.1.2): template skin, skull fit, muscles, direct parameters, the face rig.

Importing the package registers the face rig kinds with the rig registry (:mod:`..core.rig`); their
modules load only when a rig of that kind is read.
"""
from ..core.rig import register_rig_kind

FACE_RIG_FORMAT = "faces_hands.face_rig/1"
FITTED_FACE_RIG_FORMAT = "faces_hands.fitted_face_rig/1"

register_rig_kind(FACE_RIG_FORMAT, f"{__name__}.rig:FaceRig.load")
register_rig_kind(FITTED_FACE_RIG_FORMAT, f"{__name__}.fitted:FittedFaceRig.load")
