# SPDX-License-Identifier: GPL-3.0-or-later
"""The default morphable model: learned from a synthetic population, because no openly licensed scanned
3DMM exists. It is NO substitute for scans: it knows only the variations written into
``presets/morph/population.json``, on the 468-vertex MediaPipe canonical face.

1. The MediaPipe canonical face is the population mean.
2. Each published craniofacial measurement (3D Facial Norms, Weinberg et al. 2016: means and SDs by sex at
   age 25; age drift; intercanthal width by population from a pooled meta-analysis) is realised as a
   landmark-driven deformation: the two landmarks of the measurement (and, with a smooth geodesic falloff,
   their neighbourhood) move so that their distance changes by the sampled amount. Further factors
   (eyebrow height, cheeks, chin, ...) have no published norm in our sources; their sizes are marked as
   assumptions in the preset.
3. A labelled population is sampled (seeded): sex, age, population, BMI, a shared size factor (facial
   dimensions correlate; the loading is an assumption), correlated lip thicknesses (r = 0.763, Lebanese
   adults, soft-tissue thickness), and per-vertex albedo (skin tone, freckles, beard shadow, lip and eyebrow
   colour). Every example is labelled with what is measured on its own mesh.
4. PCA and the Table 5.2 attributes are learned from it by :func:`.build.build_model`, the same code path a
   user's scan set takes ("Build Model from Meshes").
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.sparse.csgraph import dijkstra

from ..assets import canonical_face
from ..core.errors import UserError
from ..core.geometry import edge_length_graph, unique_edges, vertex_normals
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format
from .build import build_model
from .model import MorphableModel
from .segments import SegmentBlender, load_segment_preset, segment_masks

__all__ = ["POPULATION_FORMAT", "ATTRIBUTES_FORMAT", "default_model", "sample_population", "deformation_field"]

POPULATION_FORMAT = register_format(PresetFormat(
    "faces_hands.morph_population", 1,
    shape={"seed": NUMBER, "count": NUMBER, "populations": {str: NUMBER}, "factors": {str: {}}, "colour": {}},
    required=("seed", "count", "populations", "factors", "colour")))
ATTRIBUTES_FORMAT = register_format(PresetFormat(
    "faces_hands.morph_attributes", 1, shape={"categories": [str], "attributes": [{}]},
    required=("categories", "attributes")))
LIP_CORRELATION = 0.763
MM = 0.001


def _falloff(distance_mm: np.ndarray, radius: float) -> np.ndarray:
    x = np.clip(distance_mm / radius, 0.0, 1.0)
    return (1.0 - x * x) ** 2


def deformation_field(vertices: np.ndarray, triangles: np.ndarray, factor: dict, graph=None,
                      normals: np.ndarray | None = None) -> np.ndarray:
    """Displacement (n, 3) in metres per mm of the factor: each move ``[vertices, direction, weight]`` drags
    its vertices (weight 1 at them) and their surroundings (geodesic falloff within ``radius`` mm) along
    ``direction`` ("axis": along the measurement, away from its other end; "normal": outwards)."""
    graph = edge_length_graph(vertices, unique_edges(triangles)) if graph is None else graph
    normals = vertex_normals(vertices, triangles) if normals is None else normals
    field = np.zeros_like(vertices)
    radius = float(factor.get("radius", 10.0))
    measure = factor.get("measure")
    for ids, direction, weight in factor["moves"]:
        ids = [int(i) for i in ids]
        distance = dijkstra(graph, directed=False, indices=ids, min_only=True, limit=radius * MM) / MM
        falloff = _falloff(np.where(np.isfinite(distance), distance, radius), radius)
        if direction == "normal":
            vectors = normals
        elif direction == "axis":
            if not measure:
                raise UserError("a move along the 'axis' needs the factor's 'measure' landmarks")
            a, b = vertices[int(measure[0])], vertices[int(measure[1])]
            centre = vertices[ids].mean(axis=0)
            away = (b - a) if np.linalg.norm(centre - b) < np.linalg.norm(centre - a) else (a - b)
            vectors = np.broadcast_to(away / np.linalg.norm(away), vertices.shape)
        else:
            unit = np.asarray(direction, np.float64)
            vectors = np.broadcast_to(unit / np.linalg.norm(unit), vertices.shape)
        field += float(weight) * MM * falloff[:, None] * vectors
    return field


def _group_mean(factor: dict, sex: str) -> tuple[float, float]:
    male, female = factor.get("male", [0, 1]), factor.get("female", [0, 1])
    pooled = 0.5 * (male[0] + female[0])
    mean, sd = (male if sex == "male" else female)
    return mean - pooled, sd


def _measured(vertices: np.ndarray, pair) -> float:
    return float(np.linalg.norm(vertices[int(pair[0])] - vertices[int(pair[1])]) / MM)


def _luminance(colour: np.ndarray, mask: np.ndarray) -> float:
    return float((colour[mask] @ np.array([0.2126, 0.7152, 0.0722])).mean())


class _Sampler:
    """One synthetic example at a time (module docstring, step 3)."""

    def __init__(self, preset: dict, mesh, masks: dict[str, np.ndarray], blender: SegmentBlender):
        self.preset, self.mesh, self.masks, self.blender = preset, mesh, masks, blender
        graph = edge_length_graph(mesh.vertices, unique_edges(mesh.faces))
        normals = vertex_normals(mesh.vertices, mesh.faces)
        rounds = int(preset.get("field_smoothing", 0))     # neighbourhood averaging keeps thin parts unfolded
        self.fields = {name: blender.smooth(deformation_field(mesh.vertices, mesh.faces, f, graph, normals), rounds)
                       for name, f in preset["factors"].items()}
        self.rng = np.random.default_rng(int(preset["seed"]))
        colour = preset["colour"]
        pattern_rng = np.random.default_rng(int(colour["freckle_pattern_seed"]))
        region = masks["cheeks"] | masks["nose"] | masks["forehead"]
        self.freckles = region & (pattern_rng.random(len(mesh.vertices)) < float(colour["freckle_fraction"]))
        self.beard = blender.smooth((masks["chin"] | masks["peripheral oral region"]
                                     | (masks["cheeks"] & (mesh.vertices[:, 2] < -0.012))).astype(float), 1)
        self.lips = blender.smooth((masks["upper lip"] | masks["lower lip"]).astype(float), 1)
        self.brows = masks["eyebrows"].astype(float)
        self.brows_wide = blender.smooth(self.brows, 2)

    def _amplitude(self, name: str, factor: dict, person: dict, size: float, lips: float) -> float:
        offset, sd = _group_mean(factor, person["sex"])
        loading = float(self.preset.get("size_factor_loading", 0.5)) * float(factor.get("size", 0))
        if factor.get("lips"):
            z = math.sqrt(LIP_CORRELATION) * lips + math.sqrt(1 - LIP_CORRELATION) * self.rng.standard_normal()
        else:
            z = loading * size + math.sqrt(1 - loading ** 2) * self.rng.standard_normal()
        amount = offset + sd * z
        age, norm = person["age"], factor.get("male" if person["sex"] == "male" else "female", [0, 0])[0]
        if age < 25 and factor.get("measure") and norm > 0:
            amount -= (25 - age) / 7.0 * float(self.preset.get("growth_to_25_percent", 3.5)) / 100 * norm
        amount += float(factor.get("age_per_decade", 0.0)) * max(age - 30.0, 0.0) / 10.0
        amount += float(factor.get("bmi_per_unit", 0.0)) * (person["bmi"] - float(self.preset["bmi"]["mean"]))
        amount += float(factor.get("population", {}).get(person["population"], 0.0))
        return amount

    def person(self, index: int, populations: list[str], weights: np.ndarray) -> dict:
        low, high = self.preset.get("age_years", [18, 65])
        bmi = self.preset["bmi"]
        return {"sex": "male" if index % 2 == 0 else "female",
                "population": populations[int(self.rng.choice(len(populations), p=weights))],
                "age": float(self.rng.uniform(low, high)),
                "bmi": float(np.clip(self.rng.normal(bmi["mean"], bmi["sd"]), *bmi["range"]))}

    def example(self, person: dict) -> tuple[np.ndarray, np.ndarray, dict]:
        size, lips = self.rng.standard_normal(), self.rng.standard_normal()
        labels, shape = {}, self.mesh.vertices.copy()
        for name, factor in self.preset["factors"].items():
            amount = self._amplitude(name, factor, person, size, lips)
            shape += amount * self.fields[name]
            labels[name] = amount
        for name, factor in self.preset["factors"].items():
            if factor.get("measure"):
                labels[name] = _measured(shape, factor["measure"])
        colour, colour_labels = self.albedo(person)
        labels.update(colour_labels)
        return shape, colour, labels

    def albedo(self, person: dict) -> tuple[np.ndarray, dict]:
        """Per-vertex albedo: skin tone, freckles, beard shadow, lips, eyebrows (all assumed, see preset)."""
        c, rng, n = self.preset["colour"], self.rng, len(self.mesh.vertices)
        mean, sd = c["skin_lightness"][person["population"]]
        tone = float(np.clip(rng.normal(mean, sd), 0.02, 0.98))
        skin = np.asarray(c["skin_dark"]) + tone * (np.asarray(c["skin_light"]) - np.asarray(c["skin_dark"]))
        colour = np.tile(skin, (n, 1)) * (1.0 + 0.03 * rng.standard_normal((n, 1)))
        freckles = float(rng.uniform(0, 1) ** 2) if tone > 0.6 else 0.0
        colour[self.freckles] += 0.45 * freckles * (np.asarray(c["freckle_colour"]) - colour[self.freckles])
        beard = float(rng.uniform(0.1, 1.0)) if person["sex"] == "male" else 0.0
        colour += (c["beard_strength"] * beard * self.beard)[:, None] * (np.asarray(c["beard_colour"]) - colour)
        redness = float(np.clip(rng.normal(*c["lip_redness"]), 0.1, 1.0))
        lip = np.asarray(c["lip_colour"]) * (0.5 + 0.5 * tone)
        colour += (redness * self.lips)[:, None] * (lip - colour)
        hair = float(np.clip(rng.normal(0.2 + 0.45 * (tone - 0.5), 0.15), 0.0, 1.0))
        bushy = float(rng.uniform(0, 1))
        brow_colour = np.asarray(c["hair_dark"]) + hair * (np.asarray(c["hair_light"]) - np.asarray(c["hair_dark"]))
        brows = np.maximum(self.brows, bushy * self.brows_wide) * 0.85
        colour += brows[:, None] * (brow_colour - colour)
        colour = np.clip(colour, 0.0, 1.0)
        skin_region = self.masks["cheeks"] | self.masks["forehead"]
        labels = {"skin_lightness": _luminance(colour, skin_region), "freckles": freckles, "beard": beard,
                  "lip_lightness": _luminance(colour, self.masks["upper lip"] | self.masks["lower lip"]),
                  "brow_lightness": _luminance(colour, self.masks["eyebrows"]), "brow_bushiness": bushy}
        return colour, labels


def sample_population(preset: dict | None = None, count: int | None = None):
    """The synthetic examples: shapes (N, n, 3), colours (N, n, 3), rating columns and per-example labels."""
    if preset is None:
        preset, _ = read_preset("morph/population.json", POPULATION_FORMAT.name)
    mesh = canonical_face()
    segment_preset, segment_source = load_segment_preset()
    masks, parents = segment_masks(mesh.vertices, mesh.faces, segment_preset, segment_source)
    blender = SegmentBlender(mesh.vertices, mesh.faces, float(segment_preset.get("blend_width_m", 0.015)))
    sampler = _Sampler(preset, mesh, masks, blender)
    populations = list(preset["populations"])
    weights = np.array([float(preset["populations"][p]) for p in populations])
    count = int(count or preset["count"])
    if not 10 <= count <= 5000:
        raise UserError(f"population count {count} is out of range (10..5000)")
    shapes, colours, rows, people = [], [], [], []
    for index in range(count):
        person = sampler.person(index, populations, weights / weights.sum())
        shape, colour, labels = sampler.example(person)
        shapes.append(shape)
        colours.append(colour)
        rows.append(labels)
        people.append(person)
    columns = {key: np.array([row[key] for row in rows]) for key in rows[0]}
    columns["female"] = np.array([1.0 if p["sex"] == "female" else -1.0 for p in people])
    columns["age"] = np.array([p["age"] for p in people])
    columns["bmi"] = np.array([p["bmi"] for p in people])
    for population in populations:
        columns[population] = np.array([1.0 if p["population"] == population else 0.0 for p in people])
    columns["heart_shape"] = columns["frontal_width"] - columns["mandible_width"]
    columns["lip_fullness"] = columns["upper_vermilion"] + columns["lower_vermilion"]
    return mesh, np.array(shapes), np.array(colours), columns, people, (masks, parents, blender, segment_preset)


@lru_cache(maxsize=2)
def default_model(count: int | None = None) -> MorphableModel:
    """The default model (module docstring), built once per session (deterministic: same presets, same
    model)."""
    mesh, shapes, colours, columns, people, (masks, parents, blender, segment_preset) = sample_population(count=count)
    table, source = read_preset("morph/attributes.json", ATTRIBUTES_FORMAT.name)
    labels, categories = {}, {}
    for entry in table["attributes"]:
        if entry["label"] not in columns:
            raise UserError(f"{source}: attribute {entry['name']!r} names the unknown rating {entry['label']!r}")
        labels[entry["name"]] = float(entry.get("sign", 1)) * columns[entry["label"]]
        categories[entry["name"]] = entry["category"]
    example_labels = [{"sex": p["sex"], "age": round(p["age"], 1), "age group": _age_group(p["age"]),
                       "population": p["population"], "bmi": round(p["bmi"], 1)} for p in people]
    names = [f"{i + 1:03d} {p['sex']} {p['population']} {p['age']:.0f}" for i, p in enumerate(people)]
    first_detail = colours[0] - blender.smooth(colours[0], 2)
    model = build_model(
        "Faces & Hands default (synthetic)", shapes, mesh.faces, colours, uvs=mesh.uvs, labels=labels,
        example_names=names, example_labels=example_labels, categories=categories,
        landmarks=np.arange(len(mesh.vertices)), segments=masks, segment_parents=parents,
        details={"skin detail (example 001)": first_detail},
        info={"topology": "mediapipe_canonical_468", "blend_width_m": float(segment_preset.get("blend_width_m", 0.015)),
              "segment_colours": segment_preset.get("colours", {}), "synthetic": True,
              "about": "learned from a synthetic population sampled from published craniofacial norms "
                       "(presets/SOURCES.md); no substitute for scans",
              "omitted_attributes": table.get("omitted", {})})
    return model


def _age_group(age: float) -> str:
    return "18-29" if age < 30 else ("30-44" if age < 45 else "45+")
