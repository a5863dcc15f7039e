"""A skip nobody meant fails CI (tests/skip_policy.py, issue 33 item 7): a test skipped because a wheel did not
import counts as a failure under FH_TEST_NO_SKIPS=1, a skip the harness marks as intended does not."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[2]
CASES = '''
import pytest
from skip_policy import intended_skip

def pytest_collection_modifyitems(items):
    for item in items:
        if item.name == "test_meant":
            intended_skip(item, "covered on another line")
'''
BODY = '''
import pytest

def test_wheel():
    pytest.importorskip("a_wheel_that_did_not_import")

def test_meant():
    pass

def test_runs():
    assert True
'''


def _run(tmp_path, strict: bool, *only) -> subprocess.CompletedProcess:
    (tmp_path / "conftest.py").write_text(CASES)
    (tmp_path / "test_cases.py").write_text(BODY)
    (tmp_path / "pytest.ini").write_text("[pytest]\n")
    env = dict(os.environ, PYTHONPATH=str(TESTS), FH_TEST_NO_SKIPS="1" if strict else "0")
    targets = [f"test_cases.py::{name}" for name in only] or ["test_cases.py"]
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "skip_policy", "-p", "no:cacheprovider",
                           "-p", "no:xdist", "--rootdir", str(tmp_path), *targets],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("strict", [False, True])
def test_an_unmeant_skip_fails_only_where_nothing_may_be_skipped(tmp_path, strict):
    result = _run(tmp_path, strict)
    if strict:
        assert result.returncode == 1 and "1 failed" in result.stdout and "a_wheel_that_did_not_import" in result.stdout
        assert "1 skipped" in result.stdout                      # the intended one
    else:
        assert result.returncode == 0 and "2 skipped" in result.stdout, result.stdout
    assert _run(tmp_path, True, "test_meant", "test_runs").returncode == 0
