"""The command line: ./fh and the launcher it uses, help, and bad input."""
from __future__ import annotations

import subprocess

import pytest

from conftest import ROOT, run_fh

pytestmark = pytest.mark.smoke


def test_fh_script_help_lists_subcommands():
    result = subprocess.run([str(ROOT / "fh"), "--help"], capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-2000:]
    for name in ("info", "demo"):
        assert name in result.stdout


def test_every_subcommand_has_help(installed):
    result = run_fh(installed, "--help")
    names = [line.split()[0] for line in result.stdout.split("positional arguments:")[1]
             .split("options:")[0].splitlines()[2:] if line.startswith("    ") and not line.startswith("     ")]
    assert names, result.stdout
    for name in names:
        sub = run_fh(installed, name, "--help")
        assert sub.returncode == 0 and "usage:" in sub.stdout, (name, sub.stderr)


def test_unknown_subcommand_is_one_clear_line(installed):
    result = run_fh(installed, "no-such-command")
    assert result.returncode != 0
    errors = [l for l in result.stderr.splitlines() if "faces_hands:" in l]
    assert len(errors) == 1 and "invalid choice" in errors[0], result.stderr
    assert "Traceback" not in result.stderr


def test_bad_output_path_writes_nothing(installed, tmp_path):
    target = tmp_path / "out" / "demo"
    target.parent.mkdir()
    (target.parent / "demo").write_text("a file where a folder is expected")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    result = run_fh(installed, "demo", "--out", target)
    assert result.returncode == 1, result.stdout + result.stderr
    error_lines = [l for l in result.stderr.splitlines() if l.startswith("faces_hands: error:")]
    assert len(error_lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert sorted(p.name for p in tmp_path.rglob("*")) == before
