"""Engine-ready weights (anim.weights): bounded least squares checked against an independent solver."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from faces_hands_addon import UserError
from faces_hands_addon.anim.weights import TargetBasis, WeightSolver, bounded_nnls, fit_weights, stack_pose


def _basis(seed=0, targets=12, vertices=60):
    rng = np.random.default_rng(seed)
    return TargetBasis(tuple(f"t{i}" for i in range(targets)), rng.normal(size=(targets, vertices, 3)) * 0.01)


def test_weights_inside_the_bounds_are_recovered_exactly():
    basis = _basis()
    rng = np.random.default_rng(1)
    truth = rng.uniform(0, 1, size=(20, 12)) * (rng.uniform(size=(20, 12)) > 0.4)
    frames = np.einsum("ft,tvk->fvk", truth, basis.displacements)
    weights, residual = WeightSolver(basis).solve_many(frames)
    assert np.abs(weights - truth).max() < 1e-6
    assert residual.max() < 1e-9


def test_bounded_nnls_matches_scipy_lsq_linear_on_random_problems():
    rng = np.random.default_rng(7)
    for _ in range(200):
        rows, cols = rng.integers(8, 40), rng.integers(2, 12)
        matrix = rng.normal(size=(rows, cols))
        rhs = rng.normal(size=rows) * rng.uniform(0.5, 4)
        ours = bounded_nnls(matrix, rhs)
        reference = lsq_linear(matrix, rhs, bounds=(0.0, 1.0), method="bvls", tol=1e-12).x
        assert ours.min() >= 0 and ours.max() <= 1
        cost = lambda w: float(np.sum((matrix @ w - rhs) ** 2))  # noqa: E731
        assert cost(ours) <= cost(reference) + 1e-8 * max(1.0, cost(reference))


def test_overshooting_and_negative_weights_are_clamped_and_correctives_fit_the_rest():
    basis = _basis(targets=4)
    frame = 1.7 * basis.displacements[0] - 0.5 * basis.displacements[1]
    weights, residual = WeightSolver(basis).solve_many(frame[None])
    assert weights[0, 0] == pytest.approx(1.0) and weights[0, 1] == pytest.approx(0.0, abs=1e-12)
    extra = TargetBasis(("fix",), (0.7 * basis.displacements[0])[None])
    both = WeightSolver(basis, extra)
    combined, left = both.solve_many(frame[None])
    assert both.names == basis.names + ("fix",) and combined[0, 4] > 0.5
    assert left[0] < residual[0]


def test_bad_input_is_refused():
    basis = _basis(targets=3, vertices=10)
    with pytest.raises(UserError, match="do not match"):
        WeightSolver(basis).solve_many(np.zeros((2, 11, 3)))
    with pytest.raises(UserError, match="do not match"):
        WeightSolver(basis).solve_many(np.full((1, 10, 3), np.nan))
    with pytest.raises(UserError, match="do not move anything"):
        WeightSolver(TargetBasis(("still",), np.zeros((1, 10, 3))))
    with pytest.raises(UserError, match="non-finite"):
        TargetBasis(("bad",), np.full((1, 10, 3), np.inf))


def test_fit_weights_and_stack_pose():
    basis = _basis(targets=3, vertices=5)
    fit = fit_weights(basis, [0.5 * basis.displacements[2], np.zeros((5, 3))])
    assert fit.weights[0] == pytest.approx([0, 0, 0.5], abs=1e-9) and fit.residual_mm()[2] < 1e-6
    moved = np.eye(4)
    moved[:3, 3] = (0, 0, 0.01)
    stacked = stack_pose(np.zeros((2, 3)), {"jaw": np.ones((3, 3))}, {"jaw": moved})
    assert stacked.shape == (5, 3) and np.allclose(stacked[2:, 2], 1.01)


def test_the_frame_fit_runs_on_one_blas_thread_and_restores_it(monkeypatch):
    """The per-frame bounded solves run with one BLAS thread (anim/weights.py: threaded BLAS on tiny problems
    costs more than it computes), and the process' own setting is back afterwards."""
    from threadpoolctl import threadpool_info
    from faces_hands_addon.anim import weights as weights_module
    seen = []
    original = weights_module.bounded_nnls

    def spy(matrix, rhs, *args, **kwargs):
        seen.append(max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"))
        return original(matrix, rhs, *args, **kwargs)

    before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    monkeypatch.setattr(weights_module, "bounded_nnls", spy)
    rng = np.random.default_rng(3)
    basis = weights_module.TargetBasis(("a", "b", "c"), rng.standard_normal((3, 40, 3)))
    weights_module.WeightSolver(basis).solve_many(rng.standard_normal((4, 40, 3)))
    assert before and seen == [1] * 4
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before
