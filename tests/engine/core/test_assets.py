# SPDX-License-Identifier: GPL-3.0-or-later
"""The default assets load, in the project convention: metres, Z up, face along -Y, +X = character's left.

Counts are exact for the pinned packages (scripts/extract_assets.py); a different count means the
assets changed and these numbers, the NOTICE and the loaders' docstrings need a look.
"""
from __future__ import annotations

import hashlib

import numpy as np
import pytest

from faces_hands_addon import UserError, assets

MIRROR = np.array([-1.0, 1.0, 1.0])

# vertex / triangle counts after merging the STL corners (myo-sim 0.2.4)
HAND_COUNTS = {
    "1mc": (2874, 5744), "thumbprox": (1976, 3948), "thumbdist": (1744, 3484),
    "2mc": (4182, 8360), "2proxph": (2563, 5122), "2midph": (1002, 2000), "2distph": (1105, 2206),
    "3mc": (4045, 8086), "3proxph": (2804, 5604), "3midph": (1119, 2234), "3distph": (1275, 2546),
    "4mc": (3245, 6486), "4proxph": (2634, 5264), "4midph": (1104, 2204), "4distph": (1306, 2608),
    "5mc": (2510, 5016), "5proxph": (1873, 3742), "5midph": (785, 1566), "5distph": (1491, 2979),
    "capitate": (2375, 4746), "hamate": (2585, 5166), "lunate": (1862, 3720), "pisiform": (3523, 7056),
    "scaphoid": (1829, 3654), "trapezium": (2248, 4492), "trapezoid": (1418, 2832),
    "triquetrum": (1588, 3172), "radius": (210, 390), "ulna": (211, 396),
}
HAND_JOINTS = [
    "pro_sup_r", "deviation_r", "flexion_r", "cmc_flexion", "cmc_abduction", "mp_flexion_r",
    "ip_flexion_r", "mcp2_flexion_r", "mcp2_abduction_r", "pm2_flexion_r", "md2_flexion_r",
    "mcp3_flexion_r", "mcp3_abduction_r", "pm3_flexion_r", "md3_flexion", "mcp4_flexion_r",
    "mcp4_abduction_r", "pm4_flexion", "md4_flexion_r", "mcp5_flexion_r", "mcp5_abduction_r",
    "pm5_flexion_r", "md5_flexion_r"]


def mirror_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """For each point of ``a``, the distance to the nearest point of ``b`` mirrored in X."""
    mirrored = b * MIRROR
    out = np.empty(len(a))
    for start in range(0, len(a), 512):
        chunk = a[start:start + 512]
        out[start:start + 512] = np.sqrt(((chunk[:, None] - mirrored[None]) ** 2).sum(-1)).min(1)
    return out


def check_mesh(mesh: assets.Mesh) -> None:
    assert mesh.vertices.dtype == np.float64 and mesh.vertices.shape[1] == 3
    assert mesh.faces.shape[1] == 3 and mesh.faces.dtype.kind == "i"
    assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)
    assert np.isfinite(mesh.vertices).all()
    if mesh.normals is not None:
        assert np.allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)


def outward_fraction(mesh: assets.Mesh) -> float:
    """Share of triangle area whose normal points away from the mesh centroid (closed-ish shells)."""
    tri = mesh.vertices[mesh.faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    away = tri.mean(1) - mesh.vertices.mean(0)
    area = np.linalg.norm(normal, axis=1)
    return float(area[(normal * away).sum(1) > 0].sum() / area.sum())


# ------------------------------------------------------------------------------------------- face

def test_canonical_face_counts_units_and_orientation():
    face = assets.canonical_face()
    check_mesh(face)
    assert face.vertices.shape == (468, 3) and face.faces.shape == (898, 3)
    size = np.ptp(face.vertices, axis=0)
    assert 0.12 < size[0] < 0.2 and 0.08 < size[1] < 0.16 and 0.15 < size[2] < 0.22  # metres
    v = face.vertices
    assert int(np.argmin(v[:, 1])) in (1, 4, 5, 19)                 # nose tip is the most -Y point
    assert v[10, 2] > v[4, 2] > v[13, 2] > v[152, 2]                 # forehead > nose > lips > chin
    assert v[263, 0] > 0 > v[33, 0]                                  # MediaPipe's left eye = +X
    assert (face.normals @ [0.0, -1.0, 0.0]).mean() > 0.5            # the skin faces -Y
    assert np.median(mirror_distance(v, v)) < 1e-6                   # MediaPipe's mesh is symmetric
    assert face.uvs.shape == (468, 2) and (face.uvs >= 0).all() and (face.uvs <= 1).all()
    assert face.uvs[10, 1] > face.uvs[152, 1] and face.uvs[263, 0] > face.uvs[33, 0]  # v up (Blender)


def test_face_contours_reference_valid_vertices_on_the_right_side():
    contours = assets.face_contours()
    face = assets.canonical_face().vertices
    expected = {"lips_outer_upper", "lips_outer_lower", "lips_inner_upper", "lips_inner_lower",
                "eye_L", "eye_R", "eye_L_upper", "eye_L_lower", "eye_R_upper", "eye_R_lower",
                "eyebrow_L_upper", "eyebrow_L_lower", "eyebrow_R_upper", "eyebrow_R_lower",
                "face_oval", "nose_bridge", "nose_lower_outline"}
    assert set(contours.lines) == expected
    for name, indices in contours.lines.items():
        assert indices.dtype.kind == "i" and len(indices) >= 4, name
        assert indices.min() >= 0 and indices.max() < 468, name
        assert len(set(indices.tolist())) == len(indices), name
        if name.endswith("_L") or "_L_" in name:
            assert face[indices, 0].mean() > 0.01, name
        if name.endswith("_R") or "_R_" in name:
            assert face[indices, 0].mean() < -0.01, name
    assert contours.lines["lips_inner_upper"].tolist() == [78, 191, 80, 81, 82, 13, 312, 311, 310, 415, 308]
    assert contours.lines["lips_inner_lower"].tolist() == [78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308]
    assert contours.closed["eye_L"] and contours.closed["face_oval"] and not contours.closed["eye_L_upper"]
    for side in "LR":
        upper, lower = contours.lines[f"eye_{side}_upper"], contours.lines[f"eye_{side}_lower"]
        assert face[upper, 2].mean() > face[lower, 2].mean()
        assert face[contours.lines[f"eyebrow_{side}_upper"], 2].mean() > face[upper, 2].mean()
    assert face[contours.lines["lips_outer_upper"], 2].mean() > face[contours.lines["lips_outer_lower"], 2].mean()
    assert set(contours.refined_only) == {"iris_L", "iris_R"}
    assert all(ids.min() >= 468 for ids in contours.refined_only.values())


# ---------------------------------------------------------------------------------- skull and jaw

def test_skull_and_jaw_upright_facing_minus_y():
    skull, jaw = assets.skull(), assets.jaw()
    for mesh in (skull, jaw):
        check_mesh(mesh)
    assert skull.vertices.shape == (3305, 3) and skull.faces.shape == (6589, 3)
    assert jaw.vertices.shape == (1459, 3) and jaw.faces.shape == (2916, 3)
    size = np.ptp(skull.vertices, axis=0)
    assert 0.12 < size[0] < 0.17 and 0.15 < size[1] < 0.2 and 0.14 < size[2] < 0.19  # metres
    s, j = skull.vertices, jaw.vertices
    centre = s.mean(0)
    top = s[np.argmax(s[:, 2])]
    assert abs(top[0]) < 0.02 and top[2] - centre[2] > 0.08           # the vault is up (+Z)
    assert j[:, 2].min() < s[:, 2].min() and j.mean(0)[2] < centre[2]  # the jaw hangs below
    assert j.mean(0)[1] < centre[1] - 0.015                           # ... in front (-Y)
    teeth = s[s[:, 2] < np.percentile(s[:, 2], 10)]                   # lowest skull points: the teeth
    assert teeth[:, 1].mean() < centre[1]                             # the face side is -Y
    assert abs(s[:, 0].min() + s[:, 0].max()) < 0.005                 # left/right symmetric in X
    assert np.median(mirror_distance(s[::3], s)) < 0.002
    assert np.median(mirror_distance(j[::2], j)) < 0.003
    assert outward_fraction(skull) > 0.6 and outward_fraction(jaw) > 0.5  # winding kept (rotation)


# ------------------------------------------------------------------------------------------- hand

def test_hand_bones_exact_counts_and_rest_pose():
    bones = assets.hand_bones()
    assert set(bones) == set(HAND_COUNTS) and len(assets.HAND_BONES) == 27
    for name, mesh in bones.items():
        check_mesh(mesh)
        assert (len(mesh.vertices), len(mesh.faces)) == HAND_COUNTS[name], name
        assert np.ptp(mesh.vertices, axis=0).max() < 0.3, name        # metres, not millimetres
    centre = {name: mesh.vertices.mean(0) for name, mesh in bones.items()}
    assert np.linalg.norm(centre["lunate"]) < 0.01                     # origin = wrist centre
    assert centre["3distph"][2] < centre["3proxph"][2] < centre["3mc"][2] < 0  # fingers hang (-Z)
    assert centre["radius"][2] > 0.05 and centre["ulna"][2] > 0.05    # forearm above the wrist
    assert centre["thumbdist"][1] < centre["2mc"][1] < centre["5mc"][1]  # thumb side forward (-Y)
    assert centre["radius"][1] < centre["ulna"][1]
    assert set(assets.hand_bones(include_forearm=False)) == set(assets.HAND_BONES)


def test_myohand_model_joints_muscles_sites():
    model = assets.myohand_model()
    assert [j.name for j in model.joints] == HAND_JOINTS
    for joint in model.joints:
        assert joint.kind == "hinge" and joint.body in model.bodies
        assert np.isclose(np.linalg.norm(joint.axis), 1.0) and joint.range[0] < joint.range[1]
        assert np.linalg.norm(joint.position) < 0.35
    by_name = {j.name: j for j in model.joints}
    for finger in "2345":    # finger flexion axes run across the hand (Y), the palm faces +X
        assert abs(by_name[f"mcp{finger}_flexion_r"].axis[1]) > 0.8
    assert by_name["flexion_r"].range == (-0.785398, 0.785398)
    assert len(model.muscles) == 39
    forces = {m.name: m.force for m in model.muscles}
    assert forces["FDP2"] == 197.3 and forces["EDC2"] == 48.8 and min(forces.values()) > 0
    for muscle in model.muscles:
        assert len(muscle.path) >= 2 and muscle.length_range[0] < muscle.length_range[1]
        assert all(p.kind in ("site", "wrap") and p.body in model.bodies for p in muscle.path)
    fds = {m.name: m for m in model.muscles}["FDS3"].path[-1].position
    edc = {m.name: m for m in model.muscles}["EDC3"].path[-1].position
    assert fds[0] > edc[0]                                            # flexors on the palm side (+X)
    for stem in assets.HAND_BONES:
        assert any(stem in b.meshes for b in model.bodies.values()), stem
    assert model.wrist_origin[0] < -0.1                               # MyoArm is a right arm (-X)


@pytest.mark.parametrize("side", ["left", "right"])
def test_webxr_hand_loads_skinned(side):
    hand = assets.webxr_hand(side)
    check_mesh(hand.mesh)
    assert hand.mesh.vertices.shape == (1360, 3) and hand.mesh.faces.shape == (2314, 3)
    assert len(hand.joint_names) == 25 and hand.rest_world.shape == (25, 4, 4)
    assert hand.skin_joints.shape == (1360, 4) and hand.skin_joints.max() < 25
    assert np.allclose(hand.skin_weights.sum(1), 1.0, atol=1e-5)
    assert np.allclose(hand.rest_world @ hand.inverse_bind, np.eye(4), atol=1e-5)
    assert np.ptp(hand.mesh.vertices, axis=0).max() < 0.3             # metres
    pos = {n: hand.rest_world[i][:3, 3] for i, n in enumerate(hand.joint_names)}
    sign = 1 if side == "left" else -1
    assert sign * pos["wrist"][0] > 0.02                              # left hand at +X
    assert pos["middle-finger-tip"][2] < pos["wrist"][2] - 0.1        # fingers hang (-Z)
    assert pos["thumb-tip"][1] < pos["pinky-finger-tip"][1] - 0.05    # thumb forward (-Y)
    assert sign * (pos["thumb-tip"][0] - pos["wrist"][0]) < 0         # thumb towards the body
    assert (hand.mesh.uvs >= -1e-6).all() and (hand.mesh.uvs <= 1 + 1e-6).all()


def test_webxr_hands_mirror_each_other():
    left, right = assets.webxr_hand("left"), assets.webxr_hand("right")
    assert np.percentile(mirror_distance(left.mesh.vertices, right.mesh.vertices), 95) < 0.004
    with pytest.raises(UserError):
        assets.webxr_hand("middle")


# ------------------------------------------------------------------------------------ bad files

@pytest.mark.parametrize("relative, reader", [
    ("myo_sim/models/meshes/hat_jaw.stl", "read_stl"),
    ("webxr/generic-hand/left.glb", "read_glb"),
    ("mediapipe/canonical_face.obj", "read_obj"),
])
@pytest.mark.parametrize("keep", [0.5, 0.97, 10])
def test_truncated_files_raise_user_error(tmp_path, relative, reader, keep):
    data = (assets.ASSETS_DIR / relative).read_bytes()
    cut = tmp_path / ("cut" + relative[relative.rindex("."):])
    cut.write_bytes(data[:int(len(data) * keep)] if keep < 1 else data[:keep])
    with pytest.raises(UserError) as info:
        getattr(assets, reader)(cut)
    assert cut.name in str(info.value)


def test_ascii_stl_reads_and_truncated_ascii_fails(tmp_path):
    def facet(*corners):
        rows = "".join(f"  vertex {x} {y} {z}\n" for x, y, z in corners)
        return f"facet normal 0 0 1\n outer loop\n{rows} endloop\nendfacet\n"

    text = ("solid t\n" + facet((0, 0, 0), (1, 0, 0), (0, 1, 0)) + facet((1, 0, 0), (1, 1, 0), (0, 1, 0))
            + "endsolid t\n")
    good = tmp_path / "a.stl"
    good.write_text(text)
    vertices, faces = assets.read_stl(good)
    assert vertices.shape == (4, 3) and faces.shape == (2, 3)         # shared corners merged
    bad = tmp_path / "b.stl"
    bad.write_text(text[: text.index("endloop")])
    with pytest.raises(UserError):
        assets.read_stl(bad)


def test_garbage_glb_json_raises_user_error(tmp_path):
    data = bytearray((assets.ASSETS_DIR / "webxr/generic-hand/right.glb").read_bytes())
    data[20:24] = b"{{{{"
    bad = tmp_path / "bad.glb"
    bad.write_bytes(bytes(data))
    with pytest.raises(UserError):
        assets.read_glb(bad)


# ---------------------------------------------------------------------------------- checksums

def test_sha256sums_match_the_files_on_disk():
    root = assets.ASSETS_DIR
    listed = {}
    for line in (root / "SHA256SUMS").read_text(encoding="ascii").splitlines():
        digest, name = line.split("  ", 1)
        listed[name] = digest
    on_disk = {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()} - {"SHA256SUMS"}
    assert set(listed) == on_disk
    for name, digest in listed.items():
        assert hashlib.sha256((root / name).read_bytes()).hexdigest() == digest, name
