"""The face rig on the artist's own mesh (thesis 3.1.2 "Creating New Animatable Head Models from the
Template"): a remeshed, non-uniformly scaled (x 1.15, y 1.05, z 0.9), sculpted copy of the template (longer
nose, fuller cheeks) at 1.7x, and the same face on a full head with ears, neck and shoulders. The mesh's
topology is never changed and each muscle must act the way it does on the default head. Motions are
compared at the landmarks, relative to the face width (tragus to tragus)."""
from dataclasses import replace

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.core import geometry, refine
from faces_hands_addon.core.rig import load_rig
from faces_hands_addon.face.fitted import MAX_VERTICES, FittedFaceRig, build_fitted_rig
from faces_hands_addon.face.rig import FaceRig, build_default_rig
from faces_hands_addon.face.template import build_template, default_inputs
from faces_hands_addon.fitting import testdata
from faces_hands_addon.fitting.template import face_template


@pytest.fixture(scope="module")
def mask():
    # seed 0: at this coarse spacing some seeds' re-triangulation bridges the thin mouth opening
    return testdata.remeshed_face(0, spacing=0.005)


@pytest.fixture(scope="module")
def rig(mask):
    return build_fitted_rig(mask.vertices, mask.faces, seed=0)


@pytest.fixture(scope="module")
def head_rig(head):
    return build_fitted_rig(head.vertices, head.faces, seed=0)


@pytest.fixture(scope="module")
def default():
    return build_default_rig("default")


@pytest.fixture(scope="module")
def parted():
    """The default head with the canonical face's lips as they are (parted, like the test meshes made from
    it): the reference for lip closure, which the closed default head does not need (issue 10)."""
    return FaceRig(build_template("default", replace(default_inputs(), closed_lips=False)))


def landmarks_of(rig, positions):
    positions = np.asarray(positions, np.float64)
    if isinstance(rig, FittedFaceRig):
        return rig.landmark_positions(positions)
    return positions[:468]                    # the default skin keeps the canonical vertex ids


def motion(rig, controls, time=1.2):
    """Landmark positions at rest and settled under ``controls``, and the motion / face width."""
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls(controls)
    rest = landmarks_of(rig, rig.rest_positions)
    moved = landmarks_of(rig, rig.relax(time))
    width = np.linalg.norm(rest[454] - rest[234])
    return rest / width, moved / width, (moved - rest) / width


def similar(fitted: float, reference: float) -> bool:
    """Same sign and within a factor of 2."""
    return fitted * reference > 0 and 0.5 < fitted / reference < 2.0


def test_the_mesh_is_the_skin_vertex_for_vertex(mask, rig):
    assert rig.warnings == []
    np.testing.assert_array_equal(rig.rest_positions, mask.vertices.astype(np.float32))
    np.testing.assert_array_equal(rig.positions, rig.rest_positions)      # exactly, before any step
    np.testing.assert_array_equal(rig.faces, mask.faces.astype(np.int32))
    rig.reset_state()
    rig.reset_controls()
    settled = rig.relax(0.5)
    assert settled.dtype == np.float32 and settled.flags["C_CONTIGUOUS"] and settled.shape == mask.vertices.shape
    assert np.abs(settled - rig.rest_positions).max() < 1e-4 * mask.face_width   # neutral stays at rest
    # head space is human-sized; head_to_mesh is a similarity back to the mesh (1.7x, moved)
    linear = rig.head_to_mesh[:3, :3]
    scale = np.cbrt(np.linalg.det(linear))
    np.testing.assert_allclose(linear.T @ linear, scale ** 2 * np.eye(3), atol=1e-9 * scale ** 2)
    assert 1.5 < scale < 2.2
    np.testing.assert_allclose(rig.to_mesh(rig.fitted.head_vertices), mask.vertices, atol=1e-12)


def test_zygomaticus_major_raises_the_mouth_corner_up_and_outward(rig, default):
    _, _, d = motion(rig, {"zygomaticus_major_L": 1.0})
    _, _, ref = motion(default, {"zygomaticus_major_L": 1.0})
    assert d[291, 0] > 0.01 and d[291, 2] > 0.01                 # +X (outward on the left) and up
    assert similar(d[291, 0], ref[291, 0]) and similar(d[291, 2], ref[291, 2])
    assert np.linalg.norm(d[61]) < 0.3 * np.linalg.norm(d[291])  # the other corner stays


def test_depressor_anguli_oris_lowers_the_mouth_corners(rig, default):
    controls = {"depressor_anguli_oris_L": 1.0, "depressor_anguli_oris_R": 1.0}
    _, _, d = motion(rig, controls)
    _, _, ref = motion(default, controls)
    for corner in (61, 291):
        assert d[corner, 2] < -0.01 and similar(d[corner, 2], ref[corner, 2])


def test_frontalis_raises_and_corrugator_pulls_together_the_brows(rig, default):
    controls = {"frontalis_inner_L": 1.0, "frontalis_inner_R": 1.0}
    _, _, d = motion(rig, controls)
    _, _, ref = motion(default, controls)
    for brow in (107, 336):
        assert d[brow, 2] > 0.01 and similar(d[brow, 2], ref[brow, 2])
    controls = {"corrugator_supercilii_L": 1.0, "corrugator_supercilii_R": 1.0}
    rest, moved, _ = motion(rig, controls)
    ref_rest, ref_moved, _ = motion(default, controls)
    closer = abs(rest[336, 0] - rest[107, 0]) - abs(moved[336, 0] - moved[107, 0])
    ref_closer = abs(ref_rest[336, 0] - ref_rest[107, 0]) - abs(ref_moved[336, 0] - ref_moved[107, 0])
    assert closer > 0.005 and similar(closer, ref_closer)


def test_orbicularis_oris_closes_and_protrudes_the_lips(rig, default, parted):
    pairs = [(13, 14), (82, 87), (312, 317)]                    # inner lip, upper / lower
    closing = {"orbicularis_oris_upper": 1.0, "orbicularis_oris_lower": 1.0}
    rest, moved, d = motion(rig, closing)
    _, _, ref = motion(parted, closing)
    for upper, lower in pairs:
        gap_rest = rest[upper, 2] - rest[lower, 2]
        gap = moved[upper, 2] - moved[lower, 2]
        assert gap_rest > 0.02
        # they meet: at most a quarter of the opening is left, or the upper lip passes a little in front
        assert -0.75 * gap_rest < gap < 0.25 * gap_rest, (upper, gap / gap_rest)
        assert similar(d[upper, 2], ref[upper, 2]) and similar(d[lower, 2], ref[lower, 2])
    _, _, d = motion(rig, {"orbicularis_oris_protrusion": 1.0})
    _, _, ref = motion(default, {"orbicularis_oris_protrusion": 1.0})
    for point in (0, 13, 17):
        assert d[point, 1] < -0.01 and similar(d[point, 1], ref[point, 1])     # forward, -Y


def test_jaw_opens_the_mouth_and_eyelids_close(rig, default):
    rest, moved, d = motion(rig, {"jaw_open": 1.0})
    _, _, ref = motion(default, {"jaw_open": 1.0})
    assert d[152, 2] < -0.1 and similar(d[152, 2], ref[152, 2])                # the chin drops
    assert moved[13, 2] - moved[14, 2] > 5 * (rest[13, 2] - rest[14, 2])      # the lips part
    assert np.linalg.norm(d[[10, 151, 9, 107, 336]], axis=1).max() < 0.003     # the forehead does not move
    rest, moved, _ = motion(rig, {"eyelid_close_R": 1.0, "eyelid_close_L": 1.0})
    for upper, lower in ((159, 145), (386, 374)):
        assert rest[upper, 2] - rest[lower, 2] > 0.02
        assert abs(moved[upper, 2] - moved[lower, 2]) < 0.25 * (rest[upper, 2] - rest[lower, 2])


def test_left_and_right_muscles_act_mirror_symmetrically(rig):
    """The test head is symmetric (its triangulation is not): mirrored muscles give mirrored motion."""
    mirror = face_template().mirror
    flip = np.array([-1.0, 1.0, 1.0])
    cases = {"zygomaticus_major": (291, 61), "depressor_anguli_oris": (291, 61), "risorius": (291, 61),
             "frontalis_inner": (336, 107), "levator_labii_superioris": (267, 37)}
    for base, (left, right) in cases.items():
        assert mirror[left] == right
        _, _, d_left = motion(rig, {base + "_L": 1.0})
        _, _, d_right = motion(rig, {base + "_R": 1.0})
        size = np.linalg.norm(d_right[right])
        assert size > 0.01, base
        assert np.linalg.norm(d_left[left] * flip - d_right[right]) < 0.25 * size, base


def test_a_head_at_100x_moves_the_same_relative_to_its_size(mask, rig):
    big = build_fitted_rig(mask.vertices * 100.0, mask.faces, landmarks=rig.landmarks * 100.0)
    np.testing.assert_allclose(big.head_to_mesh[:3, :3], 100.0 * rig.head_to_mesh[:3, :3], rtol=1e-9)
    assert big.substeps_per_frame() == rig.substeps_per_frame()           # same physics in head space
    for controls in ({"zygomaticus_major_L": 1.0}, {"jaw_open": 1.0, "orbicularis_oris_protrusion": 0.5}):
        _, _, small = motion(rig, controls)
        _, _, large = motion(big, controls)
        np.testing.assert_allclose(large, small, atol=1e-5)


def test_full_head_keeps_scalp_ears_neck_and_shoulders_still(head, head_rig):
    rig = head_rig
    assert rig.warnings == []
    np.testing.assert_array_equal(rig.rest_positions, head.vertices.astype(np.float32))
    # only the face is simulated; everything else is driven or still
    assert rig.template.node_count < 0.5 * len(head.vertices)
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls({"jaw_open": 1.0, "zygomaticus_major_L": 1.0, "frontalis_inner_R": 1.0, "eyelid_close_L": 1.0})
    positions = rig.relax(1.0)
    rest = rig.rest_positions
    width = head.face_width
    truth = head.truth
    back = (rest[:, 1] > truth[:, 1].max() + 0.3 * width) & (rest[:, 2] > truth[1, 2])   # back of the head
    shoulders = rest[:, 2] < truth[152, 2] - 0.6 * width
    ears = (np.abs(rest[:, 0] - head.symmetry_x) > 0.56 * width) & (rest[:, 2] > truth[152, 2])  # outer half
    for region in (back, shoulders, ears):
        assert region.sum() > 50
    np.testing.assert_array_equal(positions[back], rest[back])            # exactly: pinned to the skull
    np.testing.assert_array_equal(positions[shoulders], rest[shoulders])
    # this test head's ear lobes hang just behind the jaw angle: at most a trace of its motion (1.2 % of the
    # face width, 1.9 mm: the lobe moved 1.58 mm under a 1.59 mm limit; on the symmetrised jaw and hinge of
    # c558c17 it moves 1.67 mm, the rest of the ear's outer half 1.23 mm at the 99th percentile)
    assert np.abs(positions[ears] - rest[ears]).max() < 0.012 * width
    chin = rig.landmark_positions(positions)[152] - rig.landmark_positions(rest)[152]
    assert chin[2] < -0.1 * width


def test_settle_moves_the_whole_mesh_as_its_frames_do(head_rig):
    """A settle is its frames: the vertices beyond the face follow the jaw there too."""
    rig = head_rig
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls({"jaw_open": 1.0})
    settled = rig.relax(0.25)                             # 6 frames (the skin is still moving)
    rig.reset_state()
    for _ in range(6):
        stepped = rig.step_frame()
    np.testing.assert_array_equal(settled, stepped)


def test_settle_builds_the_mesh_positions_once(head_rig, monkeypatch):
    """The frames of a settle advance the state only; the mesh positions (every vertex of the artist's
    mesh, mapped from head space) are built once, after the last frame."""
    rig = head_rig
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls({"jaw_open": 1.0})
    built = []
    positions = FittedFaceRig.positions

    def counted(self):
        built.append(1)
        return positions.fget(self)
    monkeypatch.setattr(FittedFaceRig, "positions", property(counted))
    rig.relax(0.25)                                       # 6 frames
    assert len(built) == 1


def test_no_skin_inside_skull_or_jaw_after_all_muscles_and_the_jaw(rig):
    t = rig.template
    bones = t.bones
    face = np.flatnonzero(t.skin.group("surface") & ~t.skin.mouth_region & (t.attachment.bone_depth < 0.012)
                      & ~t.skin.kinematic)
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls({**{name: 1.0 for name in t.muscles.names}, "jaw_open": 1.0, "orbicularis_oris_protrusion": -1})
    rig.relax(1.0)
    positions = rig.face.network.positions.T                  # head space, the simulated nodes
    jaw = rig.rigid_transforms()["jaw"]
    jaw = np.linalg.inv(rig.head_to_mesh) @ jaw @ rig.head_to_mesh
    moved = face[np.linalg.norm(positions[face] - t.skin.vertices[face], axis=1) > 3e-4]
    assert len(moved) > 100
    inside = np.maximum(geometry.winding_number(bones.skull_vertices, bones.skull_faces, positions[moved]),
                        geometry.winding_number(bones.jaw_vertices @ jaw[:3, :3].T + jaw[:3, 3], bones.jaw_faces,
                                                positions[moved]))
    assert not np.any(inside > 0.5)
    assert rig.face.bone_guard.penetration(rig.face.network.positions).max() < 1e-6


def test_parts_bones_transforms_and_fibres_are_in_mesh_coordinates(mask, rig):
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls({"jaw_open": 0.7, "eye_yaw": 0.5})
    transforms = rig.rigid_transforms()
    np.testing.assert_array_equal(transforms["teeth_upper"], np.eye(4))
    np.testing.assert_allclose(transforms["teeth_lower"], transforms["jaw"])
    head = rig.head_to_mesh
    jaw_head = np.linalg.inv(head) @ transforms["jaw"] @ head
    np.testing.assert_allclose(jaw_head, FaceRig.rigid_transforms(rig)["jaw"], atol=1e-9)
    parts = rig.part_meshes()
    for side, contour in (("L", "eye_L"), ("R", "eye_R")):
        centre = parts[f"eye_{side}"].vertices.mean(axis=0)
        opening = mask.truth[face_template().contours[contour]].mean(axis=0)
        assert np.linalg.norm((centre - opening)[[0, 2]]) < 0.03 * mask.face_width   # behind the opening
        assert centre[1] > opening[1]                                              # inside the head
    stomion = 0.5 * (mask.truth[13] + mask.truth[14])
    for name in ("teeth_upper", "teeth_lower", "tongue"):
        vertices = parts[name].vertices                  # centred behind the lips, at the mouth's height
        assert abs(vertices[:, 0].mean() - stomion[0]) < 0.02 * mask.face_width, name
        assert vertices[:, 1].min() > min(mask.truth[13, 1], mask.truth[14, 1]), name
        assert abs(np.median(vertices[:, 2]) - stomion[2]) < 0.1 * mask.face_width, name
    skull, _ = rig.bone_meshes()["skull"]
    assert np.ptp(skull[:, 0]) == pytest.approx(np.ptp(mask.truth[:, 0]), rel=0.35)
    fibres = rig.muscle_fibres()
    points = np.vstack([line for _, line, _ in fibres])
    assert np.abs(points - mask.truth.mean(axis=0)).max() < mask.face_width
    assert np.abs(rig.muscle_display()[0] - points).max() < 1e-6          # the live display too (float32 rounding)
    masks = rig.wrinkle_masks()
    assert masks["forehead"].shape == (len(mask.vertices),) and masks["forehead"].max() > 0.5


def test_same_inputs_give_identical_rigs_and_save_load_round_trips(mask, rig, tmp_path):
    def run(face):
        face.reset_state()
        out = []
        for frame in range(4):
            face.set_controls({"zygomaticus_major_R": frame / 3, "jaw_open": 0.5 * (frame % 2)})
            out.append(face.step_frame(1 / 24).tobytes())
        return out
    again = build_fitted_rig(mask.vertices, mask.faces, landmarks=rig.landmarks)
    assert run(again) == run(rig)
    rig.set_controls({"depressor_anguli_oris_L": 0.6})
    rig.step_frame(1 / 24)
    path = tmp_path / "fitted.npz"
    rig.save(path)
    loaded = load_rig(path)                           # the one registry recognises a fitted rig
    assert isinstance(loaded, FittedFaceRig)
    assert loaded.controls == rig.controls
    np.testing.assert_array_equal(loaded.positions, rig.positions)
    np.testing.assert_array_equal(loaded.head_to_mesh, rig.head_to_mesh)
    assert loaded.step_frame(1 / 24).tobytes() == rig.step_frame(1 / 24).tobytes()


def _sphere(centre, radius, rings=10):
    """A UV sphere (closed, outward triangles)."""
    return testdata.ellipsoid(centre, (radius, radius, radius), rings)


def test_eyeballs_modelled_into_the_mesh_turn_with_the_gaze(mask, rig):
    """A separate piece lying on one of the rigid parts rides it instead of being simulated as skin."""
    eye = rig.part_meshes()["eye_L"].vertices
    centre = eye.mean(axis=0)
    ball, ball_faces = _sphere(centre, 0.97 * np.linalg.norm(eye - centre, axis=1).max())
    vertices = np.vstack([mask.vertices, ball])
    faces = np.vstack([mask.faces, ball_faces + len(mask.vertices)])
    fitted = build_fitted_rig(vertices, faces, landmarks=rig.landmarks)
    own = np.arange(len(mask.vertices), len(vertices))
    assert not np.isin(own, fitted.fitted.network_nodes).any()          # not simulated as skin
    fitted.set_controls({"eye_yaw": 1.0, "eye_pitch": 0.5, "eyelid_close_L": 0.5})
    positions = fitted.step_frame(1 / 24).astype(np.float64)
    gaze = fitted.rigid_transforms()["eye_L"]
    np.testing.assert_allclose(positions[own], ball @ gaze[:3, :3].T + gaze[:3, 3], atol=1e-6 * mask.face_width)
    assert np.abs(positions[own] - ball).max() > 0.03 * mask.face_width


def _fill_holes(vertices, faces):
    """Close every opening but the outer border with a fan (a mesh without mouth or eye openings)."""
    vertices, faces = list(vertices), [faces]
    for loop in refine.boundary_loops(faces[0])[1:]:
        vertices.append(np.mean([vertices[i] for i in loop], axis=0))
        centre = len(vertices) - 1
        faces.append(np.array([[loop[(i + 1) % len(loop)], loop[i], centre] for i in range(len(loop))]))
    return np.array(vertices), np.vstack(faces)


def test_closed_mouth_and_eyes_build_with_warnings(mask, rig):
    vertices, faces = _fill_holes(mask.vertices, mask.faces)
    closed = build_fitted_rig(vertices, faces, landmarks=rig.landmarks)
    text = " ".join(closed.warnings)
    assert "lips cannot part: no mouth opening between the lip contours" in text
    assert "left eyelids cannot open" in text and "right eyelids cannot open" in text
    closed.set_controls({"jaw_open": 1.0})
    assert np.all(np.isfinite(closed.relax(0.5)))


def test_bad_meshes_are_refused_with_a_clear_message(mask):
    with pytest.raises(UserError, match="no faces"):
        build_fitted_rig(mask.vertices, np.zeros((0, 3), np.int64))
    doubled = np.vstack([mask.faces, mask.faces[:5]])
    with pytest.raises(UserError, match=r"[0-9]+ non-manifold edges? .*Clean Up"):
        build_fitted_rig(mask.vertices, doubled)
    huge = np.zeros((MAX_VERTICES + 1, 3))
    with pytest.raises(UserError, match=r"500,000.*Decimate"):
        build_fitted_rig(huge, np.array([[0, 1, 2]]))
    with pytest.raises(UserError, match="landmarks"):
        build_fitted_rig(mask.vertices, mask.faces, landmarks=np.zeros((10, 3)))
    turned = testdata.rotated_head(mask, "+Y")       # found when searched; refused when told it faces -Y
    with pytest.raises(UserError, match=r"face.*forward -Y, up \+Z"):
        build_fitted_rig(turned.vertices, turned.faces, forward="-Y", up="+Z")


def test_the_default_rig_is_in_head_space():
    np.testing.assert_array_equal(build_default_rig("default").head_to_mesh, np.eye(4))
