"""Re-anchoring a fitted head's bone guard (physics/collision.py ``keep_own_bones(refuse=...)``): with the
fitted heads' rule (face/network.py ``under_ledge``) a plane on the underside of a ledge is refused for skin
that does not face down, as the build leaves such skin unguarded."""
import numpy as np
import pytest

from faces_hands_addon.face.network import under_ledge
from faces_hands_addon.physics import BoneHalfSpaceGuard


def _guard_under_a_ledge(refuse, facing):
    """One node 5 mm under a ledge whose underside (z = 0) faces down; its first plane faces forward."""
    grid = np.stack(np.meshgrid(np.linspace(-0.02, 0.02, 9), np.linspace(-0.02, 0.02, 9)), -1).reshape(-1, 2)
    vertices = np.column_stack([grid, np.zeros(len(grid))])
    normals = np.tile([0.0, 0.0, -1.0], (len(grid), 1))

    def exact(bone, points):
        return np.column_stack([points[:, :2], np.zeros(len(points))]), np.tile([0.0, 0.0, -1.0], (len(points), 1))
    rest = np.array([[0.0], [0.0], [-0.005]])
    guard = BoneHalfSpaceGuard(np.arange(1), np.array([[0.0], [0.01], [-0.005]]), np.array([[0.0], [-1.0], [0.0]]),
                               np.zeros(1, np.int64), 0.002)
    guard.backend = "numpy"
    facing = np.asarray(facing, np.float64).reshape(3, 1)
    guard.attach_bone_surfaces([(vertices, normals)], exact=exact, rest=rest.copy(),
                               facing=facing / np.linalg.norm(facing))
    guard.keep_own_bones(refuse=refuse)
    guard.set_bone_transforms([np.eye(4)])
    return guard, rest


@pytest.mark.parametrize("refuse, facing, refused", [
    (under_ledge, [0.0, -0.8, -0.4], True),           # forward-facing brow rising under the orbit's roof
    (None, [0.0, -0.8, -0.4], False),         # without the rule the roof's plane is taken
    (under_ledge, [0.0, -0.3, -0.95], False),         # skin facing down is the ledge's own underside: guarded
])
def test_a_ledge_underside_is_refused_for_skin_that_does_not_face_down(refuse, facing, refused):
    guard, rest = _guard_under_a_ledge(refuse, facing)
    positions = rest.copy()
    positions[0, 0] += 0.002                   # slid 2 mm: re-anchored on the exact closest point
    guard.refresh(positions)
    normal = guard.local_normal[:, 0]
    if refused:
        np.testing.assert_array_equal(normal, [0.0, -1.0, 0.0])
    else:
        np.testing.assert_array_equal(normal, [0.0, 0.0, -1.0])
