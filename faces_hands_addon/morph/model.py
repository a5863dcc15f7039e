# SPDX-License-Identifier: GPL-3.0-or-later
"""The morphable model (thesis 3.2.1): a mean shape and an orthonormal shape basis with standard deviations,
optionally the same for per-vertex colour (albedo), plus the mesh (triangles, UVs), landmark indices, segment
masks (Table 5.1), named attribute vectors (Eq. 3.4) and the example database the model was learned from.

Vectors follow the thesis' layout: a shape is ``s = (x1, y1, z1, ..., xn, yn, zn)`` (metres, Z up, the face
looks along -Y), a colour ``t = (r1, g1, b1, ...)`` (linear albedo in 0..1). A face is ``s = s_mean + U alpha``
(the principal components ``U`` are columns, 3.2.1); ``alpha`` is in metres, ``alpha_i / sigma_i`` in standard
deviations.

The Mahalanobis scalar product (3.2.2) is always computed through the low-dimensional factors (Eq. 3.7):
``<a, b>_M = <W^-1 U^T a, W^-1 U^T b>`` with ``W = diag(sigma)``, i.e. ``sum_i alpha_i beta_i / sigma_i^2``.
This equals ``a^T C^-1 b`` for the covariance ``C = U diag(sigma^2) U^T`` of Eq. 3.1/3.2 (on the span of the
model; outside it ``C`` has no inverse and the component is ignored, as with a pseudo-inverse). The thesis
writes ``W = sqrt(N) diag(sigma)`` in Eq. 3.3; with that scaling Eq. 3.7 would be ``C^-1 / N``, and the
identity "adding ``N / ||w||^2 * ds_A`` raises ``f`` by exactly 1" (3.2.2) holds for ``C^-1`` itself, which is
what we use.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..core.rig import read_rig_archive, write_rig_archive

__all__ = ["PcaPart", "Attribute", "MorphableModel", "MODEL_FORMAT", "save_model", "load_native", "matching_examples"]

MODEL_FORMAT = "faces_hands.morph_model/1"
PARTS = ("shape", "colour")


@dataclass
class PcaPart:
    """One PCA model (Eqs. 3.1-3.3): ``mean`` (3n,), orthonormal ``basis`` U (3n, k), ``sd`` sigma (k,)."""
    mean: np.ndarray
    basis: np.ndarray
    sd: np.ndarray

    @property
    def components(self) -> int:
        return int(self.sd.shape[0])

    def coefficients(self, vector: np.ndarray) -> np.ndarray:
        """``alpha = U^T (v - mean)``: a vector (3n,) or vertices (n, 3) in the model's coordinates."""
        return self.basis.T @ (np.asarray(vector, np.float64).ravel() - self.mean)

    def project(self, offset: np.ndarray) -> np.ndarray:
        """``U^T d`` of an offset from the mean (3n,) or (n, 3)."""
        return self.basis.T @ np.asarray(offset, np.float64).ravel()

    def vector(self, alpha: np.ndarray) -> np.ndarray:
        """``s = mean + U alpha`` (3n,) (3.2.1)."""
        return self.mean + self.basis @ np.asarray(alpha, np.float64)

    def offset(self, alpha: np.ndarray) -> np.ndarray:
        """``U alpha`` (3n,): the vertex-space vector of coefficients ``alpha``."""
        return self.basis @ np.asarray(alpha, np.float64)

    def mahalanobis(self, alpha: np.ndarray, beta: np.ndarray) -> np.ndarray | float:
        """``<a, b>_M`` of two vectors given by their coefficients (Eq. 3.7): ``sum alpha beta / sigma^2``.
        ``alpha`` may be (k,) or (m, k) (one product per row)."""
        return np.asarray(alpha, np.float64) @ (np.asarray(beta, np.float64) / self.sd ** 2)


@dataclass
class Attribute:
    """A facial attribute (3.2.2, Table 5.2): its vector ``ds_A`` in PC coefficients for shape and colour
    (Eq. 3.4 projected onto the basis), its Table 5.2 category, and what it was learned from."""
    name: str
    category: str
    shape: np.ndarray | None
    colour: np.ndarray | None
    label: str = ""
    description: str = ""

    def vector(self, part: str) -> np.ndarray | None:
        return self.shape if part == "shape" else self.colour


@dataclass
class MorphableModel:
    """A morphable model of faces (module docstring). ``segments`` maps a segment name to a boolean vertex
    mask; ``segment_parents`` gives the Table 5.1 hierarchy (child -> parent, the root ``face`` has none).
    ``examples`` are the example faces' coefficients (N, k) per part with ``example_labels`` (one dict per
    example: sex, age, population, ... as the database browser filters them, 5.1.1)."""
    name: str
    shape: PcaPart
    triangles: np.ndarray
    colour: PcaPart | None = None
    uvs: np.ndarray | None = None
    landmarks: np.ndarray | None = None
    segments: dict[str, np.ndarray] = field(default_factory=dict)
    segment_parents: dict[str, str] = field(default_factory=dict)
    attributes: dict[str, Attribute] = field(default_factory=dict)
    examples: dict[str, np.ndarray] = field(default_factory=dict)
    example_names: list[str] = field(default_factory=list)
    example_labels: list[dict] = field(default_factory=list)
    details: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def vertex_count(self) -> int:
        return self.shape.mean.shape[0] // 3

    def part(self, part: str) -> PcaPart | None:
        if part not in PARTS:
            raise UserError(f"unknown model part {part!r}; use shape or colour")
        return self.shape if part == "shape" else self.colour

    def attribute(self, name: str) -> Attribute:
        try:
            return self.attributes[name]
        except KeyError:
            close = [a for a in self.attributes if name.lower() in a.lower()]
            hint = f"; did you mean {', '.join(close[:4])}?" if close else f"; known: {', '.join(list(self.attributes)[:12])}"
            raise UserError(f"model {self.name!r} has no attribute {name!r}{hint}") from None

    def mean_vertices(self) -> np.ndarray:
        return self.shape.mean.reshape(-1, 3)

    def example_coefficients(self, index: int, part: str) -> np.ndarray | None:
        if not 0 <= index < len(self.example_names):
            raise UserError(f"example {index} does not exist (the database has {len(self.example_names)} faces)")
        table = self.examples.get(part)
        return None if table is None else table[index]

    def validate(self, source: str = "the model") -> "MorphableModel":
        """Refuse a model the editor cannot use (wrong shapes, NaN, a basis that is not orthonormal, ...)."""
        check_part(self.shape, source, "shape")
        n = self.vertex_count
        if self.colour is not None:
            check_part(self.colour, source, "colour")
            if self.colour.mean.shape[0] != 3 * n:
                raise UserError(f"{source}: the colour model has {self.colour.mean.shape[0] // 3} vertices, "
                                f"the shape model {n}")
        tri = np.asarray(self.triangles)
        if tri.ndim != 2 or tri.shape[1] != 3 or tri.size == 0 or tri.dtype.kind not in "iu":
            raise UserError(f"{source}: triangles must be an (M, 3) integer array")
        if tri.min() < 0 or tri.max() >= n:
            raise UserError(f"{source}: triangles index vertices outside 0..{n - 1}")
        if self.uvs is not None and np.shape(self.uvs) != (n, 2):
            raise UserError(f"{source}: UVs must be one (u, v) per vertex")
        for name, mask in self.segments.items():
            if np.shape(mask) != (n,):
                raise UserError(f"{source}: segment {name!r} has {np.size(mask)} entries for {n} vertices")
        for attribute in self.attributes.values():
            for part in PARTS:
                vector, model_part = attribute.vector(part), self.part(part)
                if vector is not None and (model_part is None or vector.shape != (model_part.components,)
                                           or not np.isfinite(vector).all()):
                    raise UserError(f"{source}: attribute {attribute.name!r} does not fit the {part} model")
        return self


def check_part(part: PcaPart, source: str, what: str) -> None:
    """Shapes, finiteness, positive deviations and an orthonormal basis (checked on a sample of columns)."""
    mean, basis, sd = (np.asarray(a) for a in (part.mean, part.basis, part.sd))
    if mean.ndim != 1 or mean.shape[0] % 3 or mean.shape[0] == 0:
        raise UserError(f"{source}: the {what} mean must hold x, y, z (or r, g, b) per vertex")
    if basis.ndim != 2 or basis.shape[0] != mean.shape[0] or sd.shape != (basis.shape[1],) or basis.shape[1] == 0:
        raise UserError(f"{source}: the {what} basis is {basis.shape} for a mean of {mean.shape[0]} values and "
                        f"{sd.shape} deviations")
    for name, array in (("mean", mean), ("basis", basis), ("deviations", sd)):
        if not np.isfinite(array).all():
            raise UserError(f"{source}: the {what} {name} holds NaN or infinite values; the file is damaged")
    if (sd <= 0).any():
        raise UserError(f"{source}: the {what} standard deviations must be positive")
    columns = np.linspace(0, basis.shape[1] - 1, min(basis.shape[1], 24)).astype(int)
    gram = basis[:, columns].T @ basis[:, columns]
    if np.abs(gram - np.eye(len(columns))).max() > 1e-4:
        raise UserError(f"{source}: the {what} basis is not orthonormal (U^T U differs from I by "
                        f"{np.abs(gram - np.eye(len(columns))).max():.2g})")


# ------------------------------------------------------------------------------------------ native .npz
def save_model(model: MorphableModel, path: str | Path) -> None:
    """Write the documented native format (``.npz`` without pickles, deterministic bytes): see
    ``load_native`` for the entries."""
    arrays: dict[str, np.ndarray] = {"triangles": np.asarray(model.triangles, np.int64)}
    for part_name in PARTS:
        part = model.part(part_name)
        if part is not None:
            arrays[f"{part_name}_mean"] = part.mean.reshape(-1, 3)
            arrays[f"{part_name}_basis"] = part.basis
            arrays[f"{part_name}_sd"] = part.sd
            if part_name in model.examples:
                arrays[f"examples_{part_name}"] = model.examples[part_name]
    if model.uvs is not None:
        arrays["uvs"] = np.asarray(model.uvs, np.float64)
    if model.landmarks is not None:
        arrays["landmarks"] = np.asarray(model.landmarks, np.int64)
    segment_names = list(model.segments)
    for index, name in enumerate(segment_names):
        arrays[f"segment_{index:03d}"] = np.asarray(model.segments[name], bool)
    attributes = []
    for index, attribute in enumerate(model.attributes.values()):
        for part_name in PARTS:
            vector = attribute.vector(part_name)
            if vector is not None:
                arrays[f"attribute_{part_name}_{index:03d}"] = vector
        attributes.append({"name": attribute.name, "category": attribute.category, "label": attribute.label,
                           "description": attribute.description})
    detail_names = list(model.details)
    for index, name in enumerate(detail_names):
        arrays[f"detail_{index:03d}"] = model.details[name]
    meta = {"format": MODEL_FORMAT, "name": model.name, "info": model.info, "segments": segment_names,
            "segment_parents": model.segment_parents, "attributes": attributes, "details": detail_names,
            "example_names": model.example_names, "example_labels": model.example_labels}
    write_rig_archive(path, meta, arrays)


def _optional_part(arrays: dict, part: str) -> PcaPart | None:
    if f"{part}_mean" not in arrays:
        return None
    return PcaPart(np.asarray(arrays[f"{part}_mean"], np.float64).ravel(),
                   np.asarray(arrays[f"{part}_basis"], np.float64), np.asarray(arrays[f"{part}_sd"], np.float64))


def load_native(path: str | Path) -> MorphableModel:
    """Read a native model. Entries: ``meta_json`` (format ``faces_hands.morph_model/1``, name, info, segment
    names and parents, attribute names/categories/labels, example names and labels, detail names);
    ``shape_mean`` (n, 3), ``shape_basis`` (3n, k) orthonormal, ``shape_sd`` (k,); optionally ``colour_mean``
    / ``colour_basis`` / ``colour_sd``; ``triangles`` (M, 3); ``uvs`` (n, 2); ``landmarks`` (L,);
    ``segment_NNN`` (n,) bool; ``attribute_shape_NNN`` / ``attribute_colour_NNN`` (k,); ``examples_shape`` /
    ``examples_colour`` (N, k); ``detail_NNN`` (n, 3) colour detail."""
    path = Path(path)
    names = ("triangles", "shape_mean", "shape_basis", "shape_sd")
    meta, arrays = read_rig_archive(path, MODEL_FORMAT, "morphable model", names,
                                    prefixes=("colour_", "uvs", "landmarks", "segment_", "attribute_",
                                              "examples_", "detail_"))
    try:
        shape = _optional_part(arrays, "shape")
        segments = {name: arrays[f"segment_{i:03d}"].astype(bool) for i, name in enumerate(meta["segments"])}
        attributes = {}
        for i, entry in enumerate(meta["attributes"]):
            attributes[entry["name"]] = Attribute(
                entry["name"], entry.get("category", "other"), arrays.get(f"attribute_shape_{i:03d}"),
                arrays.get(f"attribute_colour_{i:03d}"), entry.get("label", ""), entry.get("description", ""))
        model = MorphableModel(
            name=str(meta.get("name", path.stem)), shape=shape, triangles=arrays["triangles"],
            colour=_optional_part(arrays, "colour"), uvs=arrays.get("uvs"), landmarks=arrays.get("landmarks"),
            segments=segments, segment_parents=dict(meta.get("segment_parents", {})), attributes=attributes,
            examples={p: arrays[f"examples_{p}"] for p in PARTS if f"examples_{p}" in arrays},
            example_names=list(meta.get("example_names", [])), example_labels=list(meta.get("example_labels", [])),
            details={name: arrays[f"detail_{i:03d}"] for i, name in enumerate(meta.get("details", []))},
            info=dict(meta.get("info", {})))
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise UserError(f"{path}: the morphable model is incomplete ({error})") from None
    return model.validate(str(path))


def info_json(model: MorphableModel) -> str:
    """A short JSON summary (vertices, components, attributes) for reports."""
    return json.dumps({"name": model.name, "vertices": model.vertex_count,
                       "shape_components": model.shape.components,
                       "colour_components": model.colour.components if model.colour else 0,
                       "attributes": len(model.attributes), "examples": len(model.example_names)})


def matching_examples(examples: list, sex: str = "any", age_group: str = "any", population: str = "") -> list[tuple[int, str]]:
    """(index, name) of the database examples ``[[index, name, labels], ...]`` that pass the general settings
    of 5.1.1 (sex, age group, population; ``any`` / empty: no restriction)."""
    population = population.strip().lower()
    return [(int(index), str(name)) for index, name, labels in examples
            if sex in ("any", labels.get("sex")) and age_group in ("any", labels.get("age group"))
            and (not population or population == str(labels.get("population", "")).lower())]
