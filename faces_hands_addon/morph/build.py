# SPDX-License-Identifier: GPL-3.0-or-later
"""Learning a morphable model from example faces in correspondence (3.2.1) and its attributes from ratings
(3.2.2, 5.1.10): the one code path for a user's scan set ("Build Model from Meshes") and for the default
model's synthetic population.

* :func:`pca` - Eqs. 3.1-3.3: centre the examples, SVD of the data matrix ``dS = U W V^T``; the columns of
  ``U`` are the principal components, ``sigma_i = W_ii / sqrt(N)`` their standard deviations.
* :func:`attribute_vector` - Eq. 3.4: ``ds_A = 1/N sum_k w_k ds_k`` for per-example weights ``w``
  (centred, so that their mean is zero as 3.2.2 assumes, and scaled to unit standard deviation, so one unit
  of an attribute is one standard deviation of the rating). It is computed in coefficients:
  ``U^T ds_A = 1/N W V^T w``.
* :func:`read_labels_csv` - the per-example ratings, one row per example (5.1.10: "rate every example").
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from .model import Attribute, MorphableModel, PcaPart

__all__ = ["pca", "attribute_vector", "attributes_from_labels", "build_model", "read_labels_csv",
           "check_examples", "MIN_EXAMPLES"]

MIN_EXAMPLES = 3


def check_examples(examples, what: str = "example meshes") -> np.ndarray:
    """(N, n, 3) float64 examples of one topology, finite, at least :data:`MIN_EXAMPLES`."""
    try:
        data = np.asarray(examples, np.float64)
    except (TypeError, ValueError):
        raise UserError(f"the {what} do not all have the same number of vertices; a morphable model needs "
                        "meshes in full correspondence (same topology, same vertex order)") from None
    if data.ndim != 3 or data.shape[2] != 3:
        raise UserError(f"the {what} must be (count, vertices, 3) coordinates, not {data.shape}")
    if data.shape[0] < MIN_EXAMPLES:
        raise UserError(f"a morphable model needs at least {MIN_EXAMPLES} {what} (got {data.shape[0]})")
    if not np.isfinite(data).all():
        bad = int(np.flatnonzero(~np.isfinite(data).all(axis=(1, 2)))[0])
        raise UserError(f"{what} {bad} has NaN or infinite coordinates")
    return data


def pca(vectors: np.ndarray, max_components: int | None = None, tolerance: float = 1e-9) -> tuple[PcaPart, np.ndarray]:
    """PCA of N example vectors (N, D) (Eqs. 3.1-3.3). Returns the model part and the examples' coefficients
    (N, k) ``= (W V^T)^T``. Components whose deviation is below ``tolerance`` times the largest (the N-th,
    which centring removes, and exact duplicates) are dropped; ``max_components`` truncates (149 suffice
    for scans, [BSVS04] as quoted in 3.2.1)."""
    vectors = np.asarray(vectors, np.float64)
    count = vectors.shape[0]
    mean = vectors.mean(axis=0)
    centred = vectors - mean                                    # dS^T, one example per row
    _, singular, vt = np.linalg.svd(centred, full_matrices=False)   # dS = U W V^T  <=>  dS^T = V W U^T
    keep = singular > tolerance * max(float(singular[0]) if len(singular) else 0.0, 1e-300)
    if max_components is not None:
        keep &= np.arange(len(singular)) < max_components
    if not keep.any():
        raise UserError("the examples are all the same face; a morphable model needs variation")
    basis = vt[keep].T                                          # U: (D, k)
    basis *= np.where(basis[np.abs(basis).argmax(axis=0), np.arange(basis.shape[1])] < 0, -1.0, 1.0)
    sd = singular[keep] / math.sqrt(count)                      # W = sqrt(N) diag(sigma)
    coefficients = centred @ basis
    return PcaPart(mean, basis, sd), coefficients


def attribute_vector(coefficients: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Eq. 3.4 in PC coefficients: ``U^T ds_A = 1/N sum_k w_k alpha_k`` with the weights centred and scaled to
    unit deviation (examples whose weight is NaN are left out, i.e. given the mean weight)."""
    weights = np.asarray(weights, np.float64)
    known = np.isfinite(weights)
    if known.sum() < 2:
        raise UserError("an attribute needs ratings for at least two examples")
    centred = np.where(known, weights - weights[known].mean(), 0.0)
    spread = float(np.sqrt((centred[known] ** 2).mean()))
    if spread <= 0:
        raise UserError("every example has the same rating; the attribute cannot be learned")
    return (centred / spread) @ np.asarray(coefficients, np.float64) / len(weights)


def attributes_from_labels(labels: dict[str, np.ndarray], shape_coefficients: np.ndarray,
                           colour_coefficients: np.ndarray | None, categories: dict[str, str] | None = None,
                           descriptions: dict[str, str] | None = None,
                           parts: dict[str, tuple[str, ...]] | None = None) -> dict[str, Attribute]:
    """One attribute per rating column (Eq. 3.4 for shape and colour separately, 3.2.2). ``parts`` may
    restrict an attribute to ``("shape",)`` or ``("colour",)``."""
    out = {}
    for name, weights in labels.items():
        wanted = (parts or {}).get(name, ("shape", "colour"))
        shape = attribute_vector(shape_coefficients, weights) if "shape" in wanted else None
        colour = (attribute_vector(colour_coefficients, weights)
                  if colour_coefficients is not None and "colour" in wanted else None)
        out[name] = Attribute(name, (categories or {}).get(name, "other"), shape, colour, label=name,
                              description=(descriptions or {}).get(name, ""))
    return out


def build_model(name: str, shapes, triangles, colours=None, uvs=None, labels: dict | None = None,
                example_names: list[str] | None = None, example_labels: list[dict] | None = None,
                max_components: int | None = None, **extra) -> MorphableModel:
    """A morphable model from same-topology examples (N, n, 3) and optional colours (N, n, 3), with one
    attribute per numeric rating column in ``labels`` (name -> (N,) weights). ``extra`` passes
    segments, categories, landmarks, details and info through."""
    shapes = check_examples(shapes)
    count, n = shapes.shape[:2]
    shape_part, shape_coefficients = pca(shapes.reshape(count, -1), max_components)
    colour_part = colour_coefficients = None
    if colours is not None:
        colours = check_examples(colours, "example colours")
        if colours.shape != shapes.shape:
            raise UserError(f"colours are given for {colours.shape[0]} x {colours.shape[1]} vertices, the shapes "
                            f"have {count} x {n}")
        colour_part, colour_coefficients = pca(colours.reshape(count, -1), max_components)
    attributes = attributes_from_labels(
        {k: np.asarray(v, np.float64) for k, v in (labels or {}).items()}, shape_coefficients,
        colour_coefficients, extra.pop("categories", None), extra.pop("descriptions", None), extra.pop("parts", None))
    examples = {"shape": shape_coefficients}
    if colour_coefficients is not None:
        examples["colour"] = colour_coefficients
    model = MorphableModel(
        name=name, shape=shape_part, triangles=np.asarray(triangles, np.int64), colour=colour_part, uvs=uvs,
        attributes=attributes, examples=examples,
        example_names=list(example_names or [f"example {i + 1}" for i in range(count)]),
        example_labels=list(example_labels or [{} for _ in range(count)]), **extra)
    return model.validate(f"model {name!r}")


# ------------------------------------------------------------------------------------------ ratings
def read_labels_csv(source: str | Path, example_names: list[str]) -> tuple[dict[str, np.ndarray], list[dict]]:
    """Per-example ratings from a CSV file (or its text): a column ``name`` naming each example (a mesh's
    object or file name) and one column per attribute. Numeric columns become attributes as they are;
    a column with two words (``male``/``female``) becomes one attribute ``<first>-<second>`` (-1 / +1, sorted);
    a column with more words one attribute per word (1 for that word, 0 otherwise). Every example needs a
    row; a missing row, an unknown name, a duplicate or an empty cell is an error naming it."""
    text = Path(source).read_text(encoding="utf-8-sig") if isinstance(source, Path) else str(source)
    where = str(source) if isinstance(source, Path) else "the labels CSV"
    rows = list(csv.DictReader(io.StringIO(text)))
    if not rows or "name" not in (rows[0].keys() if rows else ()):
        raise UserError(f"{where}: needs a header row with a 'name' column and one column per attribute")
    by_name: dict[str, dict] = {}
    for number, row in enumerate(rows, 2):
        key = (row.get("name") or "").strip()
        if key in by_name:
            raise UserError(f"{where}: line {number}: {key!r} appears twice")
        by_name[key] = row
    missing = [name for name in example_names if name not in by_name]
    if missing:
        raise UserError(f"{where}: no row for {len(missing)} example(s): {', '.join(missing[:6])}"
                        f"{' ...' if len(missing) > 6 else ''}; every example needs a row")
    unknown = sorted(set(by_name) - set(example_names))
    if unknown:
        raise UserError(f"{where}: rows for examples that are not part of the model: {', '.join(unknown[:6])}")
    columns = [c for c in rows[0].keys() if c and c != "name"]
    if not columns:
        raise UserError(f"{where}: no attribute columns besides 'name'")
    labels: dict[str, np.ndarray] = {}
    for column in columns:
        cells = [(by_name[name].get(column) or "").strip() for name in example_names]
        empty = [name for name, cell in zip(example_names, cells) if not cell]
        if empty:
            raise UserError(f"{where}: column {column!r} is empty for {', '.join(empty[:6])}")
        labels.update(_column_attributes(where, column, cells))
    per_example = [{c: by_name[name][c].strip() for c in columns} for name in example_names]
    return labels, per_example


def _column_attributes(where: str, column: str, cells: list[str]) -> dict[str, np.ndarray]:
    try:
        values = np.array([float(cell) for cell in cells])
    except ValueError:
        values = None
    if values is not None:
        if not np.isfinite(values).all():
            raise UserError(f"{where}: column {column!r} holds NaN or infinite ratings")
        return {column: values}
    words = sorted(set(cells))
    if len(words) == 1:
        raise UserError(f"{where}: column {column!r} has the same value {words[0]!r} for every example")
    if len(words) == 2:
        return {f"{words[0]}-{words[1]}": np.array([1.0 if c == words[1] else -1.0 for c in cells])}
    return {word: np.array([1.0 if c == word else 0.0 for c in cells]) for word in words}
