# SPDX-License-Identifier: GPL-3.0-or-later
"""One BLAS thread, for work whose result must not depend on how many cores the machine has, and for loops
of tiny problems where a threaded BLAS spends longer waking its threads than computing (the per-frame
weight fit, :mod:`..anim.weights`).

A multi-threaded BLAS splits its sums differently for different thread counts, so a product or a solve
rounds differently on a 2-core and a 16-core machine. Most results only move in the last bits, but a
search that makes discrete choices from such numbers (the landmark location and head fitting of thesis
3.1.2) can take another path: the MakeHuman test head's landmarks moved by up to 8.8 mm between one and
two BLAS threads on the same machine. Work of that kind runs inside :func:`one_blas_thread`.
"""
from __future__ import annotations

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

_CONTROLLER: list[ThreadpoolController] = []


def one_blas_thread():
    """A context in which the BLAS libraries loaded into this process use one thread (restored after)."""
    if not _CONTROLLER:
        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=1, user_api="blas")
