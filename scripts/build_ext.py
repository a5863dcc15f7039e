#!/usr/bin/env python3
"""Build the extension zip with Blender's own tool and validate it.

Blender's ``blender_ext.py`` ships inside the ``bpy`` wheel
(``bpy/<ver>/scripts/addons_core/bl_pkg/cli/blender_ext.py``) and runs without a Blender binary.
Usage: build_ext.py --out dist/faces_hands-<version>.zip
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def blender_ext_script() -> Path:
    import importlib.util
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        sys.exit("error: bpy is not installed in this Python; run `make venv`")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit("error: blender_ext.py not found inside the bpy wheel")
    return found[-1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args()
    tool = blender_ext_script()
    out = args.out.resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=out.parent) as tmp:
        staged = Path(tmp) / out.name
        subprocess.run([sys.executable, str(tool), "build", "--source-dir", str(ROOT),
                        "--output-filepath", str(staged)], check=True, stdout=subprocess.DEVNULL)
        subprocess.run([sys.executable, str(tool), "validate", str(staged)], check=True)
        with zipfile.ZipFile(staged) as archive:
            names = archive.namelist()
        staged.replace(out)
    size_mb = out.stat().st_size / 1e6
    wheels = sum(name.endswith(".whl") for name in names)
    print(f"built {out.relative_to(ROOT)}: {len(names)} files, {wheels} wheels, {size_mb:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
