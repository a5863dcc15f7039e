"""The morphable model of whole heads (thesis 3.2, chapter 5), measured:

* **slider_ms**: time per slider change (5.1.4: "an immediate update of the displayed face"): attribute
  update + constraint solve (Eq. 3.6, one constraint) + writing the vertices into Blender (the head object
  and the linked character body's shape key), on the default model (the character's whole head), median; also on the synthetic mask and on a random model of 50,000
  vertices with 199 components;
* **attribute_monotonic_pct**: on the HELD-OUT heads (``out/head_model_heldout.npz``, written by
  ``scripts/build_head_model.py``: heads of the same sampler that never entered the PCA nor the attributes),
  each attribute's slider is added to the held-out head at -2, -1, 0, +1, +2 and the attribute's measure
  (``heads.measures``, what its ratings were) is taken on the mesh: the share of (attribute, head) pairs
  whose measure moves strictly monotonically in the attribute's direction; the age has no measure on the
  mesh and is left out;
* **caricature_folds**: triangles folded over (normal turned > 90 degrees from the face it started from) by
  caricature levels 2, 3 and 5 of 30 random faces, summed; with the largest Mahalanobis norm reached over
  the model's radius;
* **examples** (model examples + held out) and **components** (kept; and for 95 % of the variance).

Last line: ``RESULT attribute_monotonic_pct=... examples=... components=... components_95=... slider_ms=...
caricature_folds=... ...``."""
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

from faces_hands_addon.morph import heads  # noqa: E402
from faces_hands_addon.morph import model as build  # noqa: E402
from faces_hands_addon.morph.editing import EditFace  # noqa: E402

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


def monotonic(model, held) -> tuple[float, dict]:
    """(percent of monotonic (attribute, held-out head) pairs, per attribute: (pairs monotonic, mean change
    of the measure from -2 to +2 in the model examples' standard deviations))."""
    face = EditFace(model)
    reference = [heads.measures(model.shape.vector(c).reshape(-1, 3), model) for c in model.examples["shape"]]
    total = good = 0
    table = {}
    for name, entry in model.info["attributes"].items():
        measure, sign = entry["measure"], entry["sign"]
        if measure not in heads.MEASURES:
            continue
        offset, _ = face.direction(name, "shape")
        sd = float(np.std([r[measure] for r in reference]))
        ok, spans = 0, []
        for head in held:
            values = [heads.measures(head + t * offset, model)[measure] for t in (-2, -1, 0, 1, 2)]
            ok += bool(np.all(sign * np.diff(values) > 0))
            spans.append(sign * (values[-1] - values[0]) / sd)
        table[name] = (ok, float(np.mean(spans)))
        total, good = total + len(held), good + ok
    return 100.0 * good / max(total, 1), table


def caricature_folds(model, seeds=range(1, 31), levels=(2.0, 3.0, 5.0)) -> tuple[int, float, float]:
    """(folded triangles summed, largest Mahalanobis norm over the radius, mean level reached)."""
    radius, folds, worst, reached = heads.mahalanobis_radius(model), 0, 0.0, []
    for seed in seeds:
        for level in levels:
            face = EditFace(model)
            face.create("random", seed=seed)
            start = face.shape.copy()
            face.caricature(level)
            folds += heads.folded_triangles(face.shape, start, model.triangles)
            worst = max(worst, float(np.linalg.norm(face.alpha / model.shape.sd)) / radius)
            reached.append(face.caricature_level())
    return folds, worst, float(np.mean(reached))


HELD = Path(__file__).resolve().parents[1] / "out" / "head_model_heldout.npz"
if not HELD.is_file():
    sys.exit(f"{HELD} is missing: run scripts/build_head_model.py (it writes the held-out heads there)")
bpy.ops.wm.read_homefile(use_empty=True)
default = services.create_face_object(bpy.context)
model = services.model_for()
held = np.load(HELD)["vertices"].astype(np.float64)
if held.shape[1:] != (model.vertex_count, 3):
    sys.exit(f"{HELD} holds heads of {held.shape[1]} vertices; the model has {model.vertex_count}: rebuild both")
pct, table = monotonic(model, held)
for name, (ok, span) in sorted(table.items()):
    entry = model.info["attributes"][name]
    print(f"  {name:28s} measure {entry['measure']:18s} monotonic on {ok}/{len(held)} held-out heads, "
          f"-2 -> +2 moves it {span:+.2f} SD")
folds, worst, reached = caricature_folds(model)
print(f"caricature x2/x3/x5 of 30 random faces: {folds} folded triangles, largest Mahalanobis norm "
      f"{worst:.3f} of the radius, mean level reached {reached:.2f}")
character = importlib.import_module(f"{_harness.blender_env.MODULE}.faces_hands_addon.character.body")
body_mesh = importlib.import_module(f"{_harness.blender_env.MODULE}.operators.character.objects").body_mesh
body = bpy.data.objects.new("FH Character Body", body_mesh("FH Character Body", character.character_mesh()))
bpy.context.scene.collection.objects.link(body)
services.link_character(default, body)
default_ms, default_first = time_slider(default, "thin-full lips", "masculine-feminine")
ui_ms = time_ui_slider(default, "short-long nose")
print(f"head model: {model.vertex_count} vertices, {model.shape.components} shape components, written into the head "
      f"and into the character's {len(body.data.vertices)}-vertex body (shape key): {default_ms:.3f} ms per "
      f"slider change (one constraint; first change {default_first:.1f} ms); through the panel's slider "
      f"{ui_ms:.3f} ms")
mask = services.create_face_object(bpy.context, services.MASK_MODEL)
mask_ms, _ = time_slider(mask, "eyebrows-eyes distance", "masculine-feminine")
print(f"mask model: {mask_ms:.3f} ms per slider change (shape + colour, one constraint)")
services.remember_model("random-50k", random_model())
big = services.create_face_object(bpy.context, "random-50k")
big_ms, big_first = time_slider(big, "b", "a")
print(f"random model: 50000 vertices, 199 components: {big_ms:.3f} ms per slider change "
      f"(one constraint; first change {big_first:.1f} ms)")
print(f"RESULT attribute_monotonic_pct={pct:.1f} examples={len(model.example_names)}+{len(held)} "
      f"components={model.shape.components} components_95={model.info.get('components_95')} "
      f"slider_ms={default_ms:.3f} caricature_folds={folds} caricature_radius_ratio={worst:.3f} "
      f"slider_ms_mask={mask_ms:.3f} slider_ms_50k={big_ms:.3f}")
