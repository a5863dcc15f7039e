"""Test harness: every test runs against the *built* extension, never the source tree.

With Blender's Python module (``bpy``) in this Python, the built zip (``$FH_ZIP``, built by ``make test``) is
installed into a fresh temporary Blender user folder and enabled, exactly as a user installs it; engine
tests then import ``faces_hands_addon`` as the installed copy (aliased from
``bl_ext.user_default.faces_hands.faces_hands_addon``) and add-on tests drive ``bpy``.

Without ``bpy`` (``make test-engine``: a plain Python with numpy and pytest), the zip is unpacked into a
temporary folder, with its wheels for this platform, and only the engine tests run: they never need
Blender. ``FH_TEST_FROM_SOURCE=1`` is a developer shortcut (engine tests, source tree on sys.path); CI never
sets it.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import blender_env  # noqa: E402
import skip_policy  # noqa: E402
from skip_policy import intended_skip  # noqa: E402

FROM_SOURCE = os.environ.get("FH_TEST_FROM_SOURCE") == "1"
HAS_BPY = importlib.util.find_spec("bpy") is not None and not FROM_SOURCE
ENGINE_ONLY = FROM_SOURCE or not HAS_BPY


class Installed:
    """Where the session's extension lives (installed into bpy, or unpacked for engine-only runs)."""
    user_dir: Path | None = None
    extension_dir: Path | None = None
    zip_path: Path | None = None
    unpacked: Path | None = None


def _zip_path() -> Path:
    zip_path = Path(os.environ.get("FH_ZIP") or blender_env.built_zip()).resolve()
    if not zip_path.exists():
        pytest.exit(f"{zip_path} does not exist; run the tests with `make test`", returncode=2)
    return zip_path


def _install_for_session() -> None:
    if FROM_SOURCE:
        sys.path.insert(0, str(ROOT))
        return
    zip_path = _zip_path()
    Installed.zip_path = zip_path
    if not HAS_BPY:
        folder = Path(tempfile.mkdtemp(prefix="fh-test-unpacked-"))
        Installed.extension_dir, site = blender_env.unpack(zip_path, folder)
        Installed.unpacked = folder
        sys.path[:0] = [str(Installed.extension_dir), str(site)]
        return
    user_dir = Path(tempfile.mkdtemp(prefix="fh-test-user-"))
    blender_env.install(zip_path, user_dir)
    Installed.user_dir = user_dir
    Installed.extension_dir = blender_env.extension_dir(user_dir)
    blender_env.alias_installed_engine()


_install_for_session()


def pytest_configure(config):
    config.pluginmanager.register(skip_policy, "skip_policy")      # a skip nobody meant fails CI


def pytest_collection_modifyitems(config, items):
    if os.environ.get("FH_TEST_SKIP_ENGINE") == "1":
        # CI's bpy 5.0, 4.5 and 5.3 lines: the engine never imports bpy, and the same Python and numpy already
        # run every engine test (5.0 and 4.5 = 3.11 + numpy 1.26 as `make test-engine`; 5.3 = 3.13 + numpy
        # 2.5 as 5.2)
        for item in items:
            if "tests/engine/" in str(item.fspath).replace(os.sep, "/"):
                intended_skip(item, "engine tests run on another line with this Python and numpy")
    if ENGINE_ONLY:
        reason = ("FH_TEST_FROM_SOURCE=1 runs engine tests only" if FROM_SOURCE
                  else "no bpy in this Python: engine tests only")
        for item in items:
            if "tests/engine/" not in str(item.fspath).replace(os.sep, "/"):
                intended_skip(item, reason)


_exit_status = {"code": None}


def pytest_sessionfinish(session, exitstatus):
    _exit_status["code"] = int(exitstatus)


def pytest_unconfigure(config):
    """Clean up, then leave without running bpy's atexit teardown: the bpy 4.5 module can hang forever
    in a destructor at interpreter exit (seen here: GlobalState::~GlobalState waiting on its thread)."""
    for folder in (Installed.user_dir, Installed.unpacked):
        if folder and folder.exists():
            shutil.rmtree(folder, ignore_errors=True)
    if "bpy" in sys.modules and _exit_status["code"] is not None:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_exit_status["code"])


@pytest.fixture(scope="session")
def installed() -> type[Installed]:
    if not HAS_BPY:
        pytest.skip("needs the extension installed in Blender's Python module")
    return Installed


@pytest.fixture(scope="session")
def built_extension() -> Path:
    """The folder of the built extension's files (installed or unpacked), for tests that read them."""
    if Installed.extension_dir is None:
        pytest.skip("needs the built extension (not the source tree)")
    return Installed.extension_dir


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


@pytest.fixture(scope="session")
def head():
    """Full synthetic head: a remeshed, sculpted face plus cranium cap, ears, neck and shoulders (chest ahead
    of the nose), scaled and moved; read-only for the engine tests that share it."""
    from faces_hands_addon.fitting import testdata
    return testdata.full_head(0, spacing=0.005, body_spacing=0.02, scale=0.9, offset=(0.4, -0.3, 1.5))


def addon_module(name: str):
    """A module of the installed extension, by its path inside it (``operators.face.operators``)."""
    return sys.modules[f"{blender_env.MODULE}.{name}"]


def fh_command(installed, *args) -> list[str]:
    """The command line ./fh runs (same launcher), against the session's isolated install."""
    return [sys.executable, str(ROOT / "scripts" / "fh_launch.py"), "--user-dir", str(installed.user_dir),
            "--", *map(str, args)]


def run_fh(installed, *args, cwd=None, timeout=600, env=None):
    """Run the CLI the way ./fh does, against the session's isolated install."""
    import subprocess
    return subprocess.run(fh_command(installed, *args), cwd=cwd or ROOT, capture_output=True, text=True,
                          timeout=timeout, env=env)
