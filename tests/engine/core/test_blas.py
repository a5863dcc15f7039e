# SPDX-License-Identifier: GPL-3.0-or-later
"""One BLAS thread for the whole process while anyone holds it (core/blas.py): a bake fits weights on a
second thread while the first simulates, so a holder leaving may not give another, still inside, its
threads back."""
from __future__ import annotations

from threadpoolctl import threadpool_info, threadpool_limits

from faces_hands_addon.core.blas import one_blas_thread


def _counts() -> set[int]:
    return {info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"}


def test_the_limit_holds_until_the_last_holder_leaves():
    with threadpool_limits(limits=2, user_api="blas"):
        assert _counts() == {2}
        fitting, simulating = one_blas_thread(), one_blas_thread()
        assert _counts() == {1}
        fitting.release()                     # one thread's block is fitted; the other is still inside
        assert _counts() == {1}
        fitting.release()                     # a second release changes nothing
        with one_blas_thread():
            assert _counts() == {1}
        assert _counts() == {1}
        simulating.release()
        assert _counts() == {2}               # the process's own count is back
