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
