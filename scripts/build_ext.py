#!/usr/bin/env python3
"""Build the extension zips with Blender's own tool and validate each one.

One zip per Python line and platform: Blender 4.5 LTS and 5.0 embed Python 3.11, Blender 5.2 LTS and 5.3
embed Python 3.13, and each zip carries only the wheels its Python and platform install and claims exactly
its line of Blender versions. The source manifest (``blender_manifest.toml``) lists every wheel of every
line; for each zip a staged copy of the sources gets a manifest with that line's range, that platform and
those wheels, and ``blender_ext.py build`` + ``validate`` (from the ``bpy`` wheel, no Blender binary needed)
turn it into ``dist/faces_hands-<version>-<line>-<platform>.zip``.

Usage: build_ext.py --line py311|py313|all --platform linux-x64|windows-x64|macos-arm64|macos-x64|all
                    [--out-dir dist]
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: Python line -> (wheel tag, lowest Blender version, first Blender version not claimed, Blender lines)
LINES = {"py311": ("cp311", "4.5.0", "5.1.0", "Blender 4.5 LTS and 5.0"),
         "py313": ("cp313", "5.2.0", "5.4.0", "Blender 5.2 LTS and 5.3")}
PLATFORMS = ("linux-x64", "windows-x64", "macos-arm64", "macos-x64")
#: never staged (dev files; the manifest's own exclusions also apply when Blender builds)
SKIP = {".git", ".ci", ".cache", "dist", "out", "wheels", "tests", "bench", "scripts", "fh", "Makefile",
        "CONTRIBUTING.md", "docs", "__pycache__", ".pytest_cache", ".gitignore", ".fh-setup.log"}


def line_of_python(version: tuple[int, int] | None = None) -> str:
    """The Python line of this interpreter (or of ``version``)."""
    major, minor = version or sys.version_info[:2]
    tag = f"cp{major}{minor}"
    found = [line for line, spec in LINES.items() if spec[0] == tag]
    if not found:
        sys.exit(f"error: Python {major}.{minor} is no Blender line this extension ships for")
    return found[0]


def zip_name(version: str, line: str, platform: str) -> str:
    return f"faces_hands-{version}-{line}-{platform.replace('-', '_')}.zip"


def wheel_fits(name: str, line: str, platform: str) -> bool:
    """Does wheel file ``name`` install on ``platform`` under the Python of ``line``?"""
    parts = name[:-len(".whl")].split("-")
    python_tags, platform_tag = parts[-3].split("."), parts[-1]
    if not any(tag in (LINES[line][0], "py3", "py2") for tag in python_tags):
        return False
    if platform_tag == "any":
        return True
    if platform == "linux-x64":
        return "linux" in platform_tag and "x86_64" in platform_tag
    if platform == "windows-x64":
        return "win_amd64" in platform_tag
    arch = "arm64" if platform == "macos-arm64" else "x86_64"
    return "macosx" in platform_tag and (arch in platform_tag or "universal2" in platform_tag)


def blender_ext_script() -> Path:
    import importlib.util
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        sys.exit("error: bpy is not installed in this Python; run `make venv`")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit("error: blender_ext.py not found inside the bpy wheel")
    return found[-1]


def staged_manifest(text: str, line: str, platform: str, wheels: list[str]) -> str:
    _, low, high, _ = LINES[line]
    text = re.sub(r'^blender_version_min = ".*"$', f'blender_version_min = "{low}"', text, flags=re.M)
    text = re.sub(r'^blender_version_max = ".*"$', f'blender_version_max = "{high}"', text, flags=re.M)
    text = re.sub(r"^platforms = \[.*\]$", f'platforms = ["{platform}"]', text, flags=re.M)
    listed = "wheels = [\n" + "".join(f'  "./wheels/{w}",\n' for w in wheels) + "]"
    return re.sub(r"^wheels = \[\n.*?\n\]", listed, text, flags=re.M | re.S)


def _stage(stage: Path, line: str, platform: str) -> int:
    """Copy the shipped sources into ``stage`` with this zip's manifest and wheels; returns the wheel count."""
    manifest_text = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
    manifest = tomllib.loads(manifest_text)
    wheels = [Path(w).name for w in manifest["wheels"] if wheel_fits(Path(w).name, line, platform)]
    for item in ROOT.iterdir():
        if item.name in SKIP or item.name.startswith((".venv", ".blender-user")) or item.name == "blender_manifest.toml":
            continue
        if item.is_dir():
            shutil.copytree(item, stage / item.name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(item, stage / item.name)
    (stage / "wheels").mkdir()
    for name in wheels:
        source = ROOT / "wheels" / name
        if not source.exists():
            sys.exit(f"error: {source} is missing; run `make wheels`")
        try:
            os.link(source, stage / "wheels" / name)
        except OSError:
            shutil.copy2(source, stage / "wheels" / name)
    (stage / "blender_manifest.toml").write_text(staged_manifest(manifest_text, line, platform, wheels),
                                                 encoding="utf-8")
    return len(wheels)


def build(line: str, platform: str, out_dir: Path, tool: Path) -> Path:
    version = tomllib.loads((ROOT / "blender_manifest.toml").read_text())["version"]
    out = out_dir / zip_name(version, line, platform)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        stage = Path(tmp) / "source"
        stage.mkdir()
        wheels = _stage(stage, line, platform)
        staged = Path(tmp) / out.name
        subprocess.run([sys.executable, str(tool), "build", "--source-dir", str(stage),
                        "--output-filepath", str(staged)], check=True, stdout=subprocess.DEVNULL)
        subprocess.run([sys.executable, str(tool), "validate", str(staged)], check=True, stdout=subprocess.DEVNULL)
        with zipfile.ZipFile(staged) as archive:
            names = archive.namelist()
        staged.replace(out)
    print(f"built {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}: {len(names)} files, "
          f"{wheels} wheels, {out.stat().st_size / 1e6:.1f} MB ({LINES[line][3]}, {platform})")
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--line", default="this", choices=(*LINES, "all", "this"),
                        help="Python line (default: this interpreter's)")
    parser.add_argument("--platform", default="linux-x64", choices=(*PLATFORMS, "all"))
    parser.add_argument("--out-dir", type=Path, default=ROOT / "dist")
    args = parser.parse_args()
    lines = list(LINES) if args.line == "all" else [line_of_python() if args.line == "this" else args.line]
    platforms = list(PLATFORMS) if args.platform == "all" else [args.platform]
    tool = blender_ext_script()
    for line in lines:
        for platform in platforms:
            build(line, platform, args.out_dir.resolve(), tool)
    return 0


if __name__ == "__main__":
    sys.exit(main())
