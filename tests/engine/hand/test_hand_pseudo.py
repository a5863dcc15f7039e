"""Pseudo muscles (thesis 6.2.2): the force laws Eqs. 6.1-6.2, the signs of Table A.1, friction (Eq. 6.4''),
the joint limits of Table 6.4 and the chain inertia tables (Eq. 6.8, J*)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.hand import inertia
from faces_hands_addon.hand.pseudo import MAX_LENGTH, MIN_LENGTH, PseudoMuscles, contraction_force, stretch_force
from faces_hands_addon.hand.rig import build_hand_rig

DT = 1 / 30


@pytest.fixture(scope="module")
def rig():
    return build_hand_rig()


def test_eq_6_1_peaks_at_f_max_for_1_1_l0_and_follows_its_formula():
    l0, f_max = 0.066, 197.3
    lengths = np.linspace(MIN_LENGTH, MAX_LENGTH, 201) * l0
    force = contraction_force(lengths, l0, f_max)
    assert contraction_force(1.1 * l0, l0, f_max) == pytest.approx(f_max, rel=1e-12)
    assert lengths[np.argmax(force)] == pytest.approx(1.1 * l0, rel=1e-9)
    np.testing.assert_allclose(force, (1.0 - 4.0 * (lengths / l0 - 1.1) ** 2) * f_max, rtol=1e-12)
    assert contraction_force(0.6 * l0, l0, f_max) == pytest.approx(0.0, abs=1e-9)   # zero at both bounds
    assert contraction_force(1.6 * l0, l0, f_max) == pytest.approx(0.0, abs=1e-9)


def test_eq_6_2_is_zero_below_l0_and_quadratic_above():
    l0, f_max = 0.055, 48.8
    below = np.linspace(0.6, 1.0, 50) * l0
    assert np.all(stretch_force(below, l0, f_max) == 0.0)
    above = np.linspace(1.0, 1.6, 50) * l0
    np.testing.assert_allclose(stretch_force(above, l0, f_max), 2.77 * (above / l0 - 1) ** 2 * f_max, rtol=1e-12)


def test_forces_of_the_rig_use_both_laws(rig):
    pm = rig.pseudo
    lengths = pm.rest * 1.1
    c = np.full(len(pm.rest), 0.5)
    expected = 0.5 * pm.max_force + 2.77 * 0.01 * pm.max_force          # Eq. 6.3'
    np.testing.assert_allclose(pm.forces(c, lengths), expected, rtol=1e-12)


def test_fibre_lengths_change_by_the_arc_length_and_stay_within_bounds(rig):
    pm = rig.pseudo
    angles = np.zeros(rig.skeleton.dof_count)
    k = rig.skeleton.dof("index-finger-phalanx-proximal", "flexion")
    angles[k] = 0.3
    lengths = pm.fibre_lengths(angles)
    i = pm.names.index("flexor_digitorum_profundus_index")
    assert lengths[i, k] == pytest.approx(pm.rest[i] - 0.0111 * 0.3, rel=1e-9)     # l0 - r dphi
    e = pm.names.index("extensor_digitorum_index")
    assert lengths[e, k] == pytest.approx(pm.rest[e] + 0.0086 * 0.3, rel=1e-9)     # the extensor stretches
    extreme = pm.fibre_lengths(np.full(rig.skeleton.dof_count, 50.0))
    assert np.all(extreme >= MIN_LENGTH * pm.rest[:, None] - 1e-12)
    assert np.all(extreme <= MAX_LENGTH * pm.rest[:, None] + 1e-12)


def _alone(pm: PseudoMuscles, name: str, value: float, frames: int) -> np.ndarray:
    pm.reset()
    c = np.zeros(len(pm.rest))
    c[pm.names.index(name)] = value
    for _ in range(frames):
        pm.step(c, DT)
    return pm.angles.copy()


def test_every_muscle_moves_the_dofs_table_a1_says_in_its_direction(rig):
    pm = rig.pseudo
    offenders, checked = [], 0
    for spec in rig.template.muscles:
        angles = _alone(pm, spec.name, 0.5, 2)
        for row in spec.rows:
            k = rig.skeleton.dof(row.bone, row.dof)
            if row.arm < 0.002 or not pm.dynamic[k]:
                continue
            checked += 1
            if angles[k] * row.sign <= 0:
                offenders.append(f"{spec.name} {row.bone}.{row.dof}: {np.degrees(angles[k]):.2f} deg")
    assert checked > 100 and offenders == []


@pytest.mark.parametrize("muscle, joints, sign", [
    ("flexor_digitorum_profundus_index", ("proximal", "intermediate", "distal"), 1),
    ("flexor_digitorum_superficialis_middle", ("proximal", "intermediate"), 1),
    ("extensor_digitorum_ring", ("proximal",), -1),
    ("extensor_indicis", ("proximal",), -1),
])
def test_a_flexor_flexes_and_an_extensor_extends_its_finger_when_settled(rig, muscle, joints, sign):
    finger = muscle.split("_")[-1]
    finger = "index" if finger == "indicis" else finger
    angles = _alone(rig.pseudo, muscle, 0.3, 60)
    for joint in joints:
        k = rig.skeleton.dof(f"{finger}-finger-phalanx-{joint}", "flexion")
        assert sign * np.degrees(angles[k]) > 4.0, (muscle, joint, np.degrees(angles[k]))


def test_friction_brings_a_released_joint_to_rest(rig):
    pm = rig.pseudo
    flexed = _alone(pm, "flexor_digitorum_superficialis_index", 0.4, 20)
    k = rig.skeleton.dof("index-finger-phalanx-proximal", "flexion")
    assert np.degrees(flexed[k]) > 10
    c = np.zeros(len(pm.rest))
    speeds = []
    for _ in range(120):                     # released: 4 s
        pm.step(c, DT)
        speeds.append(pm.speed())
    assert max(speeds[:10]) > 0.1             # it moves back ...
    assert pm.speed() < 1e-3                  # ... and comes to rest
    assert abs(np.degrees(pm.angles[k])) < 3.0


def test_without_friction_a_spinning_joint_would_not_stop(rig):
    pm = rig.pseudo
    k = rig.skeleton.dof("index-finger-phalanx-distal", "flexion")
    saved = pm.friction, pm.capsule.copy(), pm.lever.copy(), pm.lever2.copy()
    try:
        pm.capsule[:] = 0.0
        pm.lever[:] = pm.lever2[:] = 0.0       # no muscle and no capsule: only friction acts
        for mu, expect_rest in ((saved[0], True), (1e-12, False)):
            pm.friction = mu
            pm.reset()
            pm.angles[k], pm.velocity[k] = 0.3, 2.0
            for _ in range(10):
                pm.step(np.zeros(len(pm.rest)), DT)
            assert (abs(pm.velocity[k]) < 1e-6) == expect_rest, (mu, pm.velocity[k])
    finally:
        pm.friction, pm.capsule[:], pm.lever[:], pm.lever2[:] = saved
        pm.reset()


def test_no_joint_ever_leaves_its_table_6_4_range(rig):
    pm = rig.pseudo
    rng = np.random.default_rng(7)
    pm.reset()
    low, high = pm.lower - 1e-12, pm.upper + 1e-12
    worst = 0.0
    for frame in range(240):
        if frame % 20 == 0:
            c = rng.uniform(0, 1, len(pm.rest)) * (rng.uniform(size=len(pm.rest)) < 0.3)
        pm.step(c, DT)
        assert np.all(pm.angles >= low) and np.all(pm.angles <= high), frame
        worst = max(worst, float(np.max(np.minimum(pm.angles - pm.lower, pm.upper - pm.angles) == 0)))
    assert worst == 1.0                        # some joint did reach a limit (the check is not idle)


def test_contractions_outside_0_1_are_refused(rig):
    from faces_hands_addon import UserError
    with pytest.raises(UserError, match=r"\[0, 1\]"):
        rig.pseudo.step(np.full(len(rig.pseudo.rest), 1.5), DT)


def test_eq_6_8_and_the_chain_tables_agree_with_a_direct_computation(rig):
    table = rig.pseudo.inertia
    sk = rig.skeleton
    b = sk.index["index-finger-phalanx-distal"]
    k = sk.dof("index-finger-phalanx-distal", "flexion")
    mass, length = rig.template.masses[b], sk.bone_length(b)
    assert table.entries[k].own == pytest.approx(mass * length ** 2 / 3.0)         # Eq. 6.8
    rng = np.random.default_rng(3)
    chains = [d for d in table.entries if table.entries[d].child_table is not None]
    assert len(chains) >= 14                        # MCP and PIP of four fingers, thumb CMC and MCP
    worst = 0.0
    for _ in range(12):
        angles = rng.uniform(sk.lower, sk.upper)
        looked_up = table(angles)
        for row, d in enumerate(table.dofs):
            if d in chains:
                direct = table.direct(int(d), angles)
                worst = max(worst, abs(looked_up[row] - direct) / direct)
    assert worst < 0.01, worst
    assert np.allclose(np.diff(inertia.GRID), np.radians(5.0))                    # 5-degree steps
