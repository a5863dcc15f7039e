"""The built default rigs kept in the user's cache folder: a line spoken on the cached rig has the bytes of
one spoken on a rig built for it, and a damaged cache file is said, built again and stored sound."""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

from conftest import run_fh

FPS, DAMAGED_FPS = "20", "15"      # frame rates no other test uses: cache entries of their own


def _speak(installed, out: Path, *extra, cached: bool = True, fps: str = FPS):
    env = dict(os.environ, FH_NO_RIG_CACHE="0" if cached else "1")
    result = run_fh(installed, "speak", "--text", "Good morning.", "--out", out, "--fps", fps, *extra, env=env)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-3000:]
    return result.stdout + result.stderr


def _record(said: str) -> Path:
    match = re.search(r"the default \w+ (?:from the cache|kept for the next runs): (\S+\.json)", said)
    assert match, said[-2000:]
    return Path(match.group(1))


@pytest.mark.parametrize("rig", [("--rig", "mask"), ()], ids=["mask", "character"])
def test_a_cache_hit_gives_the_bytes_of_a_build(installed, tmp_path, rig):
    built = _speak(installed, tmp_path / "built" / "line.glb", *rig, cached=False)
    assert "from the cache" not in built and "kept for the next runs" not in built
    first = _speak(installed, tmp_path / "first" / "line.glb", *rig)           # a hit or a build stored
    said = _speak(installed, tmp_path / "hit" / "line.glb", *rig)
    assert "from the cache" in said, said[-2000:]
    record = json.loads(_record(said).read_text())
    assert record["parts"]["options"]["fps"] == float(FPS) and record["parts"]["blender"] and record["parts"]["extension"]
    expected = (tmp_path / "built" / "line.glb").read_bytes()
    for name in ("first", "hit"):
        assert (tmp_path / name / "line.glb").read_bytes() == expected, (name, first[-1000:])


def test_a_damaged_cache_file_is_built_again_with_a_message(installed, tmp_path):
    said = _speak(installed, tmp_path / "warm" / "line.glb", "--rig", "mask", fps=DAMAGED_FPS)
    record = _record(said)
    content = record.parent / json.loads(record.read_text())["file"]
    data = bytearray(content.read_bytes())
    data[len(data) // 2] ^= 0xFF                         # one byte flipped, the size unchanged
    content.write_bytes(bytes(data))
    said = _speak(installed, tmp_path / "damaged" / "line.glb", "--rig", "mask", fps=DAMAGED_FPS)
    assert re.search(r"warning: the cached default mask \(.+\) cannot be used: .+ does not match its checksum; "
                     r"building it again", said), said[-2000:]
    assert "kept for the next runs" in said
    assert (tmp_path / "damaged" / "line.glb").read_bytes() == (tmp_path / "warm" / "line.glb").read_bytes()
    said = _speak(installed, tmp_path / "again" / "line.glb", "--rig", "mask", fps=DAMAGED_FPS)
    assert "from the cache" in said, said[-2000:]
