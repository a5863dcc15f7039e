"""The hand rig (thesis 6.2): the rig protocol, determinism, saving, left hands, geometric-muscle bulges,
Solve Contractions, the bake helpers, Hermite motions and bad presets."""
from __future__ import annotations

import json

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.core import rig as core_rig
from faces_hands_addon.core.geometry import vertex_normals
from faces_hands_addon.hand import bake, motion
from faces_hands_addon.hand.rig import HandRig, build_hand_rig
from faces_hands_addon.hand.solve import angles_from_rotations, solve_contractions

DT = 1 / 30


@pytest.fixture(scope="module")
def rig():
    return build_hand_rig()


def test_the_reference_hand_has_the_thesis_size(rig):
    assert rig.template.node_count == pytest.approx(1500, rel=0.05)           # 6.2.4: ~1500 nodes
    assert rig.hand.network.springs.count == pytest.approx(4500, rel=0.05)    # and ~4500 springs
    assert len(rig.template.skin.faces) == pytest.approx(3000, rel=0.05)      # 6.2.1: 3000 triangles
    assert sum(len(v) for v in rig.skeleton.mesh_names.values()) == 29        # 27 hand bones + radius, ulna
    assert len(rig.control_specs()) == 42 and len(rig.geometric.names) == 9


def test_hand_rig_implements_the_protocol(rig):
    assert isinstance(rig, core_rig.Rig) and rig.kind == "hand"
    spec = rig.control_specs()["flexor_digitorum_profundus_index"]
    assert (spec.minimum, spec.maximum, spec.kind, spec.group) == (0.0, 1.0, "muscle", "index")
    assert "flexes" in spec.description and "index DIP" in spec.description
    pose = rig.step({"ctrl": {"flexor_digitorum_profundus_index": 0.4}, "emotion": {"opponens_pollicis": 0.5}}, DT)
    assert pose.positions["skin"].dtype == np.float32 and pose.positions["skin"].shape == (rig.template.node_count, 3)
    assert set(pose.transforms) == set(rig.skeleton.names) and len(pose.transforms) == 21
    assert rig.controls["opponens_pollicis"] == 0.5
    assert np.array_equal(rig.rest_pose().positions["skin"], rig.rest_positions)


def test_settled_is_deterministic_and_independent_of_the_past(rig):
    first = rig.settled({"ctrl": {"flexor_digitorum_superficialis_middle": 0.5}}, 1.0).positions["skin"]
    rig.step({"ctrl": {"extensor_digitorum_index": 1.0}}, DT)
    again = rig.settled({"ctrl": {"flexor_digitorum_superficialis_middle": 0.5}}, 1.0).positions["skin"]
    assert first.tobytes() == again.tobytes()


def test_save_and_load_give_the_same_rig_and_bytes(rig, tmp_path):
    rig.settled({"ctrl": {"adductor_pollicis": 0.7}}, 0.5)
    data = core_rig.save_rig(rig)
    loaded = core_rig.load_rig_bytes(data)
    assert isinstance(loaded, HandRig) and core_rig.save_rig(loaded) == data
    a = rig.step({"ctrl": {"adductor_pollicis": 0.7}}, DT).positions["skin"]
    b = loaded.step({"ctrl": {"adductor_pollicis": 0.7}}, DT).positions["skin"]
    assert a.tobytes() == b.tobytes()


def test_a_left_hand_is_the_mirror_image(rig):
    left = build_hand_rig("left")
    values = {"ctrl": {"flexor_digitorum_profundus_ring": 0.5, "opponens_pollicis": 0.6}}
    right_pose, left_pose = rig.settled(values, 0.6), left.settled(values, 0.6)
    mirrored = right_pose.positions["skin"] * np.array([-1, 1, 1], np.float32)
    np.testing.assert_allclose(left_pose.positions["skin"], mirrored, atol=1e-6)
    s = np.diag([-1.0, 1, 1, 1])
    np.testing.assert_allclose(left_pose.transforms["wrist"], s @ right_pose.transforms["wrist"] @ s, atol=1e-9)
    assert np.linalg.det(left_pose.transforms["ring-finger-phalanx-distal"][:3, :3]) == pytest.approx(1.0)
    assert np.array_equal(left.faces, rig.faces[:, ::-1])


@pytest.mark.parametrize("muscle", ["opponens_pollicis", "abductor_digiti_minimi", "dorsal_interosseus_1"])
def test_a_geometric_muscle_bulges_the_skin_above_it(rig, muscle):
    rig.reset()
    zero = np.zeros(rig.skeleton.dof_count)
    rest = rig.pose_joints(zero).positions["skin"].astype(float)
    rig.set_controls({muscle: 1.0})
    bulged = rig.pose_joints(zero).positions["skin"].astype(float)
    rig.reset()
    outward = np.einsum("ij,ij->i", bulged - rest, vertex_normals(rest, rig.template.skin.faces))
    assert outward.max() > 0.0015, outward.max()                 # > 1.5 mm swelling
    far = np.linalg.norm(rest - rest[np.argmax(outward)], axis=1) > 0.05
    assert np.abs(bulged - rest)[far].max() < 3e-4               # and nothing 5 cm away


@pytest.mark.parametrize("muscle", ["adductor_pollicis", "opponens_pollicis", "palmar_interosseus_2",
                                    "flexor_digiti_minimi_brevis"])
def test_a_geometric_muscle_shortens_when_its_twin_turns_the_joints(rig, muscle):
    # turning every DOF its pseudo twin crosses by 20 degrees its way (Table A.1 signs) must shorten the
    # geometric muscle, so that it thickens there (its volume is kept, 6.2.2) and lengthens when turned the
    # other way. Before, opponens pollicis lay along the thumb metacarpal alone and lengthened to 1.19 (1.39 at
    # 40 degrees; thumb opposed in a grip: 1.46): opposing the thumb thinned the thenar eminence. Its origin is
    # now on the carpus (trapezium and flexor retinaculum): 0.75
    geo, sk = rig.geometric, rig.skeleton
    m = geo.names.index(muscle)
    spec = next(s for s in rig.template.muscles if s.name == rig.muscle_names[geo.pseudo[m]])
    turn = np.zeros(sk.dof_count)
    for row in spec.rows:
        turn[sk.dof(row.bone, row.dof)] += np.radians(20.0) * row.sign
    zero = np.zeros(len(rig.muscle_names))

    def length(q):
        points, _ = geo.surface(sk.bone_transforms(np.clip(q, rig.pseudo.lower, rig.pseudo.upper)), zero)
        row = geo.layout.spine_rows[m]
        return np.linalg.norm(np.diff(points[row], axis=0), axis=1).sum()

    rest = length(np.zeros(sk.dof_count))
    assert length(turn) < 0.9 * rest
    assert length(-turn) > rest


def test_solve_contractions_reaches_a_pose_set_on_the_bones(rig):
    sk = rig.skeleton
    target = np.zeros(sk.dof_count)
    for finger, mcp, pip in (("index", 40, 50), ("middle", 60, 70), ("ring", 70, 80), ("pinky", 70, 80)):
        target[sk.dof(f"{finger}-finger-phalanx-proximal", "flexion")] = np.radians(mcp)
        target[sk.dof(f"{finger}-finger-phalanx-intermediate", "flexion")] = np.radians(pip)
    target[sk.dof("thumb-phalanx-proximal", "flexion")] = np.radians(30)
    target[sk.dof("pinky-finger-phalanx-proximal", "abduction")] = sk.dofs[
        sk.dof("pinky-finger-phalanx-proximal", "abduction")].lower     # the curled little finger adducts (Table A.1)
    solution = solve_contractions(rig.pseudo, target)
    assert all(0.0 <= v <= 1.0 for v in solution.contractions.values())
    effort = sum(v * v for v in solution.contractions.values())
    rig.contact.enabled = False           # the solver balances muscles only; the finger contact would hold
    try:                                  # the adducted little finger off the ring finger
        rig.settled({"ctrl": solution.contractions}, 3.0)
    finally:
        rig.contact.enabled = True
    error = np.degrees(np.abs(rig.joint_angles - target))[rig.pseudo.dynamic]
    assert error.mean() < 4.0 and error.max() < 15.0, (error.mean(), error.max())
    stronger = {k: min(1.0, v * 1.5 + 0.05) for k, v in solution.contractions.items()}
    assert effort < sum(v * v for v in stronger.values())


def test_angles_round_trip_through_bone_rotations(rig):
    sk = rig.skeleton
    rng = np.random.default_rng(5)
    angles = rng.uniform(sk.lower, sk.upper) * 0.7
    rotations = sk.local_rotations(angles)
    back = angles_from_rotations(sk, {n: rotations[b] for b, n in enumerate(sk.names)})
    np.testing.assert_allclose(back, angles, atol=1e-9)


def test_unskinning_reproduces_the_simulated_skin(rig):
    rig.settled({"ctrl": {"flexor_digitorum_profundus_middle": 0.5}}, 1.0)
    pose = rig.pose()
    transforms = np.array([pose.transforms[n] for n in rig.skeleton.names])
    rest_space = bake.unskinned(rig, pose.positions["skin"].astype(float), transforms)
    blended = (rig.skin_weights() @ transforms[:, :3, :].reshape(21, 12)).reshape(-1, 3, 4)
    again = np.einsum("nij,nj->ni", blended[:, :, :3], rest_space) + blended[:, :, 3]
    np.testing.assert_allclose(again, pose.positions["skin"], atol=1e-6)
    basis = bake.bone_basis(np.tile(np.eye(4), (21, 1, 1)), rig.skeleton.parent, transforms)
    assert np.allclose(basis[0], np.eye(4))                                     # the forearm never moves


def test_corrective_shapes_are_a_fixed_set(rig):
    shapes = list(bake.corrective_shapes(rig, settle_time=0.2))
    names = [s.name for s in shapes]
    assert len(names) == len(set(names)) and 20 <= len(shapes) <= 40
    assert sum(n.startswith("FH.bulge.") for n in names) == 9
    weights = bake.corrective_weights(shapes, rig.skeleton.upper, np.ones(42))
    assert np.all(weights == 1.0)
    assert np.all(bake.corrective_weights(shapes, np.zeros(rig.skeleton.dof_count), np.zeros(42)) == 0.0)


def test_hermite_passes_through_its_keys_and_stays_in_range():
    times = np.array([0.0, 0.5, 1.2, 2.0])
    values = np.array([[0.0, 1.0], [1.0, 0.0], [0.2, 0.9], [0.0, 0.0]])
    np.testing.assert_allclose(motion.hermite(times, values, times), values, atol=1e-12)
    dense = motion.hermite(times, values, np.linspace(0, 2, 201))
    assert dense.min() >= 0.0 and dense.max() <= 1.0
    assert np.all(np.abs(np.diff(dense, axis=0)) < 0.05)                        # smooth


def test_a_staged_pose_in_a_motion_squeezes_after_its_key_and_lets_go_before_the_next(rig):
    names = rig.muscle_names
    times, keyed = motion.motion_keys("wave_to_fist", names)
    fist, squeezed = motion.pose_stages("fist", names)
    k = keyed.index(fist)
    assert keyed[k + 1] == fist and keyed[k + 2] == squeezed and keyed[k + 3] == fist
    assert times[k + 1] - times[k] == pytest.approx(motion.SQUEEZE_AFTER)
    assert times[k + 4] - times[k + 3] == pytest.approx(motion.SQUEEZE_RISE)
    times, keyed = motion.motion_keys("showcase", names)                 # the demo's motion squeezes its fist
    assert squeezed in keyed


def _thumb_inside_the_curl(rig) -> float:
    """How far (m) a thumb sample lies on the palm side of the curled middle/ring phalanx it is nearest, less
    the two bones' contact distance (positive: past that phalanx, inside the curl; hand/thumb_contact.py)."""
    tc = rig.thumb_contact
    transforms = rig.skeleton.bone_transforms(rig.pseudo.angles)
    points, between, distance = tc._measure(transforms)
    nearest, rows = np.argmin(distance - tc.distance, axis=1), np.arange(len(points))
    palmar = np.einsum("fij,fj->fi", transforms[tc.finger_owner][:, :3, :3], tc.palmar)
    depth = np.einsum("ti,ti->t", between[rows, nearest], palmar[nearest]) - tc.distance[rows, nearest]
    close = distance[rows, nearest] - tc.distance[rows, nearest] < 0.010
    return float(np.where(tc.curl[nearest] & close, depth, -1.0).max())


def test_the_showcase_thumb_never_snaps_through_the_curled_fingers(rig):
    """Frame by frame through the demo's motion (its fist squeezes, then points, gives a thumbs up): while the
    middle and ring fingers are curled, no thumb DOF turns more than 10 degrees in one frame and no thumb sample
    ends up past the phalanx it rests on. Before the continuous thumb contact the squeeze's rising thenar pull
    carried the held thumb through the fingers in one frame (frame 62: CMC 15.6/9.0 -> 55/-40 degrees, both
    Table 6.4 limits, MCP 27.4 -> 81.4; 29 mm past the phalanx), and it came back out at frames 74-75."""
    names = rig.skeleton.dof_names()
    thumb = [k for k, n in enumerate(names) if n.startswith("thumb-")]
    curl = [[names.index(f"{f}-finger-phalanx-{p}.flexion") for p in ("proximal", "intermediate")]
            for f in ("middle", "ring")]
    _, table = motion.motion_table("showcase", rig.muscle_names, 30.0)
    previous, curled, jumps, inside = None, [], [], []
    for state in bake.simulate_frames(rig, table, DT):
        angles = np.degrees(state.angles)
        curled.append(min(angles[a] + angles[b] for a, b in curl) > 90.0)
        jumps.append(0.0 if previous is None else float(np.abs(angles[thumb] - previous).max()))
        inside.append(_thumb_inside_the_curl(rig))
        previous = angles[thumb]
    curled = np.array(curled)
    assert curled.sum() > 100                                 # the fist, the point and the thumbs up
    assert np.array(jumps)[curled].max() < 10.0
    assert np.array(inside)[curled].max() < 0.0


def test_a_staged_pose_without_room_before_the_next_key_keeps_its_first_stage(rig, tmp_path):
    from faces_hands_addon.core import presets
    doc = json.loads((presets.SHIPPED_FOLDER / "hand" / "poses.json").read_text())
    doc["motions"]["quick_fist"] = {"description": "test", "keys": [[0.0, "relaxed"], [0.8, "fist"], [1.6, "point"]]}
    (tmp_path / "hand").mkdir()
    (tmp_path / "hand" / "poses.json").write_text(json.dumps(doc))
    before = presets.user_folder()
    presets.set_user_folder(tmp_path)
    try:
        times, keyed = motion.motion_keys("quick_fist", rig.muscle_names)
    finally:
        presets.set_user_folder(before)
    fist, squeezed = motion.pose_stages("fist", rig.muscle_names)
    assert squeezed not in keyed and fist in keyed and len(times) == 3


def test_every_preset_pose_and_motion_reads(rig):
    assert {"fist", "point", "thumbs_up", "pinch", "spread", "relaxed", "computer_graphics_scientist"} <= set(
        motion.pose_names())
    for name in motion.motion_names():
        times, table = motion.motion_table(name, rig.muscle_names, 30.0)
        assert table.shape == (len(times), 42) and table.min() >= 0 and table.max() <= 1


def test_contractions_outside_0_1_in_a_preset_are_clamped_with_a_warning(rig, tmp_path):
    """A preset contraction outside [0, 1] is clamped with a warning that names the muscle, the value and the
    file (the hand's bad-input rule: "contractions out of range clamped with a warning"; refused before);
    a value that is no finite number, or an unknown muscle, is still refused."""
    from faces_hands_addon.core import presets
    from faces_hands_addon.core.errors import InputWarning
    doc = json.loads((presets.SHIPPED_FOLDER / "hand" / "poses.json").read_text())
    doc["poses"]["fist"]["contractions"]["flexor_digitorum_profundus_index"] = 1.5
    doc["poses"]["fist"]["contractions"]["extensor_digitorum_index"] = -0.25
    (tmp_path / "hand").mkdir()
    path = tmp_path / "hand" / "poses.json"
    path.write_text(json.dumps(doc))
    before = presets.user_folder()
    presets.set_user_folder(tmp_path)
    try:
        with pytest.warns(InputWarning) as caught:
            values = motion.pose_contractions("fist", rig.muscle_names)
        messages = [str(w.message) for w in caught]
        assert any(str(path) in m and "flexor_digitorum_profundus_index = 1.5" in m and "1 is used" in m
                   for m in messages), messages
        assert any("extensor_digitorum_index = -0.25" in m and "0 is used" in m for m in messages), messages
        assert values["flexor_digitorum_profundus_index"] == 1.0 and values["extensor_digitorum_index"] == 0.0
        doc["poses"]["fist"]["contractions"]["flexor_digitorum_profundus_index"] = "1.5"
        path.write_text(json.dumps(doc))
        with pytest.raises(UserError, match="must be a number"):
            motion.pose_contractions("fist", rig.muscle_names)
    finally:
        presets.set_user_folder(before)
    with pytest.raises(UserError, match="unknown hand muscle"):
        motion.checked_contractions({"biceps": 0.5}, rig.muscle_names, "test")
    with pytest.raises(UserError, match="must be a number in"):
        motion.checked_contractions({"extensor_digitorum_index": float("nan")}, rig.muscle_names, "test")


@pytest.mark.parametrize("squeeze, message", [({"opponens_pollicis": 1.5}, r"squeeze: contraction opponens_pollicis = 1.5 is outside \[0, 1\]; 1 is used"),
                                              ({"biceps": 0.5}, "squeeze: unknown hand muscle 'biceps'")])
def test_a_pose_squeeze_is_checked_like_its_contractions(rig, tmp_path, squeeze, message):
    """A staged pose's second stage (hand/motion.py) gets the contractions' messages (a value out of range
    clamped with a warning, an unknown muscle refused); a file without any squeeze (the format before it)
    still reads, each pose one stage."""
    from faces_hands_addon.core import presets
    from faces_hands_addon.core.errors import InputWarning
    doc = json.loads((presets.SHIPPED_FOLDER / "hand" / "poses.json").read_text())
    (tmp_path / "hand").mkdir()
    before = presets.user_folder()
    presets.set_user_folder(tmp_path)
    try:
        for pose in doc["poses"].values():
            pose.pop("squeeze", None)
        (tmp_path / "hand" / "poses.json").write_text(json.dumps(doc))
        assert all(len(motion.pose_stages(n, rig.muscle_names)) == 1 for n in motion.pose_names())
        doc["poses"]["fist"]["squeeze"] = squeeze
        (tmp_path / "hand" / "poses.json").write_text(json.dumps(doc))
        if "unknown" in message:
            with pytest.raises(UserError, match=message):
                motion.pose_stages("fist", rig.muscle_names)
        else:
            with pytest.warns(InputWarning, match=message):
                stages = motion.pose_stages("fist", rig.muscle_names)
            assert stages[1]["opponens_pollicis"] == 1.0
    finally:
        presets.set_user_folder(before)


def test_stepping_the_bones_alone_turns_them_as_the_whole_step_does(rig):
    """A host that skins the hand itself (the character) steps the joints without the skin: frame by frame
    the same bone transforms as the full step (the skin never moves a bone), for a fist closing into the
    palm (finger contact) and opening again."""
    fist = motion.pose_contractions("fist", list(rig.specs))
    whole, bones = rig.worker_copy(), rig.worker_copy()
    whole.reset()
    bones.reset()
    for frame in range(40):
        values = {"ctrl": fist if frame < 25 else {}}
        expected = whole.step(values, 1 / 30).transforms
        turned = bones.step_bones(values, 1 / 30)
        assert turned.keys() == expected.keys()
        for name, matrix in expected.items():
            assert np.array_equal(turned[name], matrix), (frame, name)
    assert max(abs(whole.pseudo.angles)) > 0.3 and whole.time == bones.time
