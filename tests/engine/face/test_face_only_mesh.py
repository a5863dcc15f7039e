"""A face-only artist's mesh (no vertex beyond the face: the network has no driven ring) is a fitted head
all the same: the fitted heads' skin-guard rules hold for it (face/network.py ``_bone_guard``)."""
import numpy as np

from faces_hands_addon.face.fitted import build_fitted_rig
from faces_hands_addon.face.network import LEDGE_DOWN, OVER_BONE
from faces_hands_addon.face.rig import build_default_rig


def test_a_face_only_mesh_gets_the_fitted_heads_guard_rules():
    base = build_default_rig("default")
    assert not base.template.skin.fitted
    rig = build_fitted_rig(base.rest_positions.astype(np.float64), base.faces.astype(np.int64), seed=0)
    skin, anchoring = rig.template.skin, rig.template.attachment
    assert skin.fitted and not skin.driven                  # fitted, simulated to its border
    guarded = rig.face.bone_guard.nodes
    assert len(guarded) > 500
    # only skin lying over its bone is held, and skin hanging under a ledge is not (keyed on the driven ring
    # before: 154 and 54 guarded nodes of this mesh broke these rules; the dense head's brow flickered)
    facing = np.einsum("ij,ij->i", skin.normals[guarded], anchoring.bone_normal[guarded])
    assert np.all(facing > OVER_BONE)
    assert not np.any((anchoring.bone_normal[guarded, 2] < -LEDGE_DOWN) & (skin.normals[guarded, 2] > -0.5))
