"""On CI nothing is skipped that the suite did not mean to skip (issue 33 item 7).

A test skipped because a wheel did not import (``importorskip("h5py")``, ``skipif(numba is missing)``) passes
quietly while the feature it guards is broken for every user of that line. With ``FH_TEST_NO_SKIPS=1``
(``.ci/run`` sets it) such a skip is reported as a failure; skips the harness itself marks with
:data:`INTENDED` (engine tests on lines whose Python and numpy another line covers, add-on tests without
``bpy``) stay skips. Loaded by ``tests/conftest.py``.
"""
from __future__ import annotations

import os

import pytest

INTENDED = "fh_intended_skip"
VARIABLE = "FH_TEST_NO_SKIPS"


def intended_skip(item, reason: str) -> None:
    """Skip ``item`` on purpose (kept a skip under :data:`VARIABLE`)."""
    item.add_marker(pytest.mark.skip(reason=reason))
    item.add_marker(getattr(pytest.mark, INTENDED))


def pytest_configure(config):
    config.addinivalue_line("markers", f"{INTENDED}: a skip the harness means (allowed on CI)")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    if (os.environ.get(VARIABLE) == "1" and report.skipped and not hasattr(report, "wasxfail")
            and item.get_closest_marker(INTENDED) is None):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        report.outcome = "failed"
        report.longrepr = (f"skipped where nothing may be skipped ({VARIABLE}=1): {reason}. A wheel that does "
                           "not import here breaks what this test guards for every user of this line.")
