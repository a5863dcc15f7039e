"""The extension as users get it: zip contents, Blender's validation, install/enable/disable cycles."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import blender_env  # noqa: E402

pytestmark = pytest.mark.smoke

DEV_ONLY = ("tests/", "bench/", "scripts/", ".ci/", ".git/", "Makefile", "fh", "pytest.ini", "CONTRIBUTING.md",
            ".gitignore", "dist/", "out/", ".venv", ".blender-user")


def _manifest():
    return tomllib.loads((ROOT / "blender_manifest.toml").read_text())


def test_zip_has_no_dev_files(installed):
    with zipfile.ZipFile(installed.zip_path) as archive:
        names = archive.namelist()
    offenders = [n for n in names if n.startswith(DEV_ONLY) or n in DEV_ONLY or "__pycache__" in n]
    assert not offenders, f"dev files shipped in the zip: {offenders[:10]}"
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert any(n.startswith("faces_hands_addon/") for n in names)


def test_zip_has_exactly_the_wheels_of_its_line_and_platform(installed):
    from build_ext import line_of_python, wheel_fits
    line = line_of_python()
    with zipfile.ZipFile(installed.zip_path) as archive:
        wheels = sorted(Path(n).name for n in archive.namelist() if n.endswith(".whl"))
        shipped = tomllib.loads(archive.read("blender_manifest.toml").decode())
    listed = [Path(w).name for w in _manifest()["wheels"]]
    assert wheels == sorted(w for w in listed if wheel_fits(w, line, "linux-x64"))
    assert {w.split("-")[0] for w in wheels} == {"scipy", "soundfile", "cffi", "pycparser", "espeakng_loader", "h5py",
                                                 "pocketsphinx", "numba", "llvmlite", "threadpoolctl"}
    assert shipped["platforms"] == ["linux-x64"]
    expected = {"py311": ("4.5.0", "5.1.0"), "py313": ("5.2.0", "5.4.0")}[line]
    assert (shipped["blender_version_min"], shipped["blender_version_max"]) == expected


def test_manifest_has_every_dependency_for_every_line_and_platform():
    from build_ext import LINES, PLATFORMS, wheel_fits
    listed = [Path(w).name for w in _manifest()["wheels"]]
    for line in LINES:
        for platform in PLATFORMS:
            found = {w.split("-")[0] for w in listed if wheel_fits(w, line, platform)}
            # the simulation kernel's numba: no numba release has Intel-macOS wheels for numpy 2.5 (numpy path)
            kernel = set() if platform == "macos-x64" else {"numba", "llvmlite"}
            assert found == {"scipy", "soundfile", "cffi", "pycparser", "espeakng_loader", "pocketsphinx", "h5py",
                             "threadpoolctl", *kernel}, (line, platform, found)
            scipy = [w for w in listed if w.startswith("scipy-") and wheel_fits(w, line, platform)]
            assert len(scipy) == 1, (line, platform, scipy)


def test_engine_never_imports_blender(installed):
    """Import every engine module from the installed copy in a Python where bpy/mathutils/bmesh
    cannot be imported at all."""
    script = textwrap.dedent(f"""
        import importlib, pkgutil, sys
        class Block:
            def find_spec(self, name, path=None, target=None):
                if name.split('.')[0] in ('bpy', 'mathutils', 'bmesh', 'bpy_extras', 'gpu'):
                    raise ImportError('engine imported ' + name)
        sys.meta_path.insert(0, Block())
        sys.path[:0] = [{str(installed.extension_dir)!r}, {str(blender_env.wheel_site_packages(installed.user_dir))!r}]
        import faces_hands_addon
        names = [m.name for m in pkgutil.walk_packages(faces_hands_addon.__path__, 'faces_hands_addon.')]
        for name in names:
            importlib.import_module(name)
        print(len(names) + 1)
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert int(result.stdout.strip().splitlines()[-1]) >= 2


CYCLE_SCRIPT = r"""
import json, subprocess, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import blender_env
zip_path, user_dir, tool = Path(sys.argv[2]), Path(sys.argv[3]), sys.argv[4]
blender_env.install(zip_path, user_dir)
import bpy, addon_utils
module = blender_env.MODULE
def state():
    return {
        "enabled": module in {a.module for a in bpy.context.preferences.addons},
        "operators": sorted(n for n in dir(bpy.types) if n.startswith(("FH_", "FACES_HANDS_"))),
        "scene_prop": hasattr(bpy.types.Scene, "faces_hands"),
        "registry": sys.modules[module + ".operators.bases.registry"].registered_summary()
                    if module + ".operators.bases.registry" in sys.modules else None,
        "menu_entries": sum(1 for menu in ("VIEW3D_MT_add", "VIEW3D_MT_object", "TOPBAR_MT_file_export")
                            for f in getattr(getattr(bpy.types, menu).draw, "_draw_funcs", [])
                            if getattr(f, "__module__", "").startswith(module)),
        "handlers": sum(1 for name in dir(bpy.app.handlers) if not name.startswith("_")
                        for h in (getattr(bpy.app.handlers, name) if isinstance(getattr(bpy.app.handlers, name), list) else [])
                        if getattr(h, "__module__", "").startswith(module)),
    }
states = {"installed": state()}
addon_utils.disable(module, default_set=True)
states["disabled"] = state()
addon_utils.enable(module, default_set=True)
states["reenabled"] = state()
addon_utils.disable(module, default_set=True)
states["disabled_again"] = state()
addon_utils.enable(module, default_set=True)
states["enabled_again"] = state()
print("STATES " + json.dumps(states))
"""


def _ops_exist(bpy_state):
    return bool(bpy_state["operators"]) and bpy_state["scene_prop"]


def test_build_validate_install_enable_disable_reenable(tmp_path):
    """Build with Blender's own tool (the staged build of scripts/build_ext.py), validate, install into a fresh
    user folder, then cycle
    enable -> disable -> enable twice in a fresh process: nothing stale survives a disable."""
    from build_ext import blender_ext_script, build, line_of_python
    tool = blender_ext_script()
    zip_path = build(line_of_python(), "linux-x64", tmp_path / "dist", tool)   # built and validated
    validate = subprocess.run([sys.executable, str(tool), "validate", str(zip_path)],
                              capture_output=True, text=True)
    assert validate.returncode == 0, validate.stdout + validate.stderr
    run = subprocess.run([sys.executable, "-c", CYCLE_SCRIPT, str(ROOT / "scripts"), str(zip_path),
                          str(tmp_path / "user"), str(tool)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    line = next(l for l in run.stdout.splitlines() if l.startswith("STATES "))
    states = json.loads(line[len("STATES "):])
    for key in ("installed", "reenabled", "enabled_again"):
        assert states[key]["enabled"] and _ops_exist(states[key]), (key, states[key])
        assert states[key]["menu_entries"] == 3, (key, states[key])
    for key in ("disabled", "disabled_again"):
        assert not states[key]["enabled"], (key, states[key])
        assert states[key]["operators"] == [], (key, states[key])
        assert not states[key]["scene_prop"], (key, states[key])
        assert states[key]["handlers"] == 0, (key, states[key])
        assert states[key]["menu_entries"] == 0, (key, states[key])
        assert states[key]["registry"] == {"classes": [], "properties": [], "handlers": [], "timers": [],
                                           "cli": 0, "menus": []}, (key, states[key])
    assert states["installed"]["operators"] == states["enabled_again"]["operators"]
