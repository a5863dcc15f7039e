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


def test_a_commands_temporary_files_all_go_with_it(installed, tmp_path, monkeypatch):
    """Everything under the command's own temporary root is removed, even a folder whose cleanup an
    interrupt cut short; a signal while the root is made or removed is raised afterwards, not lost."""
    import os
    import signal
    import tempfile

    from conftest import addon_module
    interrupts = addon_module("operators.cli.interrupts")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with pytest.raises(KeyboardInterrupt):
        with interrupts.interruptible(), interrupts.private_temp_root():
            nested = tempfile.mkdtemp(prefix="fh-out-")        # cleanup never runs: the interrupt comes first
            (tmp_path / "seen").write_text(nested)
            os.kill(os.getpid(), signal.SIGINT)
    assert tempfile.tempdir == str(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seen"]
    assert (tmp_path / "seen").read_text().startswith(str(tmp_path / "fh-run-"))
    with interrupts.interruptible():
        with pytest.raises(interrupts.Terminated):
            with interrupts.deferred():
                os.kill(os.getpid(), signal.SIGTERM)
                reached = True                                 # the handler only recorded it
        assert reached
    interrupts.clear()


def test_a_run_leaves_bytecode_for_the_next(installed, built_extension):
    """Blender writes no bytecode and unpacks wheels without compiling them; a command line run writes the
    bytecode of what it loaded from the extension and its wheels, so the next run does not compile it again."""
    import importlib.util
    import shutil
    from pathlib import Path

    cached = [built_extension / "operators" / "cli" / "command_line.py", built_extension / "faces_hands_addon" / "core" / "errors.py"]
    for source in cached:
        shutil.rmtree(source.parent / "__pycache__", ignore_errors=True)
    result = run_fh(installed, "info")
    assert result.returncode == 0, result.stderr[-2000:]
    for source in cached:
        assert Path(importlib.util.cache_from_source(str(source))).is_file(), source
