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

ROOT = Path(__file__).resolve().parents[2]
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


def test_zip_has_wheels_for_every_platform(installed):
    manifest = _manifest()
    with zipfile.ZipFile(installed.zip_path) as archive:
        wheels = [Path(n).name for n in archive.namelist() if n.endswith(".whl")]
    assert sorted(wheels) == sorted(Path(w).name for w in manifest["wheels"])
    distributions = {w.split("-")[0] for w in wheels}
    for required in ("scipy", "soundfile", "espeakng_loader", "pocketsphinx"):
        assert required in distributions
    platform_words = {"linux-x64": ("linux",), "windows-x64": ("win_amd64",),
                      "macos-arm64": ("arm64", "universal2")}
    for platform in manifest["platforms"]:
        for dist in distributions:
            candidates = [w for w in wheels if w.split("-")[0] == dist]
            ok = [w for w in candidates
                  if w.endswith("-any.whl") or any(word in w.split("-")[-1] for word in platform_words[platform])]
            assert ok, f"no {dist} wheel for {platform}"


def test_manifest_fields():
    manifest = _manifest()
    assert manifest["id"] == "faces_hands" and manifest["type"] == "add-on"
    assert manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert manifest["blender_version_min"] == "4.5.0"
    assert set(manifest["platforms"]) == {"linux-x64", "windows-x64", "macos-arm64"}
    assert "files" in manifest["permissions"]


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
        "registry": sys.modules[module + ".operators.registry"].registered_summary()
                    if module + ".operators.registry" in sys.modules else None,
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
    """Build with Blender's own tool, validate, install into a fresh user folder, then cycle
    enable -> disable -> enable twice in a fresh process: nothing stale survives a disable."""
    from build_ext import blender_ext_script
    tool = blender_ext_script()
    zip_path = tmp_path / "faces_hands-test.zip"
    build = subprocess.run([sys.executable, str(tool), "build", "--source-dir", str(ROOT),
                            "--output-filepath", str(zip_path)], capture_output=True, text=True)
    assert build.returncode == 0, build.stdout[-2000:] + build.stderr[-2000:]
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
    for key in ("disabled", "disabled_again"):
        assert not states[key]["enabled"], (key, states[key])
        assert states[key]["operators"] == [], (key, states[key])
        assert not states[key]["scene_prop"], (key, states[key])
        assert states[key]["handlers"] == 0, (key, states[key])
        assert states[key]["registry"] == {"classes": [], "properties": [], "handlers": [], "timers": [],
                                           "cli": 0}, (key, states[key])
    assert states["installed"]["operators"] == states["enabled_again"]["operators"]
