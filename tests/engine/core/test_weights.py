"""Engine-ready weights (anim.weights): bounded least squares checked against an independent solver."""
from __future__ import annotations

import importlib.util

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
    monkeypatch.setenv("FH_PHYSICS_KERNEL", "numpy")     # the reference path (the compiled one: next test)
    rng = np.random.default_rng(3)
    basis = weights_module.TargetBasis(("a", "b", "c"), rng.standard_normal((3, 40, 3)))
    weights_module.WeightSolver(basis).solve_many(rng.standard_normal((4, 40, 3)))
    assert before and seen == [1] * 4
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before


def _box_problems(rng, frames, rows, cols, prior=None):
    """A take-like run of bounded least-squares problems (each frame near the last), optionally with the
    prior rows the weights bake stacks below the targets."""
    matrix = rng.normal(size=(rows, cols))
    if prior is not None:
        matrix = np.vstack([matrix, prior * np.eye(cols)])
    drift = np.cumsum(rng.normal(size=(frames, len(matrix))) * 0.2, axis=0) + rng.normal(size=len(matrix)) * 2
    return np.ascontiguousarray(matrix), np.ascontiguousarray(drift)


@pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba is not importable here")
def test_compiled_box_solver_finds_the_reference_minimum_and_leaves_it_the_hard_frames(monkeypatch):
    """The weights bake's compiled active-set loops (``_box_normal`` with prior rows, ``_box_qr`` without;
    warm-started frame to frame) reach the minimum :func:`bounded_nnls` (the reference) reaches: the same
    cost, and the same weights wherever the problem is well conditioned (here: with prior rows); frames they
    cannot settle go to the reference."""
    from faces_hands_addon.anim import weights as weights_module
    from faces_hands_addon.physics import kernel
    monkeypatch.delenv("FH_PHYSICS_KERNEL", raising=False)
    normal = kernel.compiled(weights_module._box_normal, weights_module._sets_settled)
    qr = kernel.compiled(weights_module._box_qr, weights_module._sets_settled)
    assert normal is not None and qr is not None
    rng = np.random.default_rng(21)
    for prior, tolerance in ((None, None), (0.5, 1e-9)):
        for _ in range(6):
            matrix, rhs = _box_problems(rng, 40, int(rng.integers(10, 60)), int(rng.integers(3, 30)), prior)
            count = matrix.shape[1]
            low, high = np.ones(count, bool), np.zeros(count, bool)
            weights, solved = np.zeros((len(rhs), count)), np.zeros(len(rhs), bool)
            hessian, targets = np.ascontiguousarray(matrix.T @ matrix), np.ascontiguousarray(rhs @ matrix)
            tolerances = 1e-9 * np.maximum(1.0, np.abs(targets).max(axis=1))
            if prior is not None:
                normal(hessian, targets, tolerances, low, high, 30, weights, solved)
            else:
                qr(matrix, rhs, hessian, targets, tolerances, low, high, 30, weights, solved)
            assert solved.mean() > 0.9
            for row, ours in zip(rhs[solved], weights[solved]):
                reference = bounded_nnls(matrix, row)
                cost = lambda w: float(np.sum((matrix @ w - row) ** 2))  # noqa: E731
                assert ours.min() >= 0 and ours.max() <= 1
                assert cost(ours) <= cost(reference) + 1e-9 * max(1.0, cost(reference))
                if tolerance is not None:
                    assert np.abs(ours - reference).max() < tolerance


@pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba is not importable here")
def test_weight_solver_agrees_with_and_without_the_compiled_loop(monkeypatch):
    """Whole ``WeightSolver.solve_many`` (primary targets held near a prior, then correctives): the compiled
    path gives the reference's weights and residuals."""
    from faces_hands_addon.physics import kernel
    rng = np.random.default_rng(5)
    basis, extra = _basis(seed=1, targets=10, vertices=80), _basis(seed=2, targets=6, vertices=80)
    truth = rng.uniform(-0.2, 1.2, size=(30, 10))
    frames = np.einsum("ft,tvk->fvk", truth, basis.displacements) + rng.normal(size=(30, 80, 3)) * 0.002
    prior = np.clip(truth + rng.normal(size=truth.shape) * 0.1, 0, 1)
    exact = np.arange(30) % 7 == 0
    results = []
    for choice in ("numpy", "numba"):
        monkeypatch.setenv("FH_PHYSICS_KERNEL", choice)
        kernel.substep_kernel()
        results.append(WeightSolver(basis, extra).solve_many(frames, prior, exact))
    assert kernel.loaded()
    assert np.abs(results[0][0][:, :10] - results[1][0][:, :10]).max() < 1e-8
    assert np.abs(results[0][1] - results[1][1]).max() < 1e-9
    assert np.array_equal(results[1][0][exact, :10], np.clip(prior[exact], 0, 1))


def test_the_weight_fit_gives_the_same_bytes_whatever_the_blas_thread_count():
    """A threaded BLAS sums the large products in another order for another thread count (the jobs runner
    saw 3 of 4 GLBs change between one and two workers): the solver pins one thread itself."""
    from threadpoolctl import threadpool_limits
    from faces_hands_addon.anim.weights import TargetBasis, WeightSolver
    rng = np.random.default_rng(5)
    basis = TargetBasis(tuple(f"t{k}" for k in range(48)), rng.normal(size=(48, 6000, 3)))
    correctives = TargetBasis(tuple(f"c{k}" for k in range(30)), rng.normal(size=(30, 6000, 3)))
    frames = rng.normal(size=(64, 6000, 3))
    prior = rng.uniform(size=(64, 48))
    results = []
    for threads in (1, 4):
        with threadpool_limits(limits=threads, user_api="blas"):
            solver = WeightSolver(basis, correctives)
            weights, residual = solver.solve_many(frames, prior)
        results.append(weights.tobytes() + residual.tobytes())
    assert results[0] == results[1]


@pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba is not importable here")
def test_the_weight_fit_does_not_depend_on_what_loaded_the_kernel_before(monkeypatch):
    """The compiled loop and the scipy reference agree to rounding only, so which one runs may depend on the
    environment alone: a jobs worker's first line (nothing has loaded the kernel yet) and its later lines
    (a settle loaded it) give the same bytes."""
    from faces_hands_addon.physics import kernel
    monkeypatch.delenv("FH_PHYSICS_KERNEL", raising=False)
    rng = np.random.default_rng(9)
    basis, extra = _basis(seed=3, targets=10, vertices=80), _basis(seed=4, targets=6, vertices=80)
    frames = np.einsum("ft,tvk->fvk", rng.uniform(-0.2, 1.2, size=(30, 10)), basis.displacements)
    frames += rng.normal(size=frames.shape) * 0.002
    with monkeypatch.context() as patch:
        patch.setattr(kernel, "loaded", lambda: False)          # a fresh process: nothing loaded it
        first = WeightSolver(basis, extra).solve_many(frames)
    kernel.substep_kernel()
    later = WeightSolver(basis, extra).solve_many(frames)
    assert first[0].tobytes() == later[0].tobytes() and first[1].tobytes() == later[1].tobytes()


@pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba is not importable here")
def test_a_weight_fit_leaves_the_substep_kernel_unloaded():
    """The fit compiles its own loop without loading the substep kernel: a retarget, which fits weights and
    simulates nothing, does not pay for the kernel's load."""
    import os
    import subprocess
    import sys
    script = (
        "import sys, numpy as np; from faces_hands_addon.physics import kernel as k; "
        "from faces_hands_addon.anim.weights import TargetBasis, WeightSolver; "
        "rng = np.random.default_rng(2); b = TargetBasis(tuple('t%d' % i for i in range(8)), "
        "rng.normal(size=(8, 40, 3))); w, r = WeightSolver(b).solve_many(rng.normal(size=(12, 40, 3))); "
        "sys.exit(0 if (not k.loaded() and k.numba_usable() and w.shape == (12, 8)) else 1)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env.pop("FH_PHYSICS_KERNEL", None)
    subprocess.run([sys.executable, "-c", script], check=True, env=env, timeout=600)
