"""Time per slider change of a morphable face (thesis 5.1.4: "an immediate update of the displayed face"):
attribute update + constraint solve (Eq. 3.6, one constraint) + writing the vertices (and colours) into
Blender, for the default model and for a random model of 50,000 vertices with 199 components.
Last line: ``RESULT slider_ms_default=... slider_ms_50k=...`` (medians)."""
from __future__ import annotations

import importlib
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from faces_hands_addon.morph import model as build  # noqa: E402

services = importlib.import_module(f"{_harness.blender_env.MODULE}.operators.morph.services")


def random_model(vertices=50_000, components=199, seed=0):
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(vertices)))
    xs, zs = np.meshgrid(np.linspace(-0.08, 0.08, side), np.linspace(-0.1, 0.1, side))
    grid = np.stack([xs.ravel(), np.zeros(xs.size), zs.ravel()], axis=1)[:vertices]
    quads = [(j * side + i, j * side + i + 1, (j + 1) * side + i + 1) for j in range(side - 1) for i in range(side - 1)]
    triangles = np.array([t for t in quads if max(t) < vertices])
    basis, _ = np.linalg.qr(rng.standard_normal((3 * vertices, components)))
    sd = np.linspace(0.004, 0.0002, components)
    attributes = {name: build.Attribute(name, "overall", rng.standard_normal(components) * sd, None)
                  for name in ("a", "b")}
    return build.MorphableModel("random 50k", build.PcaPart(grid.ravel(), basis, sd), triangles,
                                attributes=attributes, segments={"face": np.ones(vertices, bool)})


def time_slider(obj, name, constrained, repeats=40) -> tuple[float, float]:
    """Median ms per change once the directions are cached, and ms of the first change (builds the cache)."""
    services.apply(obj, lambda f: f.constrain(constrained))
    start = time.perf_counter()
    services.apply(obj, lambda f: f.set_attribute(name, 0.01))   # first touch builds the direction cache
    first = (time.perf_counter() - start) * 1000.0
    times = []
    for step in range(repeats):
        value = 0.5 * np.sin(step / 3.0)
        start = time.perf_counter()
        services.apply(obj, lambda f: f.set_attribute(name, value, "both" if f.colour is not None else "shape"))
        times.append((time.perf_counter() - start) * 1000.0)
    return statistics.median(times), first


def time_ui_slider(obj, name, repeats=40) -> float:
    """The same through the panel: the slider property's update runs faces_hands.morph_set_attribute."""
    item = next(i for i in obj.faces_hands_morph.sliders if i.name == name)
    times = []
    for step in range(repeats):
        start = time.perf_counter()
        item.shape = 0.5 * np.cos(step / 3.0)
        times.append((time.perf_counter() - start) * 1000.0)
    return statistics.median(times)


bpy.ops.wm.read_homefile(use_empty=True)
default = services.create_face_object(bpy.context)
default_ms, default_first = time_slider(default, "eyebrows-eyes distance", "masculine-feminine")
ui_ms = time_ui_slider(default, "narrow-wide")
model = services.model_for()
print(f"default model: {model.vertex_count} vertices, {model.shape.components} shape + "
      f"{model.colour.components} colour components: {default_ms:.3f} ms per slider change (shape + colour, "
      f"one constraint; first change {default_first:.1f} ms); through the panel's slider {ui_ms:.3f} ms")
services.remember_model("random-50k", random_model())
big = services.create_face_object(bpy.context, "random-50k")
big_ms, big_first = time_slider(big, "b", "a")
print(f"random model: 50000 vertices, 199 components: {big_ms:.3f} ms per slider change "
      f"(one constraint; first change {big_first:.1f} ms)")
print(f"RESULT slider_ms_default={default_ms:.3f} slider_ms_50k={big_ms:.3f}")
