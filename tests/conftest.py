"""Test harness: every test runs against the *installed* extension.

At session start the built zip (``$FH_ZIP``, built by ``make test``) is installed into a fresh temporary
Blender user folder inside the ``bpy`` module and enabled, exactly as a user installs it. Engine tests
then import ``faces_hands_addon`` and get the installed copy (aliased from
``bl_ext.user_default.faces_hands.faces_hands_addon``), never the source tree; add-on tests drive
``bpy`` with the extension enabled. ``FH_TEST_FROM_SOURCE=1`` is a developer shortcut for quick engine
iteration (engine tests only, source tree on sys.path); CI never sets it.
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import blender_env  # noqa: E402

FROM_SOURCE = os.environ.get("FH_TEST_FROM_SOURCE") == "1"


class Installed:
    """Where the session's installed extension lives."""
    user_dir: Path | None = None
    extension_dir: Path | None = None
    zip_path: Path | None = None


def _install_for_session() -> None:
    if FROM_SOURCE:
        sys.path.insert(0, str(ROOT))
        return
    zip_path = Path(os.environ.get("FH_ZIP") or blender_env.built_zip()).resolve()
    if not zip_path.exists():
        pytest.exit(f"{zip_path} does not exist; run the tests with `make test`", returncode=2)
    user_dir = Path(tempfile.mkdtemp(prefix="fh-test-user-"))
    blender_env.install(zip_path, user_dir)
    Installed.user_dir = user_dir
    Installed.extension_dir = blender_env.extension_dir(user_dir)
    Installed.zip_path = zip_path
    blender_env.alias_installed_engine()


_install_for_session()


def pytest_collection_modifyitems(config, items):
    if FROM_SOURCE:
        skip = pytest.mark.skip(reason="FH_TEST_FROM_SOURCE=1 runs engine tests only")
        for item in items:
            if "tests/engine/" not in str(item.fspath).replace(os.sep, "/"):
                item.add_marker(skip)


_exit_status = {"code": None}


def pytest_sessionfinish(session, exitstatus):
    _exit_status["code"] = int(exitstatus)


def pytest_unconfigure(config):
    """Clean up, then leave without running bpy's atexit teardown: the bpy 4.5 module can hang forever
    in a destructor at interpreter exit (seen here: GlobalState::~GlobalState waiting on its thread)."""
    if Installed.user_dir and Installed.user_dir.exists():
        shutil.rmtree(Installed.user_dir, ignore_errors=True)
    if "bpy" in sys.modules and _exit_status["code"] is not None:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_exit_status["code"])


@pytest.fixture(scope="session")
def installed() -> type[Installed]:
    if FROM_SOURCE:
        pytest.skip("needs the installed extension")
    return Installed


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return ROOT


@pytest.fixture
def bpy_clean(installed):
    """A factory-fresh empty scene with the installed extension still enabled (per-test isolation)."""
    import bpy
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert hasattr(bpy.types.Scene, "faces_hands"), "extension got disabled by the reset"
    yield bpy
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)


def run_fh(installed, *args, cwd=None, timeout=600):
    """Run the CLI the way ./fh does (same launcher), against the session's isolated install."""
    import subprocess
    cmd = [sys.executable, str(ROOT / "scripts" / "fh_launch.py"), "--user-dir", str(installed.user_dir),
           "--", *map(str, args)]
    return subprocess.run(cmd, cwd=cwd or ROOT, capture_output=True, text=True, timeout=timeout)
