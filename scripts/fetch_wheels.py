#!/usr/bin/env python3
"""Download every wheel the manifest lists, unmodified from PyPI, into ./wheels/ (git-ignored).

The manifest's ``wheels = [...]`` is the single list of what ships. For each entry this script asks
pip for exactly that file (distribution, version, Python tag and platform tags are read from the file
name), then checks its SHA-256 against ``scripts/wheels.lock``. Files already present with the right
checksum are not fetched again, so ``make wheels`` is cheap after the first run.

Usage: fetch_wheels.py [--update-lock]
"""
from __future__ import annotations

import hashlib
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LOCK = ROOT / "scripts" / "wheels.lock"


def sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def read_lock() -> dict[str, str]:
    table = {}
    if LOCK.exists():
        for line in LOCK.read_text().splitlines():
            if line.strip():
                digest, name = line.split()
                table[name] = digest
    return table


def pip_download(filename: str, dest: Path) -> None:
    """Fetch one wheel file by its exact name from the package index."""
    parts = filename[:-4].split("-")
    dist, version, py_tag, _abi_tag, plat_tag = parts[0], parts[1], parts[-3], parts[-2], parts[-1]
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:",
           f"{dist}=={version}", "-d", str(dest)]
    if plat_tag != "any":
        for tag in plat_tag.split("."):
            cmd += ["--platform", tag]
        python_version = "3.11"
        for tag in py_tag.split("."):
            if tag.startswith("cp") and tag[2:].isdigit():
                python_version = f"{tag[2]}.{tag[3:]}"
        cmd += ["--python-version", python_version]
    subprocess.run(cmd, check=True)


def main() -> int:
    update_lock = "--update-lock" in sys.argv
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    wanted = [Path(entry).name for entry in manifest.get("wheels", [])]
    wheel_dir = ROOT / "wheels"
    wheel_dir.mkdir(exist_ok=True)
    lock = read_lock()
    bad = []
    for name in wanted:
        target = wheel_dir / name
        if not target.exists() or (name in lock and sha256(target) != lock[name]):
            print(f"fetching {name}", flush=True)
            with tempfile.TemporaryDirectory() as tmp:
                pip_download(name, Path(tmp))
                got = Path(tmp) / name
                if not got.exists():
                    found = ", ".join(p.name for p in Path(tmp).iterdir())
                    print(f"error: pip returned {found or 'nothing'} instead of {name}", file=sys.stderr)
                    return 1
                got.replace(target)
        digest = sha256(target)
        if update_lock:
            lock[name] = digest
        elif lock.get(name) != digest:
            bad.append(name)
    if update_lock:
        LOCK.write_text("".join(f"{lock[n]}  {n}\n" for n in sorted(wanted)))
    if bad:
        print("error: checksum mismatch or missing lock entry for: " + ", ".join(bad), file=sys.stderr)
        return 1
    stale = sorted(p.name for p in wheel_dir.glob("*.whl") if p.name not in wanted)
    for name in stale:
        (wheel_dir / name).unlink()
    print(f"wheels: {len(wanted)} files verified in {wheel_dir.relative_to(ROOT)}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
