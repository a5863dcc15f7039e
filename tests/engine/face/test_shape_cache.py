"""Settled target shapes cached on disk (anim.shape_cache): a hit is byte-identical to a fresh settle."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.anim import baking
from faces_hands_addon.anim.shape_cache import ShapeCache
from faces_hands_addon.core.rig import save_rig
from faces_hands_addon.face.rig import build_default_rig

EXPRESSIONS = {"open": {"jaw_open": 0.6}, "smile": {"zygomaticus_major_L": 0.8, "zygomaticus_major_R": 0.8}}


@pytest.fixture(scope="module")
def rig():
    rig = build_default_rig("default")
    save_rig(rig)                                      # gives the rig its identity, as the store does
    return rig


def _arrays(shapes):
    return [(s.name, {k: v.tobytes() for k, v in s.pose.positions.items()},
             {k: v.tobytes() for k, v in s.pose.transforms.items()}) for s in shapes]


def test_a_cached_shape_is_the_simulated_one_byte_for_byte(rig, tmp_path):
    fresh = _arrays(baking.expression_shapes(rig, EXPRESSIONS))
    cache = ShapeCache(tmp_path)
    first = _arrays(baking.expression_shapes(rig, EXPRESSIONS, cache=cache))
    assert (cache.hits, cache.misses) == (0, 2) and len(list(tmp_path.glob("*.npz"))) == 2
    again = ShapeCache(tmp_path)
    second = _arrays(baking.expression_shapes(rig, EXPRESSIONS, cache=again))
    assert (again.hits, again.misses) == (2, 0)
    assert fresh == first == second


def test_another_rig_or_other_values_miss_and_a_corrupt_entry_is_recomputed(rig, tmp_path):
    cache = ShapeCache(tmp_path)
    list(baking.expression_shapes(rig, {"open": {"jaw_open": 0.6}}, cache=cache))
    list(baking.expression_shapes(rig, {"open": {"jaw_open": 0.61}}, cache=cache))
    assert cache.misses == 2
    for entry in tmp_path.glob("*.npz"):
        entry.write_bytes(entry.read_bytes()[:100])          # truncated
    again = ShapeCache(tmp_path)
    shape = next(baking.expression_shapes(rig, {"open": {"jaw_open": 0.6}}, cache=again))
    assert again.misses == 1 and np.all(np.isfinite(shape.pose.positions["skin"]))
    unnamed = build_default_rig("default")                 # no identity yet: never cached
    nothing = ShapeCache(tmp_path / "other")
    next(baking.expression_shapes(unnamed, {"open": {"jaw_open": 0.6}}, cache=nothing))
    assert not (tmp_path / "other").exists()


def test_shapes_settled_on_two_threads_are_the_ones_settled_one_by_one(rig, tmp_path, monkeypatch):
    """baking settles static shapes on worker copies of the rig, two at a time; each is byte-identical to
    the shape the rig settles alone, comes out in order, is cached as before, and the rig itself is left
    alone (its own simulation state is not touched by the workers)."""
    expressions = dict(EXPRESSIONS, blink={"eyelid_close_L": 1.0, "eyelid_close_R": 1.0},
                       pucker={"orbicularis_oris_upper": 0.7, "orbicularis_oris_protrusion": 0.8},
                       brows={"frontalis_inner_L": 1.0, "frontalis_outer_R": 0.6})
    monkeypatch.setattr(baking, "SETTLE_THREADS", 1)
    alone = _arrays(baking.expression_shapes(rig, expressions)) + _arrays(baking.basis_shapes(rig, 0.3))
    monkeypatch.setattr(baking, "SETTLE_THREADS", 2)
    rig.set_controls({"jaw_open": 0.3})
    rig.step_frame(1 / 24)
    before = rig.face.network.positions.copy()
    generator = baking.expression_shapes(rig, expressions, cache=ShapeCache(tmp_path))
    first = next(generator)
    assert np.array_equal(rig.face.network.positions, before)              # workers use their own copies
    threaded = _arrays([first, *generator]) + _arrays(baking.basis_shapes(rig, 0.3))
    assert [entry[0] for entry in threaded] == [entry[0] for entry in alone]
    assert threaded == alone
    again = ShapeCache(tmp_path)
    assert _arrays(baking.expression_shapes(rig, expressions, cache=again))[:5] == alone[:5]
    assert (again.hits, again.misses) == (5, 0)


@pytest.mark.parametrize("threads", [1, 2])
def test_an_expression_met_twice_is_settled_once(rig, tmp_path, monkeypatch, threads):
    """Equal control dicts (the visemes DD and nn) settle once: the same bytes, each shape its own arrays,
    one cache entry."""
    monkeypatch.setattr(baking, "SETTLE_THREADS", threads)
    settled = []
    plain = type(rig).settled
    monkeypatch.setattr(type(rig), "settled", lambda self, *a, **k: settled.append(1) or plain(self, *a, **k))
    expressions = dict(EXPRESSIONS, again=dict(EXPRESSIONS["open"]))
    cache = ShapeCache(tmp_path)
    shapes = list(baking.expression_shapes(rig, expressions, cache=cache))
    assert len(settled) == 2 and (cache.hits, cache.misses) == (0, 2)
    assert [s.name for s in shapes] == ["open", "smile", "again"]
    first, twin = shapes[0].pose.positions["skin"], shapes[2].pose.positions["skin"]
    assert np.array_equal(first, twin) and first is not twin
    assert not np.array_equal(first, shapes[1].pose.positions["skin"])


def test_entries_read_once_are_kept_in_memory_while_their_file_is_unchanged(rig, tmp_path, monkeypatch):
    """A jobs worker bakes every line with the same targets: the second lookup in the process reads no
    file; the kept copy is byte-identical and a private copy (a caller writing into it changes nothing);
    an entry whose file was replaced or removed is read again (or missed), never answered from memory."""
    from faces_hands_addon.anim import shape_cache
    cache = ShapeCache(tmp_path)
    fresh = _arrays(baking.expression_shapes(rig, EXPRESSIONS, cache=cache))
    reads = []
    plain = shape_cache._read_file
    monkeypatch.setattr(shape_cache, "_read_file", lambda path: reads.append(path) or plain(path))
    again = ShapeCache(tmp_path)
    shapes = list(baking.expression_shapes(rig, EXPRESSIONS, cache=again))
    assert (again.hits, again.misses, reads) == (2, 0, [])
    assert _arrays(shapes) == fresh
    shapes[0].pose.positions["skin"][:] = 0.0                      # the caller's copy only
    assert _arrays(baking.expression_shapes(rig, EXPRESSIONS, cache=ShapeCache(tmp_path))) == fresh
    entry = sorted(tmp_path.glob("*.npz"))[0]
    entry.write_bytes(entry.read_bytes()[:100])                     # replaced behind the process's back
    third = ShapeCache(tmp_path)
    assert _arrays(baking.expression_shapes(rig, EXPRESSIONS, cache=third)) == fresh
    assert reads == [entry] and third.misses == 1
    for path in tmp_path.glob("*.npz"):
        path.unlink()
    gone = ShapeCache(tmp_path)
    list(baking.expression_shapes(rig, EXPRESSIONS, cache=gone))
    assert (gone.hits, gone.misses) == (0, 2)
