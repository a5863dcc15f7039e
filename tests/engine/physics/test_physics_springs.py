"""Mass-spring network (thesis 3.1.2 "Mass Spring Network", Fig. 3.4): force law, biphasic stiffness,
attachments, damping, pinned and driven nodes, the stability guard."""
import math

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.physics import (Attachments, LeapfrogIntegrator, SpringNetwork, SpringSet,
                                       biphasic_force, gershgorin_eigen_bound)


def two_nodes(length=1.5, rest=1.0, k_soft=10.0, k_stiff=10.0, threshold=0.0):
    positions = np.array([[0.0, 0.0, 0.0], [length, 0.0, 0.0]])
    springs = SpringSet([0], [1], rest, k_soft, k_stiff, threshold)
    return SpringNetwork(positions, 1.0, springs)


def grid(n=12, spacing=0.01, k_soft=20.0, ratio=4.0, threshold=0.1, attach=0.5):
    xs, zs = np.meshgrid(np.arange(n), np.arange(n))
    positions = np.stack([xs.ravel() * spacing, np.zeros(n * n), zs.ravel() * spacing], 1)
    index = np.arange(n * n).reshape(n, n)
    edges = np.concatenate([np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1),
                            np.stack([index[:-1, :].ravel(), index[1:, :].ravel()], 1),
                            np.stack([index[:-1, :-1].ravel(), index[1:, 1:].ravel()], 1)])
    rest = np.linalg.norm(positions[edges[:, 1]] - positions[edges[:, 0]], axis=1)
    springs = SpringSet(edges[:, 0], edges[:, 1], rest, k_soft, k_soft * ratio, threshold)
    depth = np.array([[0.0], [0.004], [0.0]])
    attachments = Attachments(np.arange(n * n), attach, 0.0, positions.T + depth, positions.T - depth)
    return SpringNetwork(positions, 1e-3, springs, attachments)


def test_spring_force_is_hookean_and_restoring():
    net = two_nodes(length=1.5, rest=1.0, k_soft=10.0, k_stiff=10.0)
    force = net.forces()
    # F_end = -c (l - l0)/l (x_e - x_s): magnitude c (l - l0) = 5, pulling the ends together
    np.testing.assert_allclose(force[:, 1], [-5.0, 0.0, 0.0])
    np.testing.assert_allclose(force[:, 0], [5.0, 0.0, 0.0])
    compressed = two_nodes(length=0.6, rest=1.0)
    np.testing.assert_allclose(compressed.forces()[:, 1], [4.0, 0.0, 0.0])   # pushes apart
    np.testing.assert_allclose(two_nodes(length=1.0).forces(), 0.0)


def test_force_direction_follows_the_spring_in_3d():
    positions = np.array([[0.1, 0.2, 0.3], [0.4, -0.2, 0.9]])
    net = SpringNetwork(positions, 1.0, SpringSet([0], [1], 0.5, 3.0, 3.0, 0.0))
    d = positions[1] - positions[0]
    length = np.linalg.norm(d)
    np.testing.assert_allclose(net.forces()[:, 1], -3.0 * (length - 0.5) / length * d)
    assert np.allclose(net.forces().sum(axis=1), 0.0)        # Newton's third law


def test_biphasic_stiffness_soft_then_stiff_and_continuous():
    rest, k1, k2, e = 1.0, 10.0, 80.0, 0.2
    stretch = np.linspace(-0.3, 0.6, 91)
    f = biphasic_force(stretch, rest, k1, k2, e)
    below = stretch <= e * rest
    np.testing.assert_allclose(f[below], k1 * stretch[below])
    np.testing.assert_allclose(f[~below], k1 * e + k2 * (stretch[~below] - e))
    slopes = np.diff(f) / np.diff(stretch)
    assert slopes.min() == pytest.approx(k1) and slopes.max() == pytest.approx(k2)
    eps = 1e-9
    assert abs(biphasic_force(np.array(e + eps), rest, k1, k2, e)
               - biphasic_force(np.array(e - eps), rest, k1, k2, e)) < 1e-6   # no jump at the knee
    net = two_nodes(length=1.5, rest=1.0, k_soft=k1, k_stiff=k2, threshold=e)
    assert net.forces()[0, 1] == pytest.approx(-(k1 * e + k2 * (0.5 - e)))


def test_compression_branch_is_softer_and_continuous():
    stretch = np.linspace(-0.3, 0.3, 61)
    f = biphasic_force(stretch, 1.0, 10.0, 40.0, 0.2, k_compress=2.5)
    np.testing.assert_allclose(f[stretch < 0], 2.5 * stretch[stretch < 0])
    np.testing.assert_allclose(f[(stretch >= 0) & (stretch <= 0.2)], 10.0 * stretch[(stretch >= 0) & (stretch <= 0.2)])
    net = SpringNetwork(np.array([[0.0, 0, 0], [0.6, 0, 0]]), 1.0, SpringSet([0], [1], 1.0, 10.0, 40.0, 0.2, 2.5))
    assert net.forces()[0, 1] == pytest.approx(2.5 * 0.4)


def test_attachment_and_mirrored_spring_hold_the_node_and_push_it_out():
    positions = np.zeros((1, 3))
    anchor = np.array([[0.0], [0.01], [0.0]])       # bone behind the skin (+Y is into the head)
    mirror = -anchor                                  # reflected outward through the node
    att = Attachments([0], 2.0, 0.0, anchor, mirror)
    net = SpringNetwork(positions, 1.0, SpringSet([], [], [], [], [], []), att)
    np.testing.assert_allclose(net.forces(), 0.0, atol=1e-15)
    pushed_in = np.array([[0.0], [0.003], [0.0]])
    assert net.forces(pushed_in)[1, 0] < 0             # outward, away from the bone
    slid = np.array([[0.002], [0.0], [0.0]])
    assert net.forces(slid)[0, 0] == pytest.approx(-2 * 2.0 * 0.002)   # follows a sliding anchor


def test_damped_energy_decays():
    net = grid()
    rng = np.random.default_rng(1)
    net.positions[1] += rng.normal(0, 0.002, net.node_count)
    integ = LeapfrogIntegrator(net, damping=0.02)
    rest_energy = grid().potential_energy()          # pre-tension of the attachment pairs
    energies = []
    for _ in range(40):
        integ.advance(1 / 24)
        energies.append(net.potential_energy() - rest_energy + integ.kinetic_energy())
    assert energies[-1] < 0.05 * energies[0]
    assert all(b <= a * 1.05 for a, b in zip(energies, energies[1:]))


def test_undamped_energy_is_conserved_by_leapfrog():
    net = grid(ratio=1.0)
    net.positions[1] += np.random.default_rng(2).normal(0, 0.001, net.node_count)
    integ = LeapfrogIntegrator(net, damping=0.0)
    e0 = net.potential_energy()
    for _ in range(400):
        integ.step(integ.max_substep * 0.5)
    assert net.potential_energy() + integ.kinetic_energy() == pytest.approx(e0, rel=0.05)


def test_pinned_nodes_stay_and_driven_nodes_follow_their_targets():
    net = grid(attach=0.0)
    n = 12
    pinned = np.zeros(net.node_count, bool)
    pinned[:n] = True                                  # bottom row pinned
    pinned[-n:] = True                                 # top row driven
    net.kinematic = pinned
    integ = LeapfrogIntegrator(net, damping=0.05)
    start = net.positions.copy()
    target = net.positions.copy()
    target[2, -n:] += 0.02                             # pull the top row up by 2 cm
    for _ in range(60):
        integ.advance(1 / 24, driven=target)
    np.testing.assert_array_equal(net.positions[:, :n], start[:, :n])
    np.testing.assert_allclose(net.positions[:, -n:], target[:, -n:])
    middle = net.positions[2, n * 6:n * 7] - start[2, n * 6:n * 7]
    assert np.all(middle > 0.005) and np.all(middle < 0.015)   # the sheet stretches in between


def test_guard_substeps_come_from_the_gershgorin_bound():
    net = grid(k_soft=50.0, ratio=8.0)
    integ = LeapfrogIntegrator(net, damping=0.01)
    bound = gershgorin_eigen_bound(net)
    # the largest eigenvalue of M^-1 K with every spring on its stiff branch and fully tensioned
    # (block k_stiff * I, the worst case) never exceeds the bound
    n, sp = net.node_count, net.springs
    stiffness = np.zeros((n, n))
    np.add.at(stiffness, (sp.start, sp.start), sp.k_stiff)
    np.add.at(stiffness, (sp.end, sp.end), sp.k_stiff)
    np.add.at(stiffness, (sp.start, sp.end), -sp.k_stiff)
    np.add.at(stiffness, (sp.end, sp.start), -sp.k_stiff)
    stiffness[np.arange(n), np.arange(n)] += 2 * net.attachments.stiffness
    true_max = np.linalg.eigvalsh(stiffness / net.masses[0]).max()
    assert true_max <= bound.max() * (1 + 1e-9)
    # with light damping the substep is just inside 2 / sqrt(lambda)
    assert integ.max_substep == pytest.approx(0.9 * 2 / math.sqrt(bound.max()), rel=0.02)
    assert integ.substeps_for(1 / 24) == math.ceil((1 / 24) / integ.max_substep)


def test_stiffness_damping_and_time_step_sweep_never_gives_nan_or_growth():
    rng = np.random.default_rng(3)
    for k_soft in (0.1, 10.0, 1e3, 1e5):
        for ratio in (1.0, 10.0, 100.0):
            for damping in (0.0, 1e-3, 10.0, 1e4):
                net = grid(n=6, k_soft=k_soft, ratio=ratio, attach=k_soft / 10)
                net.positions += rng.normal(0, 0.003, net.positions.shape)   # violent start
                integ = LeapfrogIntegrator(net, damping=damping, max_substeps=50)
                start_energy = net.potential_energy()
                for frame_dt in (1 / 240, 1 / 24, 0.5, 1 / 24):
                    assert integ.advance(frame_dt) <= 50
                    assert np.all(np.isfinite(net.positions))
                    energy = net.potential_energy() + integ.kinetic_energy()
                    assert energy <= 1.5 * start_energy + 1e-12, (k_soft, ratio, damping, frame_dt)


def test_damping_never_restricts_the_step_and_heavy_damping_allows_larger_ones():
    light = LeapfrogIntegrator(grid(), damping=0.0).max_substep
    heavy = LeapfrogIntegrator(grid(), damping=10.0).max_substep
    assert heavy > light


def test_bad_parameters_raise_user_errors():
    with pytest.raises(UserError):
        SpringSet([0], [1], 1.0, 10.0, 5.0, 0.1)      # stiff branch softer than the soft one
    with pytest.raises(UserError):
        SpringNetwork(np.zeros((2, 3)), 0.0, SpringSet([0], [1], 1.0, 1.0, 1.0, 0.0))
    with pytest.raises(UserError):
        LeapfrogIntegrator(two_nodes(), damping=-1.0)


def test_simulation_is_deterministic():
    def run():
        net = grid()
        net.positions[1] += np.random.default_rng(7).normal(0, 0.002, net.node_count)
        integ = LeapfrogIntegrator(net, damping=0.01)
        for _ in range(5):
            integ.advance(1 / 24)
        return net.positions.tobytes()
    assert run() == run()
