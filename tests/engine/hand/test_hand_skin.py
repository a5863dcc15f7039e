"""The reference skin's shape (thesis 6.2.1, Fig. 6.13): round finger and thumb sections centred on their
bones (the warped WebXR hand had a cone for a thumb and flat-sided ring finger bases), fingers that part when
spread, geometric muscles that swell the skin by millimetres (6.2.2, Fig. 6.18), a thumbs-up thumb off the fist."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from faces_hands_addon.core import geometry
from faces_hands_addon.hand import motion
from faces_hands_addon.hand.rig import build_hand_rig
from faces_hands_addon.hand.skin_shape import fold_vertices


def settle_pose(rig, name: str, max_time: float):
    """The preset pose ``name`` settled from rest as the contact sheet does (a staged pose's squeeze after its
    first stage has settled, motion.pose_stages)."""
    return rig.settled_stages(motion.pose_stages(name, rig.muscle_names), max_time)


@pytest.fixture(scope="module")
def rig():
    return build_hand_rig()


def section_roundness(rig, bone: str, s: float) -> float:
    """Smallest over largest distance from the bone axis of the skin's cut by the plane across the bone at
    ``s`` of its length (only edges of that finger's skin, so the neighbours do not count)."""
    sk, skin = rig.skeleton, rig.template.skin
    b = sk.index[bone]
    finger = bone.split("-")[0]
    own = [i for i, n in enumerate(sk.names) if n.startswith(finger) and "metacarpal" not in n]
    mask = np.isin(skin.weights.argmax(axis=1), own)
    head, tail = sk.position[b], sk.tail[b]
    z = (tail - head) / np.linalg.norm(tail - head)
    centre = head + s * (tail - head)
    edges = geometry.unique_edges(skin.faces)
    h = (skin.vertices - centre) @ z
    cut = (h[edges[:, 0]] * h[edges[:, 1]] < 0) & mask[edges[:, 0]] & mask[edges[:, 1]]
    a, c = edges[cut, 0], edges[cut, 1]
    t = h[a] / (h[a] - h[c])
    points = skin.vertices[a] + t[:, None] * (skin.vertices[c] - skin.vertices[a])
    r = np.linalg.norm(points - centre, axis=1)
    assert len(r) >= 8
    return float(r.min() / r.max())


@pytest.mark.parametrize("bone, s, least", [
    ("thumb-phalanx-proximal", 0.5, 0.55), ("thumb-phalanx-proximal", 0.7, 0.6),
    ("thumb-phalanx-distal", 0.5, 0.6), ("thumb-phalanx-distal", 0.7, 0.6),
    ("index-finger-phalanx-intermediate", 0.5, 0.5), ("middle-finger-phalanx-intermediate", 0.5, 0.5),
    ("ring-finger-phalanx-intermediate", 0.5, 0.5), ("pinky-finger-phalanx-intermediate", 0.5, 0.5),
    ("ring-finger-phalanx-proximal", 0.7, 0.5), ("ring-finger-phalanx-proximal", 0.5, 0.55), ("middle-finger-phalanx-proximal", 0.7, 0.6),
])
def test_finger_and_thumb_sections_are_round_round_their_bones(rig, bone, s, least):
    # a round section has ratio 1; the target ellipse (thinner on the back than on the pad) about 0.73;
    # the warped asset had 0.40-0.48 on the thumb (a cone off its bones), 0.27 at the ring finger's base.
    # The intermediate phalanges carry a 3 mm palmar pad (skin_shape.PADS): their target is 6.2 / 11.4 = 0.54
    # at mid-bone by design (0.72 before, when the limit was 0.65), and the skin follows it (0.54)
    assert section_roundness(rig, bone, s) >= least


def test_the_finger_bases_have_no_folds(rig):
    # the warped asset, pushed off the neighbouring fingers' bones, had 29 finger nodes on edges folded past 90 degrees
    # (the flaps at the ring and little finger bases); now its webs are a smooth membrane
    skin, names = rig.template.skin, rig.skeleton.names
    folded = fold_vertices(skin.vertices, skin.faces)
    on_fingers = ["phalanx" in names[b] for b in skin.weights[folded].argmax(axis=1)]
    assert sum(on_fingers) <= 8          # (the asset's own zigzag at the wrist rim is not counted)


def test_the_forearm_ends_in_a_smooth_dome(rig):
    # the asset's flat cap had a saw-tooth rim (alternate rim nodes 7 and 21 mm above the wrist joint, edges
    # folded 100-109 degrees; the highest node 20 mm off the axis); now no edge of the skin above the wrist
    # folds past 60 degrees (49 now) and the end's highest point is near the forearm's axis (a dome: 3.9 mm off)
    skin = rig.template.skin
    origin = rig.skeleton.position[rig.skeleton.index["wrist"]]
    axis = rig.skeleton.position[rig.skeleton.index["forearm"]] - origin
    axis /= np.linalg.norm(axis)
    height = (skin.vertices - origin) @ axis
    normals = geometry.face_normals(skin.vertices, skin.faces)
    up = np.flatnonzero((height[skin.faces] > 0).all(axis=1))
    pairs = [(i, j) for i in up for j in up if i < j and len(set(skin.faces[i]) & set(skin.faces[j])) == 2]
    cos = [normals[i] @ normals[j] for i, j in pairs]
    assert len(pairs) > 100 and np.degrees(np.arccos(min(cos))) < 60.0
    top = skin.vertices[np.argmax(height)] - origin
    assert np.linalg.norm(top - (top @ axis) * axis) < 0.006          # 20 mm before; the forearm is 45 mm across


def test_the_skin_stays_outside_the_bones(rig):
    sk, skin = rig.skeleton, rig.template.skin
    for name in sk.names[1:]:
        inside = geometry.winding_number(skin.vertices, skin.faces, sk.mesh_vertices[name][::7])
        assert np.all(inside > 0.5), name


def test_spread_parts_every_pair_of_neighbouring_fingers(rig):
    rig.reset()
    pose = settle_pose(rig, "spread", 2.5)
    rig.reset()
    skin = pose.positions["skin"].astype(float)
    owner = rig.template.skin.weights.argmax(axis=1)
    sk = rig.skeleton
    fingers = ("index", "middle", "ring", "pinky")
    for a, b in zip(fingers[:-1], fingers[1:]):
        tips_a = skin[owner == sk.index[f"{a}-finger-phalanx-distal"]]
        tips_b = skin[owner == sk.index[f"{b}-finger-phalanx-distal"]]
        assert cdist(tips_a, tips_b).min() > 0.010, (a, b)          # > 1 cm of air between the fingertips


@pytest.mark.parametrize("muscle, least_mm", [
    ("adductor_pollicis", 3.0), ("opponens_pollicis", 4.5), ("dorsal_interosseus_1", 4.0),
    ("palmar_interosseus_1", 1.8), ("palmar_interosseus_2", 1.8), ("palmar_interosseus_3", 1.8),
    ("opponens_digiti_minimi", 3.0), ("flexor_digiti_minimi_brevis", 3.5), ("abductor_digiti_minimi", 4.5),
])
def test_every_geometric_muscle_swells_the_skin_by_millimetres(rig, muscle, least_mm):
    rig.reset()
    zero = np.zeros(rig.skeleton.dof_count)
    rest = rig.pose_joints(zero, 2.5).positions["skin"].astype(float)
    rig.set_controls({muscle: 1.0})
    bulged = rig.pose_joints(zero, 2.5).positions["skin"].astype(float)
    rig.reset()
    outward = np.einsum("ij,ij->i", bulged - rest, geometry.vertex_normals(rest, rig.template.skin.faces))
    assert outward.max() * 1000 >= least_mm
    assert (outward > 0.001).sum() >= 10                               # a swelling, not one raised node


def test_the_thumbs_up_thumb_stands_off_the_fist(rig):
    """The thumb of ``thumbs_up`` points to the thumb side, across the hand's axis, not along the curled index
    finger (seen from three quarters it lay on the fist and vanished against it)."""
    from faces_hands_addon.hand.reference import RADIAL
    sk = rig.skeleton
    rig.reset()
    settle_pose(rig, "thumbs_up", 3.0)
    transforms = sk.bone_transforms(rig.pseudo.angles)
    rig.reset()
    proximal, distal = sk.index["thumb-phalanx-proximal"], sk.index["thumb-phalanx-distal"]
    base = sk.posed_points(transforms, proximal, sk.position[proximal])
    tip = sk.posed_points(transforms, distal, sk.tail[distal])
    direction = (tip - base) / np.linalg.norm(tip - base)
    axis = sk.position[sk.index["middle-finger-phalanx-proximal"]] - sk.position[sk.index["wrist"]]
    assert direction @ RADIAL > 0.85                                   # 0.74 before the fix
    assert np.degrees(np.arccos(direction @ axis / np.linalg.norm(axis))) > 65   # 60 before


@pytest.mark.parametrize("pose, least_mm", [("fist", 2.0), ("point", 2.0), ("thumbs_up", 2.0)])
def test_grip_poses_swell_their_geometric_muscles(rig, pose, least_mm):
    """A held fist co-contracts intrinsic muscles (presets/hand/poses.json, GRIP in
    scripts/hand_pose_presets.py): the geometric muscles lift the skin by millimetres in the pose itself, not
    only on the bulge sheet. Before, minimal-effort contractions left them at 0.2-0.5 mm."""
    rig.reset()
    settle_pose(rig, pose, 3.0)
    contraction = rig.contraction_vector()
    transforms = rig.skeleton.bone_transforms(rig.pseudo.angles)
    rig.reset()
    _, bulge = rig.geometric.surface(transforms, contraction)
    _, relaxed = rig.geometric.surface(transforms, np.zeros_like(contraction))
    lift = np.linalg.norm(rig.geometric.skin_displacement(bulge - relaxed), axis=1) * 1000
    assert lift.max() >= least_mm
    assert (lift > 0.5).sum() >= 10


EMINENCES = {"hypothenar": ("opponens_digiti_minimi", "flexor_digiti_minimi_brevis", "abductor_digiti_minimi"),
             "first web": ("first_dorsal_interosseus",), "thenar": ("adductor_pollicis", "opponens_pollicis")}


@pytest.mark.parametrize("pose, region, least_mm", [
    ("fist", "hypothenar", 5.0), ("point", "hypothenar", 5.0), ("thumbs_up", "hypothenar", 5.0),
    ("pinch", "first web", 4.0), ("spread", "hypothenar", 2.5), ("spread", "first web", 2.0),
    ("fist", "thenar", 3.0),    # 0.6 mm before the fist's squeeze (presets/hand/poses.json, hand/motion.py)
])
def test_grip_poses_lift_the_skin_over_their_eminences(rig, pose, region, least_mm):
    """The contact sheet's grip poses swell the simulated skin itself: each pose simulated from rest, then the
    skin settled at the joint angles it reached with and without its geometric muscles' bulge (Fig. 6.18,
    ``HandRig.bulge_lift``), over the nodes whose heaviest muscle footprint is one of the region's muscles.
    With the poses before the co-contractions of scripts/hand_pose_presets.py (GRIP): hypothenar 2.7 mm and 5
    nodes over 1 mm in fist, point and thumbs up, the first web 0.5 mm in the pinch, spread 1.7 and 0.5 mm."""
    rig.reset()
    settle_pose(rig, pose, 3.0)
    lift, _, _ = rig.bulge_lift(rig.joint_angles)
    rig.reset()
    geo = rig.geometric
    nodes = np.isin(geo.footprint_owner(), [geo.names.index(name) for name in EMINENCES[region]])
    assert lift[nodes].max() * 1000 >= least_mm
    assert (lift[nodes] > 0.001).sum() >= 10                           # a swelling, not one raised node


def _axis(rig, transforms: np.ndarray, bone: str, samples: int = 12) -> np.ndarray:
    sk = rig.skeleton
    b = sk.index[bone]
    s = np.linspace(0.0, 1.0, samples)[:, None]
    points = sk.position[b] + s * (sk.tail[b] - sk.position[b])
    return points @ transforms[b][:3, :3].T + transforms[b][:3, 3]


@pytest.mark.parametrize("pose", ["fist", "point"])
def test_the_thumb_rests_on_the_curled_fingers_instead_of_sinking_into_them(rig, pose):
    """Between the thumb's phalanx axes and the middle and ring fingers' proximal and middle phalanx axes lie at
    least the two bones' skin radii (less 1 mm): the thumb rests on the fingers' skin. Before the thumb contact
    (hand/thumb_contact.py) the fist's thumb sank 6.2 mm into these fingers' skin, the point's 8.9 mm."""
    from faces_hands_addon.hand.crease import bone_radii
    skin = rig.template.skin
    radii = dict(zip(rig.skeleton.names, bone_radii(rig.skeleton, skin.vertices, skin.weights)))
    rig.reset()
    settle_pose(rig, pose, 2.5)
    transforms = rig.skeleton.bone_transforms(rig.pseudo.angles)
    rig.reset()
    worst = np.inf
    for thumb in ("thumb-phalanx-proximal", "thumb-phalanx-distal"):
        for finger in (f"{f}-finger-phalanx-{p}" for f in ("middle", "ring") for p in ("proximal", "intermediate")):
            gap = cdist(_axis(rig, transforms, thumb), _axis(rig, transforms, finger)).min()
            worst = min(worst, gap - radii[thumb] - radii[finger])
    assert worst * 1000 >= -1.0


def test_the_fist_squeezes_with_its_thumb_curled_on_the_fingers(rig):
    """The fist's squeeze (its second stage, hand/motion.py: opponens and adductor pollicis contracted once the
    fist has settled) swells the thenar eminence by millimetres while the thumb stays where the closed fist put
    it, curled on the fingers (the thumb contact holds a thumb pressed onto them, hand/thumb_contact.py). Before:
    the fist held 0.1 of opponens (0.6 mm of thenar lift), and the thenar contracted from rest swung the thumb
    across the palm to its CMC limits (the tip 87 mm away), overshooting the fingers within one frame."""
    stages = motion.pose_stages("fist", rig.muscle_names)
    assert len(stages) == 2 and stages[1]["opponens_pollicis"] > stages[0]["opponens_pollicis"]
    rig.reset()
    rig.settled({"ctrl": stages[0]}, 3.0)
    closed = rig.joint_angles
    rig.settled_stages(stages, 3.0)
    squeezed = rig.joint_angles
    lift, _, _ = rig.bulge_lift(squeezed)
    rig.reset()
    thumb = [k for (bone, _), k in rig.skeleton.dof_index.items() if bone.startswith("thumb-")]
    assert np.degrees(np.abs(squeezed - closed)[thumb]).max() < 2.0      # curled as the closed fist left it
    geo = rig.geometric
    nodes = np.isin(geo.footprint_owner(), [geo.names.index(name) for name in EMINENCES["thenar"]])
    assert lift[nodes].max() * 1000 >= 3.0 and (lift[nodes] > 0.001).sum() >= 30


def test_a_keyed_fist_closes_then_squeezes_with_its_thumb_held(rig):
    """The fist keyed as a motion (hand/motion.py: the pose held 1 s, then its squeeze 0.3 s later, clamped
    Hermite tangents so the held contractions do not sag) plays close-then-squeeze: at its end the thenar is
    lifted and the thumb lies where the closed fist put it. With the squeeze keyed 0.3 s after the pose (or with
    Catmull-Rom tangents) the thumb swung across the palm to its CMC limits, the tip 89 mm away."""
    names = rig.muscle_names
    times, keyed = motion.motion_keys("fist", names)
    stages = motion.pose_stages("fist", names)
    assert keyed[1] == keyed[2] == stages[0] and keyed[3] == stages[1] and times[3] - times[1] >= 1.0
    at, table = motion.motion_table("fist", names, 30.0)
    held = (at >= times[1]) & (at <= times[2])
    opponens = names.index("opponens_pollicis")
    assert np.all(table[held, opponens] >= stages[0]["opponens_pollicis"] - 1e-9)    # no sag before the squeeze
    rig.reset()
    rig.settled({"ctrl": stages[0]}, 3.0)
    closed = rig.joint_angles
    rig.reset()
    for row in table:
        rig.step({"ctrl": dict(zip(names, row))}, 1 / 30)
    lift, _, _ = rig.bulge_lift(rig.joint_angles)
    angles = rig.joint_angles
    rig.reset()
    thumb = [k for (bone, _), k in rig.skeleton.dof_index.items() if bone.startswith("thumb-")]
    # the keyed fist ends within a few degrees of the settled one (its thumb IP 4.3 degrees off since the
    # fingers' palmar pads, hand/skin_shape.py PADS, moved the surface the thumb rests on); a thumb thrown
    # across the palm is tens of degrees off
    assert np.degrees(np.abs(angles - closed)[thumb]).max() < 6.0
    geo = rig.geometric
    nodes = np.isin(geo.footprint_owner(), [geo.names.index(name) for name in EMINENCES["thenar"]])
    assert lift[nodes].max() * 1000 >= 3.0
