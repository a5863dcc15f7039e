"""Whole files kept by key (the built default character): a sound entry comes back byte for byte, a damaged,
missing or foreign one is reported and never copied out, writers racing on one key leave a whole entry."""
from __future__ import annotations

import json
import threading

import pytest

from faces_hands_addon.core.file_cache import FileCache, cache_key, tree_fingerprint


@pytest.fixture
def stored(tmp_path):
    source = tmp_path / "rig.blend"
    source.write_bytes(b"BLENDER-v500" + bytes(range(256)) * 40)
    cache = FileCache(tmp_path / "cache")
    key = cache_key({"what": "character", "fps": 30.0})
    assert cache.store(key, source, {"fps": 30.0}) == cache.record_path(key)
    return cache, key, source


def test_a_stored_file_comes_back_byte_for_byte(stored, tmp_path):
    cache, key, source = stored
    out = tmp_path / "back.blend"
    assert cache.fetch(key, out).hit
    assert out.read_bytes() == source.read_bytes()
    assert not cache.fetch(cache_key({"what": "character", "fps": 24.0}), tmp_path / "other.blend").hit


def test_the_key_changes_with_every_part():
    base = {"what": "character", "fps": 30.0, "extension": "a", "blender": "5.0.1"}
    keys = {cache_key(base)} | {cache_key({**base, name: "changed"}) for name in base}
    assert len(keys) == len(base) + 1
    assert cache_key(dict(reversed(list(base.items())))) == cache_key(base)


def _content(cache, key):
    return cache.folder / json.loads(cache.record_path(key).read_text())["file"]


@pytest.mark.parametrize("damage, problem", [
    (lambda cache, key: _content(cache, key).write_bytes(b"x" * _content(cache, key).stat().st_size),
     "does not match its checksum"),
    (lambda cache, key: _content(cache, key).write_bytes(_content(cache, key).read_bytes()[:-7]),
     "does not match its checksum"),
    (lambda cache, key: _content(cache, key).unlink(), "is missing"),
    (lambda cache, key: cache.record_path(key).write_text("{not json"), "not readable"),
    (lambda cache, key: cache.record_path(key).write_text(
        cache.record_path(key).read_text().replace(key, "0" * 40)), "another key"),
])
def test_a_damaged_entry_is_reported_and_never_copied_out(stored, tmp_path, damage, problem):
    cache, key, source = stored
    damage(cache, key)
    out = tmp_path / "back.blend"
    fetched = cache.fetch(key, out)
    assert not fetched.hit and problem in fetched.problem
    assert not out.exists()
    cache.store(key, source)                     # the rebuild stored over it is sound again
    assert cache.fetch(key, out).hit and out.read_bytes() == source.read_bytes()


def test_writers_racing_on_one_key_leave_a_whole_entry(tmp_path):
    cache = FileCache(tmp_path / "cache")
    key = cache_key({"what": "race"})
    sources = []
    for n in range(6):
        sources.append(tmp_path / f"build{n}.blend")
        sources[-1].write_bytes(bytes([n]) * (200_000 + n))       # each build's bytes differ
    threads = [threading.Thread(target=cache.store, args=(key, source)) for source in sources]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    out = tmp_path / "back.blend"
    assert cache.fetch(key, out).hit
    assert out.read_bytes() in {source.read_bytes() for source in sources}
    assert not list(cache.folder.glob(".fh-file-*"))             # no temporary file left


def test_old_entries_go_past_the_limit(tmp_path):
    cache = FileCache(tmp_path / "cache", keep=2)
    source = tmp_path / "rig.blend"
    keys = []
    for n in range(4):
        source.write_bytes(b"build %d" % n)
        keys.append(cache_key({"n": n}))
        cache.store(keys[-1], source)
    assert sorted(p.name for p in cache.folder.glob("*.json")) == sorted(f"{k}.json" for k in keys[-2:])


def test_the_tree_fingerprint_follows_file_bytes_not_bytecode(tmp_path):
    root = tmp_path / "extension"
    (root / "pkg" / "__pycache__").mkdir(parents=True)
    (root / "wheels").mkdir()
    (root / "pkg" / "a.py").write_text("x = 1\n")
    (root / "wheels" / "numpy-2.0.whl").write_bytes(b"w" * 10)
    before = tree_fingerprint(str(root))
    (root / "pkg" / "__pycache__" / "a.cpython-311.pyc").write_bytes(b"compiled")
    tree_fingerprint.cache_clear()
    assert tree_fingerprint(str(root)) == before
    (root / "pkg" / "a.py").write_text("x = 2\n")
    tree_fingerprint.cache_clear()
    assert tree_fingerprint(str(root)) != before
