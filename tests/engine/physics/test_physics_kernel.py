"""The fused numba kernel (physics/kernel.py) against the numpy reference path of the integrator (thesis
3.1.2 "Mass Spring Network"): same network, same frames, positions agree to 1e-9 m."""
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from faces_hands_addon.physics import Attachments, LeapfrogIntegrator, SpringNetwork, SpringSet, kernel

pytestmark = pytest.mark.skipif(importlib.util.find_spec("numba") is None,
                                reason="numba is not importable here (the numpy path is the only one)")

TOLERANCE_M = 1e-9


def grid(n=16, spacing=0.01, k_soft=20.0, ratio=4.0, threshold=0.1, attach=0.5, attached=None):
    """A sheet with biphasic edge and diagonal springs and zero-rest attachment pairs (as the face: one
    per node in node order, or on the nodes ``attached`` in that order)."""
    xs, zs = np.meshgrid(np.arange(n), np.arange(n))
    positions = np.stack([xs.ravel() * spacing, np.zeros(n * n), zs.ravel() * spacing], 1)
    index = np.arange(n * n).reshape(n, n)
    edges = np.concatenate([np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1),
                            np.stack([index[:-1, :].ravel(), index[1:, :].ravel()], 1),
                            np.stack([index[:-1, :-1].ravel(), index[1:, 1:].ravel()], 1)])
    rest = np.linalg.norm(positions[edges[:, 1]] - positions[edges[:, 0]], axis=1) * 0.97
    springs = SpringSet(edges[:, 0], edges[:, 1], rest, k_soft, k_soft * ratio, threshold, k_soft * 0.5)
    depth = np.array([[0.0], [0.004], [0.0]])
    attached = np.arange(n * n) if attached is None else np.asarray(attached)
    attachments = Attachments(attached, attach, 0.0, positions.T[:, attached] + depth,
                              positions.T[:, attached] - depth)
    return SpringNetwork(positions, 1e-3, springs, attachments)


def _drive(backend, kinematic=0, every=4, frames=30, attached=None):
    net = grid(n=16, attached=attached)
    net.kinematic[:kinematic] = True
    integrator = LeapfrogIntegrator(net, 0.02)
    integrator.backend = backend
    att = net.attachments
    anchor0, mirror0 = att.anchor.copy(), att.mirror.copy()
    calls = []
    for frame in range(frames):
        offset = np.array([[0.002 * np.cos(frame / 5)], [0.003 * np.sin(frame / 3)], [0.001]])
        driven = net.positions.copy()
        driven[1, :kinematic] += 0.0005 * frame
        used = integrator.advance(1 / 24, anchor=anchor0 + offset, mirror=mirror0 + offset,
                                  driven=driven if kinematic else None,
                                  constraint=lambda x, v, fraction: calls.append(fraction), constraint_every=every)
        calls.append(("frame", used))
    return net.positions.copy(), integrator.velocity.copy(), integrator.time, calls


@pytest.mark.parametrize("kinematic, every", [(0, 4), (5, 1), (5, 3)])
def test_fused_kernel_matches_numpy_reference(kinematic, every):
    assert kernel.available(), kernel._STATE["error"]
    ref = _drive("numpy", kinematic, every)
    fused = _drive("numba", kinematic, every)
    assert np.abs(ref[0] - fused[0]).max() < TOLERANCE_M
    assert np.abs(ref[1] - fused[1]).max() < 1e-6           # m/s
    assert ref[2] == pytest.approx(fused[2], abs=1e-12)
    assert ref[3] == fused[3]                                # the guard runs at the same fractions


@pytest.mark.parametrize("attached", [np.arange(256)[::-1], np.arange(0, 256, 3),
                                      np.random.default_rng(0).permutation(256)[:200]])
def test_fused_kernel_matches_numpy_with_attachments_in_any_order(attached):
    """Attachments that are not one per node in node order (reversed, on some nodes, shuffled) take the
    kernel's indexed attachment loop."""
    ref = _drive("numpy", attached=attached)
    fused = _drive("numba", attached=attached)
    assert np.abs(ref[0] - fused[0]).max() < TOLERANCE_M
    assert np.abs(ref[1] - fused[1]).max() < 1e-6


@pytest.mark.parametrize("materials", [1, 3, 4, 5, 300])
def test_fused_kernel_matches_numpy_with_any_number_of_spring_materials(materials):
    """The kernel reads a spring's constants from its material: up to four materials by comparison (the
    face has three), more from the table; per-spring stiffness and thresholds drawn from ``materials``
    distinct values give the numpy path's motion."""
    runs = []
    for backend in ("numpy", "numba"):
        net = grid(n=12)
        sp = net.springs
        kind = np.random.default_rng(materials).integers(0, materials, sp.count)
        soft = np.linspace(10.0, 30.0, materials)[kind]
        springs = SpringSet(sp.start, sp.end, sp.rest, soft, soft * np.linspace(1.0, 5.0, materials)[kind],
                            np.linspace(0.05, 0.2, materials)[kind], soft * np.linspace(0.2, 1.0, materials)[kind])
        network = SpringNetwork(net.positions.T, 1e-3, springs, net.attachments)
        material, table = network.kernel_materials
        assert len(table) == max(4, len(np.unique(kind))) and material.max() == len(np.unique(kind)) - 1
        integrator = LeapfrogIntegrator(network, 0.02)
        integrator.backend = backend
        start = network.positions.copy()
        offset = np.array([[0.002], [0.003], [-0.001]])
        for _ in range(10):
            integrator.advance(1 / 24, anchor=network.attachments.anchor + offset,
                               mirror=network.attachments.mirror + offset)
        runs.append(network.positions.copy())
    assert np.abs(runs[0] - runs[1]).max() < TOLERANCE_M and np.abs(runs[0] - start).max() > 1e-4


def test_spring_materials_rebuild_every_springs_constants_bit_for_bit():
    """What the kernel forms from a spring's material is what the numpy path reads: the same bytes."""
    from faces_hands_addon.face.rig import build_default_rig
    net = build_default_rig("default").face.network
    material, table = net.kernel_materials
    assert material.dtype == np.uint8 and len(np.unique(material)) == 3       # skin, lid/lip, stiff-less lining
    rows = table[material]
    sp = net.springs
    assert np.array_equal(rows[:, 0], sp.k_soft) and np.array_equal(rows[:, 1], net._k_extra)
    assert np.array_equal(rows[:, 2], net._k_yield)
    assert np.array_equal(rows[:, 3] * sp.rest, net._knee)
    assert np.array_equal(np.maximum(sp.rest * rows[:, 4], 1e-12), net._min_length)


def test_fused_kernel_matches_on_the_default_face():
    from faces_hands_addon.face.rig import build_default_rig
    rig = build_default_rig("default")
    results = []
    for backend in ("numpy", "numba"):
        rig.reset_state()
        rig.reset_controls()
        rig.face.set_backend(backend)
        rig.set_controls({"jaw_open": 0.6, "zygomaticus_major_L": 0.8, "orbicularis_oris_protrusion": 0.5})
        for _ in range(12):
            rig.step_frame(1 / 24)
        results.append(rig.face.network.positions.copy())
    assert np.abs(results[0] - results[1]).max() < TOLERANCE_M


def test_kernel_switch(monkeypatch):
    monkeypatch.setenv(kernel.ENV_VARIABLE, "numpy")
    assert kernel.substep_kernel() is None and kernel.guard_kernels() is None   # the reference, on request
    monkeypatch.delenv(kernel.ENV_VARIABLE)
    assert kernel.substep_kernel() is not None
    assert kernel.compile_seconds() is not None and kernel.compile_seconds() > 0


def test_compiled_code_is_cached_in_the_given_folder_only(tmp_path):
    """numba's cache goes to the folder the add-on names (its user folder), never beside the sources."""
    package = Path(kernel.__file__).parent
    before = set(package.rglob("*.nbi")) | set(package.rglob("*.nbc"))
    script = ("import sys; from faces_hands_addon.physics import kernel; "
              f"kernel.set_cache_folder({str(tmp_path / 'numba')!r}); "
              "sys.exit(0 if kernel.substep_kernel() is not None else 1)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env.pop("NUMBA_CACHE_DIR", None)
    subprocess.run([sys.executable, "-c", script], check=True, env=env, timeout=600)
    assert list((tmp_path / "numba").rglob("*.nbi")) and list((tmp_path / "numba").rglob("*.nbc"))
    assert set(package.rglob("*.nbi")) | set(package.rglob("*.nbc")) == before


@pytest.mark.parametrize("fraction", [0.25, 1.0])
def test_compiled_guards_match_numpy(fraction):
    from faces_hands_addon.physics import BoneHalfSpaceGuard, CapBulge, SphereGuard
    rng = np.random.default_rng(7)
    nodes = np.sort(rng.choice(400, 150, replace=False))
    point, normal = rng.normal(size=(3, 150)) * 0.01, rng.normal(size=(3, 150))
    outcome = []
    for backend in ("numpy", "numba"):
        x, v = np.random.default_rng(3).normal(size=(3, 400)) * 0.01, np.random.default_rng(4).normal(size=(3, 400))
        guard = BoneHalfSpaceGuard(nodes, point, normal, np.zeros(150, np.int64), 0.002)
        guard.backend = backend
        guard.set_bone_transforms([np.eye(4)])
        guard.begin_frame()
        moved = np.eye(4)
        moved[:3, 3] = [0.001, -0.002, 0.003]
        guard.set_bone_transforms([moved])
        guard(x, v, fraction)
        eye = SphereGuard(nodes[::2], [0.001, 0.0, -0.002], 0.008)
        eye.backend = backend
        eye(x, v, fraction)
        # the lid guard as the face uses it: cornea bulge with per-node sag, let off near the rest place
        sag = np.linspace(0.0, 0.0004, len(nodes[1::2]))
        rest = x[:, nodes[1::2]] + np.random.default_rng(5).normal(size=(3, len(nodes[1::2]))) * 0.0005
        lid = SphereGuard(nodes[1::2], [0.0, 0.004, 0.0], 0.009, extra=CapBulge(0.009, 0.035, 32.0, sag),
                          rest=rest, fade=0.0015)
        lid.backend = backend
        before = x[:, lid.nodes].copy()
        lid(x, v, fraction)
        pushed = np.sqrt(np.einsum("ij,ij->j", x[:, lid.nodes] - before, x[:, lid.nodes] - before)) > 1e-6
        assert 5 < pushed.sum() < len(lid.nodes)                  # the lid guard acted on some nodes, not all
        outcome.append((x, v))
    assert np.abs(outcome[0][0] - outcome[1][0]).max() < TOLERANCE_M
    assert np.abs(outcome[0][1] - outcome[1][1]).max() < 1e-9
    assert np.abs(outcome[0][0] - np.random.default_rng(3).normal(size=(3, 400)) * 0.01).max() > 1e-4  # guards acted


def test_frames_do_not_depend_on_what_ran_before_in_the_process():
    """The kernel and the numpy path agree to rounding only, so the "auto" backend makes one choice per
    process (physics/kernel.py): a fresh process's first frames of the default head (a small network, a
    short take), and the same frames once a long take or the live preview has loaded the kernel, are the
    same bytes (the old rule gave them numpy, then the kernel: two files for one line)."""
    script = (
        "import sys, hashlib; from faces_hands_addon.physics import kernel as k; "
        "from faces_hands_addon.face.rig import build_default_rig; "
        "rig = build_default_rig('default')\n"
        "def frames():\n"
        "    rig.reset_state(); out = hashlib.sha256()\n"
        "    for n in range(4):\n"
        "        rig.set_controls({'zygomaticus_major_R': n / 3, 'jaw_open': 0.5 * (n % 2)})\n"
        "        out.update(rig.step_frame(1 / 24).tobytes())\n"
        "    return out.digest()\n"
        "first = frames(); used = k.loaded(); k.substep_kernel(); later = frames()\n"
        "sys.exit(0 if (first == later and used) else 1)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env.pop(kernel.ENV_VARIABLE, None)
    subprocess.run([sys.executable, "-c", script], check=True, env=env, timeout=600)


def test_compiled_nearest_bone_vertex_matches_the_kd_tree():
    """The skin guard's re-anchoring asks for the nearest bone vertex within reach; the compiled grid
    search (anchor_kernel.nearest_in_bone: own cube first, farther cubes skipped) must give the KD-tree's
    answer: same vertex, same distance, none beyond reach, on each of two packed bones."""
    from scipy.spatial import cKDTree
    from faces_hands_addon.physics import anchor_kernel
    search = kernel.compiled(anchor_kernel.nearest_in_bone)
    assert search is not None
    rng = np.random.default_rng(9)
    reach = 0.02
    bones = []
    for scale in ([1.0, 1.2, 1.1], [0.6, 0.5, 0.7]):
        direction = rng.normal(size=(3000, 3))
        bones.append(0.08 * direction / np.linalg.norm(direction, axis=1, keepdims=True) * scale)
    grids = anchor_kernel.pack_grids([(v, -v) for v in bones], reach)
    for bone, vertices in enumerate(bones):
        points = vertices[rng.integers(0, len(vertices), 4000)] * rng.uniform(0.7, 1.4, (4000, 1))
        points[:50] += 1.0                                                     # far outside the grid
        found = [search(*p, bone, grids.vertices, grids.order, grids.starts, grids.cube_start,
                        grids.origin, grids.dims, grids.cell, reach) for p in points]
        dist = np.array([d for d, _ in found])
        index = np.array([v - grids.vertex_start[bone] if v >= 0 else len(vertices) for _, v in found])
        expected_dist, expected_index = cKDTree(vertices).query(points, distance_upper_bound=reach)
        assert np.array_equal(index, expected_index)
        assert np.array_equal(np.isinf(dist), np.isinf(expected_dist))
        finite = np.isfinite(dist)
        assert np.abs(dist[finite] - expected_dist[finite]).max() < 1e-15
        assert 0.2 < finite.mean() < 0.98                                      # both cases occur


def test_compiled_re_anchoring_picks_the_numpy_planes():
    """The skin and teeth guards' once-per-frame re-anchoring (collision.BoneHalfSpaceGuard.refresh) in the
    compiled loops (physics/anchor_kernel.py) must pick the same nodes, bone vertices and planes as the numpy
    reference, with the jaw turned and the skin slid along the bones, the exact closest points included."""
    import copy
    from faces_hands_addon.face.rig import build_default_rig
    face = build_default_rig("default").face
    jaw = np.eye(4)
    angle = np.radians(12.0)
    jaw[1:3, 1:3] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    jaw[:3, 3] = [0.0, -0.004, -0.006]
    for name in ("bone_guard", "teeth_guard"):
        guards = {backend: copy.deepcopy(getattr(face, name)) for backend in ("numpy", "numba")}
        rng = np.random.default_rng(11)
        x = face.network.positions.copy()
        changed = 0
        for round_ in range(4):
            x = x + rng.normal(size=x.shape) * 0.0012                       # most nodes slide past 1.5 mm
            for backend, guard in guards.items():
                guard.backend = backend
                guard.begin_frame()
                guard.set_bone_transforms([np.eye(4), jaw if round_ % 2 else np.eye(4)])
                guard.refresh(x)
            reference, compiled = guards["numpy"], guards["numba"]
            assert np.array_equal(reference.bone, compiled.bone)
            for field in ("local_point", "local_normal", "point", "normal", "_last"):
                assert np.abs(getattr(reference, field) - getattr(compiled, field)).max() < 1e-15, (name, field)
            changed += int((reference.bone == 1).sum())
        assert changed > 0                                                  # the jaw's planes were chosen too


def test_compiled_lid_rotation_matches_numpy(monkeypatch):
    """The lids' per-frame rotation (face/lid_kernel.py, used once the kernel is loaded) against the numpy
    reference (kinematics.LidRig.rotate_lid): closing, gaze, levator and squeeze, out-of-range values
    clipped alike, the cornea lift included."""
    from faces_hands_addon.face.rig import build_default_rig
    lids = build_default_rig("default").template.organs.lids
    kernel.substep_kernel()
    assert kernel.loaded()
    rng = np.random.default_rng(5)
    rest = build_default_rig("default").template.skin.vertices
    lifted = 0
    for values in [(1.0, 0.0, 0.0, 0.0), (1.3, -1.4, 0.5, 1.2), *rng.uniform(-0.2, 1.2, (12, 4))]:
        for lid in lids.values():
            lid_rest = rest[lid.index]
            compiled = lid.rotate_lid(lid_rest, *values)
            with monkeypatch.context() as patch:
                patch.setattr(kernel, "loaded", lambda: False)
                reference = lid.rotate_lid(lid_rest, *values)
            assert np.abs(compiled - reference).max() < 1e-15
            lifted += int((np.linalg.norm(reference - lid.centre, axis=1)
                           > np.linalg.norm(lid_rest - lid.centre, axis=1) + 1e-6).sum())
    assert lifted > 0                                                      # the cornea lift acted


def test_compiled_muscle_pull_matches_numpy(monkeypatch):
    """The muscles' pull on the attachments (face/attachment_kernel.py, used once the kernel is loaded)
    against the numpy reference (attachment.AttachmentMap.muscle_displacement + jaw_frame_correction):
    random control-point displacements, the jaw at rest and turned, opened and pushed forward."""
    from faces_hands_addon.face.kinematics import jaw_matrix
    from faces_hands_addon.face.rig import build_default_rig
    rig = build_default_rig("default")
    attachment, muscles = rig.template.attachment, rig.template.muscles
    kernel.substep_kernel()
    assert kernel.loaded()
    rng = np.random.default_rng(7)
    bones = rig.template.bones
    jaws = [jaw_matrix(bones.tmj_pivot, bones.tmj_axis, *values, glide=bones.jaw_glide)
            for values in rng.uniform(-0.3, 1.0, (4, 4))]
    for jaw in (np.eye(4), *jaws):
        displacement = rng.normal(size=muscles.rest.shape) * 0.003
        start = rng.normal(size=(len(attachment.jaw_weight), 3)) * 0.05
        compiled, reference = start.copy(), start.copy()
        attachment.add_muscle_pull(displacement, muscles.rest, muscles.jaw_carry, jaw, compiled)
        with monkeypatch.context() as patch:
            patch.setattr(kernel, "loaded", lambda: False)
            attachment.add_muscle_pull(displacement, muscles.rest, muscles.jaw_carry, jaw, reference)
        assert np.abs(reference - start).max() > 1e-4                     # the muscles pulled
        assert np.abs(compiled - reference).max() < 1e-15


def test_compiled_muscle_deformation_matches_numpy(monkeypatch):
    """The muscles' per-frame deformation (face/muscle_kernel.py, used once the kernel is loaded) against
    the numpy reference (muscles.MuscleSystem.deform): random contractions (out-of-range ones clipped
    alike), protrusion forward, back and none, the jaw at rest and posed, parted rest lips; points,
    displacements and thicknesses."""
    from faces_hands_addon.face.kinematics import jaw_matrix
    from faces_hands_addon.face.rig import build_default_rig
    import copy
    template = build_default_rig("default").template
    muscles, bones = copy.deepcopy(template.muscles), template.bones
    kernel.substep_kernel()
    assert kernel.loaded()
    rng = np.random.default_rng(3)
    muscles.set_rest_closing(rng.normal(size=muscles.rest.shape) * 0.002)   # parted rest lips (a fitted head)
    moved = 0.0
    for trial in range(12):
        contraction = rng.uniform(0.0, 1.0, len(muscles.names)) * (rng.uniform(size=len(muscles.names)) < 0.6)
        protrusion = (0.0, rng.uniform(0.1, 1.0), rng.uniform(-1.0, -0.1))[trial % 3]
        jaw = jaw_matrix(bones.tmj_pivot, bones.tmj_axis, *rng.uniform(-0.3, 1.0, 4),
                         glide=bones.jaw_glide) if trial % 2 else np.eye(4)
        compiled = muscles.deform(contraction, protrusion, jaw)
        with monkeypatch.context() as patch:
            patch.setattr(kernel, "loaded", lambda: False)
            reference = muscles.deform(contraction, protrusion, jaw)
        for field in ("points", "displacement", "thickness"):
            assert np.abs(getattr(compiled, field) - getattr(reference, field)).max() < 1e-15, field
        moved = max(moved, float(np.abs(reference.displacement).max()))
    assert moved > 1e-3                                                    # the muscles contracted


def test_compiled_sliver_ties_match_numpy(monkeypatch):
    """The sliver ties' placement (face/sliver_kernel.py, used once the kernel is loaded) against the numpy
    reference (network.SliverTies.__call__): a strip of flat triangles, whose ties share nodes (several
    batches; an apex is another tie's edge end), on jittered positions and velocities."""
    from faces_hands_addon.face.network import SliverTies
    rng = np.random.default_rng(11)
    count = 40
    vertices = np.stack([np.arange(count) * 0.001, np.zeros(count), rng.uniform(-1e-4, 1e-4, count)], 1)
    faces = np.stack([np.arange(count - 2), np.arange(1, count - 1), np.arange(2, count)], 1)
    ties = SliverTies.build(vertices, faces, np.ones(count, bool))
    assert len(ties.batches) > 1
    kernel.substep_kernel()
    assert kernel.loaded()
    for trial in range(4):
        x = np.ascontiguousarray(vertices.T + rng.normal(size=(3, count)) * 0.0005)
        v = rng.normal(size=(3, count)) * 0.01
        compiled_x, compiled_v, reference_x, reference_v = x.copy(), v.copy(), x.copy(), v.copy()
        ties(compiled_x, compiled_v)
        with monkeypatch.context() as patch:
            patch.setattr(kernel, "loaded", lambda: False)
            ties(reference_x, reference_v)
        assert np.abs(reference_x - x).max() > 1e-5                         # the ties moved the apices
        assert np.abs(compiled_x - reference_x).max() < 1e-15
        assert np.abs(compiled_v - reference_v).max() < 1e-15


def test_compiled_jaw_carry_and_offsets_match_numpy(monkeypatch):
    """The rest positions carried by the jaw and the anchor offsets turned with it (face/attachment_kernel.py,
    used once the kernel is loaded) against the numpy reference (attachment.AttachmentMap.carried and
    posed_offsets): the jaw at rest and opened, turned, pushed forward."""
    from faces_hands_addon.face.kinematics import jaw_matrix
    from faces_hands_addon.face.rig import build_default_rig
    rig = build_default_rig("default")
    attachment, bones, rest = rig.template.attachment, rig.template.bones, rig.template.skin.vertices
    kernel.substep_kernel()
    assert kernel.loaded()
    rng = np.random.default_rng(13)
    jaws = [jaw_matrix(bones.tmj_pivot, bones.tmj_axis, *values, glide=bones.jaw_glide)
            for values in rng.uniform(-0.3, 1.0, (4, 4))]
    for jaw in (np.eye(4), *jaws):
        compiled = (attachment.carried(rest, jaw), attachment.posed_offsets(rig.face.anchor_offset, jaw))
        with monkeypatch.context() as patch:
            patch.setattr(kernel, "loaded", lambda: False)
            reference = (attachment.carried(rest, jaw), attachment.posed_offsets(rig.face.anchor_offset, jaw))
        for got, wanted in zip(compiled, reference):
            assert np.abs(got - wanted).max() < 1e-15
    assert np.abs(reference[0] - rest).max() > 1e-3                        # the jaw carried some nodes
    assert np.abs(reference[1] - rig.face.anchor_offset).max() > 1e-4     # and turned their offsets
