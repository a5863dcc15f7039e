# SPDX-License-Identifier: GPL-3.0-or-later
"""The edit face of mind2model (5.1): a face of a morphable model changed by operations, with attribute
constraints re-established after every operation (3.2.3).

The face is kept twice, in sync: as vertices / colours (what Blender shows) and as PC coefficients ``alpha``,
``beta`` (what the Mahalanobis products of Eq. 3.7 need). Every operation adds a displacement whose
coefficients are known, so a slider change costs a few vector additions, not a product with the basis:

* attributes (3.2.2, 5.1.4): ``s -> s + t u_A`` with ``u_A = ds_A / <ds_A, ds_A>_M``, so ``f_A`` rises by ``t``
  exactly (for an unrestricted model ``u_A = N / ||w||^2 ds_A``, the thesis' identity); shape and colour
  values are separate; restricted to segments by :class:`.segments.SegmentBlender`;
* caricature (3.2.2): the distance from the average scaled by the level, in PC representation;
* feature import (5.1.5): the selected segments replaced by those of an example (blended at the borders);
* affine transforms of the face or a segment (5.1.3); a high-frequency detail vector at a factor (5.1.9);
* constraints (3.2.3): the values ``c_A = <ds, ds_A>_M`` (Eq. 3.5) are stored; after each operation
  ``ds + sum_j mu_j ds_Aj`` (Eq. 3.6) with ``mu`` from the small system ``sum_j mu_j <ds_Aj, ds_Ai>_M =
  c_Ai - <ds, ds_Ai>_M``, for shape (``mu``) and colour (``nu``) separately. A constraint may be restricted
  to segments (its correction is blended into them) and applied to the whole database (5.1.7, Fig. 5.8).

The state is the list of operations (the edit history): :meth:`EditFace.state` / :func:`face_from_state`
save and replay it, deterministically.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from .model import MorphableModel
from .segments import SegmentBlender, selection_mask

__all__ = ["Constraint", "EditFace", "face_from_state", "model_fingerprint", "FACE_FORMAT", "MAX_VALUE"]

FACE_FORMAT = "faces_hands.morph_face"
MAX_VALUE = 10.0          # attribute values (in standard deviations of the rating) beyond this are refused
MAX_CARICATURE = 5.0


def model_fingerprint(model: MorphableModel) -> str:
    """A short name of the model's numbers (a saved face only replays on the model it was made with)."""
    cached = model.info.get("fingerprint")
    if cached:
        return cached
    digest = hashlib.sha256()
    for array in (model.shape.mean, model.shape.sd, np.asarray(model.triangles)):
        digest.update(np.ascontiguousarray(array).tobytes())
    digest.update(json.dumps(sorted(model.attributes)).encode())
    model.info["fingerprint"] = digest.hexdigest()[:16]
    return model.info["fingerprint"]


@dataclass
class Constraint:
    """A stored attribute value (Eq. 3.5) for shape and/or colour, optionally restricted to segments."""
    attribute: str
    shape: float | None
    colour: float | None
    segments: tuple[str, ...] = ()

    def value(self, part: str) -> float | None:
        return self.shape if part == "shape" else self.colour

    def to_json(self) -> dict:
        return {"attribute": self.attribute, "shape": self.shape, "colour": self.colour,
                "segments": list(self.segments)}


def _finite(value, what: str, limit: float = MAX_VALUE) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise UserError(f"{what} must be a number, not {value!r}") from None
    if not np.isfinite(value) or abs(value) > limit:
        raise UserError(f"{what} = {value} is out of range (-{limit:g}..{limit:g})")
    return value


def folded_against(vertices: np.ndarray, reference: np.ndarray, triangles) -> int:
    """Triangles whose normal turned more than 90 degrees from the reference mesh's (folded over)."""
    tri = np.asarray(triangles, np.int64)

    def normals(points):
        p = np.asarray(points, np.float64).reshape(-1, 3)
        return np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    return int(np.sum(np.einsum("ij,ij->i", normals(vertices), normals(reference)) < 0))


def _segment_key(segments) -> tuple[str, ...]:
    return tuple(sorted({s for s in (segments or ()) if s and s != "face"}))


class EditFace:
    """A face being edited (module docstring). ``shape`` (n, 3) and ``colour`` (n, 3) or None."""

    def __init__(self, model: MorphableModel, blender: SegmentBlender | None = None):
        self.model = model
        self.blender = blender or SegmentBlender(model.mean_vertices(), model.triangles,
                                                 float(model.info.get("blend_width_m", 0.02)))
        self.constraints: list[Constraint] = []
        self.history: list[dict] = []
        self.applied: dict[str, float] = {}
        self.database = {part: table.copy() for part, table in model.examples.items()}
        self._directions: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self._reset(np.zeros(model.shape.components),
                    None if model.colour is None else np.zeros(model.colour.components))

    # ------------------------------------------------------------------ state
    def _reset(self, alpha: np.ndarray, beta: np.ndarray | None) -> None:
        self.alpha = np.asarray(alpha, np.float64).copy()
        self.shape = self.model.shape.vector(self.alpha).reshape(-1, 3)
        self.beta = None if beta is None else np.asarray(beta, np.float64).copy()
        self.colour = None if beta is None else self.model.colour.vector(self.beta).reshape(-1, 3)
        self.applied = {}

    def coefficients(self, part: str) -> np.ndarray | None:
        return self.alpha if part == "shape" else self.beta

    def parts(self, part: str) -> tuple[str, ...]:
        wanted = ("shape", "colour") if part == "both" else (part,)
        for name in wanted:
            if name not in ("shape", "colour"):
                raise UserError(f"unknown part {part!r}; use shape, colour or both")
        return tuple(p for p in wanted if self.model.part(p) is not None)

    def value(self, attribute: str, part: str = "shape") -> float:
        """``f_A`` of the face (3.2.2, Eq. 3.5): ``<ds, ds_A>_M`` through the factors (Eq. 3.7)."""
        vector = self.model.attribute(attribute).vector(part)
        if vector is None or self.model.part(part) is None:
            raise UserError(f"attribute {attribute!r} has no {part} vector in this model")
        return float(self.model.part(part).mahalanobis(self.coefficients(part), vector))

    def slider(self, attribute: str, part: str = "shape", segments=()) -> float:
        return self.applied.get(self._key("attribute", attribute, part, segments), 0.0)

    def caricature_level(self, part: str = "shape", segments=()) -> float:
        return self.applied.get(self._key("caricature", part, segments), 1.0)

    @staticmethod
    def _key(*parts) -> str:
        *head, segments = parts
        return json.dumps([*head, list(_segment_key(segments))])

    # ------------------------------------------------------------------ directions
    def unit_direction(self, attribute: str, part: str) -> np.ndarray:
        """``u_A = ds_A / <ds_A, ds_A>_M`` (coefficients): adding ``t u_A`` raises ``f_A`` by ``t``."""
        vector = self.model.attribute(attribute).vector(part)
        if vector is None:
            raise UserError(f"attribute {attribute!r} has no {part} vector in this model")
        norm = float(self.model.part(part).mahalanobis(vector, vector))
        if norm <= 0:
            raise UserError(f"attribute {attribute!r} has a zero {part} vector")
        return vector / norm

    def _restricted(self, key: tuple, coefficients: np.ndarray, part: str, segments) -> tuple[np.ndarray, np.ndarray]:
        """(vertex displacement (n, 3), its coefficients) of ``coefficients``, restricted to ``segments``."""
        cached = self._directions.get(key)
        if cached is None:
            model_part = self.model.part(part)
            offset = model_part.offset(coefficients).reshape(-1, 3)
            mask = selection_mask(self.model.segments, segments, self.model.vertex_count)
            if mask is not None:
                offset = self.blender.blend(offset, mask)
                coefficients = model_part.project(offset)
            cached = (offset, np.asarray(coefficients, np.float64))
            self._directions[key] = cached
        return cached

    def direction(self, attribute: str, part: str, segments=()) -> tuple[np.ndarray, np.ndarray]:
        """(vertex displacement, coefficients) of one unit of ``attribute``, restricted to ``segments`` or,
        when none are given, to the attribute's own segments if the model names them
        (``info["attribute_segments"]``: a feature's attribute moves that feature, Table 5.1, 5.1.4)."""
        if not _segment_key(segments):
            segments = tuple(self.model.info.get("attribute_segments", {}).get(attribute, ()))
        key = (attribute, part, _segment_key(segments))
        return self._restricted(key, self.unit_direction(attribute, part), part, segments)

    def _add(self, part: str, offset: np.ndarray, coefficients: np.ndarray, amount: float = 1.0) -> None:
        if part == "shape":
            self.shape += amount * offset
            self.alpha += amount * coefficients
        else:
            self.colour += amount * offset
            self.beta += amount * coefficients

    def _add_displacement(self, part: str, displacement: np.ndarray, segments) -> None:
        """Add a vertex-space displacement (restricted to ``segments``), projecting it for the coefficients."""
        mask = selection_mask(self.model.segments, segments, self.model.vertex_count)
        if mask is not None:
            displacement = self.blender.blend(displacement, mask)
        self._add(part, displacement, self.model.part(part).project(displacement))

    # ------------------------------------------------------------------ operations
    def run(self, op: dict, record: bool = True) -> None:
        """Apply one operation (a dict as in :attr:`history`), then re-establish the constraints."""
        kind = op.get("op")
        handler = getattr(self, f"_op_{kind}", None) if isinstance(kind, str) else None
        if handler is None:
            raise UserError(f"unknown edit operation {kind!r}")
        handler(op)
        if kind not in ("constrain", "unconstrain", "constrain_database"):
            self.enforce_constraints()
        if record:
            last = self.history[-1] if self.history else None
            if (last is not None and kind == "attribute" and last.get("op") == "attribute"
                    and [last[k] for k in ("name", "part", "segments")] == [op[k] for k in ("name", "part", "segments")]):
                self.history[-1] = op           # a slider drag is one edit (exact: see enforce_constraints)
            else:
                self.history.append(op)

    def create(self, kind: str = "average", seed: int = 0, index: int = 0, scale: float = 1.0) -> None:
        """Start over (5.1.10): the average face, a random face (``seed``), or example ``index``."""
        self.constraints.clear()
        self.history.clear()
        self.database = {part: table.copy() for part, table in self.model.examples.items()}
        self.run({"op": "create", "kind": kind, "seed": int(seed), "index": int(index), "scale": float(scale)})

    def _op_create(self, op: dict) -> None:
        kind, model = op["kind"], self.model
        beta0 = None if model.colour is None else np.zeros(model.colour.components)
        if kind == "average":
            self._reset(np.zeros(model.shape.components), beta0)
        elif kind == "random":
            rng = np.random.default_rng(int(op["seed"]))
            scale = _finite(op.get("scale", 1.0), "random face scale", 3.0)
            alpha = scale * model.shape.sd * rng.standard_normal(model.shape.components)
            beta = None if beta0 is None else scale * model.colour.sd * rng.standard_normal(model.colour.components)
            self._reset(alpha, beta)
        elif kind == "coefficients":                # a face fitted elsewhere (a photograph, 3.2.4)
            alpha = np.asarray(op["shape"], np.float64)
            if alpha.shape != (model.shape.components,) or not np.isfinite(alpha).all():
                raise UserError(f"the face's coefficients do not fit model {model.name!r}")
            beta = op.get("colour")
            beta = beta0 if beta is None or beta0 is None else np.asarray(beta, np.float64)
            if beta is not None and (beta.shape != beta0.shape or not np.isfinite(beta).all()):
                raise UserError(f"the face's colour coefficients do not fit model {model.name!r}")
            self._reset(alpha, beta)
        elif kind == "example":
            index = int(op["index"])
            alpha = model.example_coefficients(index, "shape")
            if alpha is None:
                raise UserError("this model has no example database")
            beta = model.example_coefficients(index, "colour")
            self._reset(alpha, beta if beta is not None else beta0)
        else:
            raise UserError(f"unknown face {kind!r}; use average, random, example or coefficients")

    def set_attribute(self, name: str, value: float, part: str = "shape", segments=()) -> None:
        """Set the slider of attribute ``name`` (shape or colour) to ``value`` (5.1.4)."""
        for one in self.parts(part):
            self.run({"op": "attribute", "name": name, "part": one, "value": _finite(value, name),
                      "segments": list(_segment_key(segments))})

    def set_attribute_value(self, name: str, value: float, part: str = "both", segments=()) -> None:
        """Give the face the attribute value ``f_A = value`` (3.2.2, Eq. 3.5), absolutely, for each part: the
        slider of ``name`` moves by the amount that gets there. ``f_A`` is linear along the slider's direction
        (restricted to ``segments`` or not) and so is the constraints' correction after it (Eq. 3.6): one
        step, and with constraints a second one at the rate the first achieved, get there exactly."""
        target = _finite(value, name)
        for one in self.parts(part):
            start, first = self.value(name, one), self.slider(name, one, segments)
            _, coefficients = self.direction(name, one, segments)
            rate = float(self.model.part(one).mahalanobis(coefficients, self.model.attribute(name).vector(one)))
            if abs(rate) < 1e-12:
                raise UserError(f"{name} cannot be changed within the segments {', '.join(segments)}")
            slider = first + (target - start) / rate
            self._slide(name, one, segments, slider, target)
            reached = self.value(name, one)
            if abs(reached - target) > 1e-9 * max(1.0, abs(target)) and slider != first:
                rate = (reached - start) / (slider - first)
                if abs(rate) < 1e-9:
                    raise UserError(f"the constraints hold {name} where it is; release them to set it")
                self._slide(name, one, segments, slider + (target - reached) / rate, target)

    def _slide(self, name: str, part: str, segments, slider: float, target: float) -> None:
        self.run({"op": "attribute", "name": name, "part": part, "segments": list(_segment_key(segments)),
                  "value": _finite(slider, f"the {name} slider that gives {name} = {target:g}"), "target": target})

    def _op_attribute(self, op: dict) -> None:
        key = self._key("attribute", op["name"], op["part"], op["segments"])
        delta = float(op["value"]) - self.applied.get(key, 0.0)
        offset, coefficients = self.direction(op["name"], op["part"], op["segments"])
        self._add(op["part"], offset, coefficients, delta)
        self.applied[key] = float(op["value"])

    def caricature(self, level: float, part: str = "both", segments=()) -> None:
        """Caricature level ``c`` (3.2.2): ``s_c = s_mean + c sum alpha_k s_k``, relative to level 1."""
        level = _finite(level, "caricature level", MAX_CARICATURE)
        if level < 0.05:
            raise UserError("caricature level must be at least 0.05 (1 = the face itself)")
        for one in self.parts(part):
            self.run({"op": "caricature", "part": one, "level": level, "segments": list(_segment_key(segments))})

    def _op_caricature(self, op: dict) -> None:
        key = self._key("caricature", op["part"], op["segments"])
        ratio = float(op["level"]) / self.applied.get(key, 1.0)
        part = op["part"]
        current = self.shape if part == "shape" else self.colour
        deviation = current - self.model.part(part).mean.reshape(-1, 3)
        ratio = self._bounded(part, ratio, deviation, op["segments"])
        if op["segments"]:
            self._add_displacement(part, (ratio - 1.0) * deviation, op["segments"])
        else:
            self._add(part, deviation, self.coefficients(part).copy(), ratio - 1.0)
        self.applied[key] = self.applied.get(key, 1.0) * ratio

    def _bounded(self, part: str, ratio: float, deviation: np.ndarray, segments) -> float:
        """The caricature ratio, lowered where needed so the face stays plausible (3.2.2) for a model that
        names its range (``info["mahalanobis_radius"]``, the farthest example): a Mahalanobis norm
        ``||alpha / sigma||`` of at most that radius (the norm of ``alpha + (r - 1) d`` is quadratic in
        ``r``: the largest ``r`` up to the asked one within the radius is its root; a face already beyond
        it is not pushed further out), and no triangle folded over against the face it started from
        (bisection on ``r``). Other models are not bounded."""
        radius = self.model.info.get("mahalanobis_radius")
        if not radius or part != "shape" or ratio <= 1.0:
            return ratio
        mask = selection_mask(self.model.segments, segments, self.model.vertex_count) if segments else None
        moved = deviation if mask is None else self.blender.blend(deviation, mask)
        sd = self.model.shape.sd
        alpha, step = self.alpha / sd, self.model.shape.project(moved) / sd
        a, b, c = float(step @ step), 2.0 * float(alpha @ step), float(alpha @ alpha) - float(radius) ** 2
        if c >= 0:
            return 1.0
        if a > 0:
            ratio = min(ratio, 1.0 + (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a))
        if folded_against(self.shape + (ratio - 1.0) * moved, self.shape, self.model.triangles) == 0:
            return ratio
        low, high = 1.0, ratio
        for _ in range(16):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if folded_against(self.shape + (middle - 1.0) * moved, self.shape,
                                                         self.model.triangles) == 0 else (low, middle)
        return low

    def import_feature(self, index: int, segments, part: str = "both") -> None:
        """Replace the selected segments by those of database example ``index`` (5.1.5)."""
        if not 0 <= int(index) < len(self.model.example_names):
            raise UserError(f"example {index} does not exist (the database has {len(self.model.example_names)})")
        for one in self.parts(part):
            self.run({"op": "import", "part": one, "index": int(index), "segments": list(_segment_key(segments))})

    def _op_import(self, op: dict) -> None:
        part = op["part"]
        table = self.database.get(part)
        if table is None:
            raise UserError(f"this model has no {part} examples to import from")
        target = self.model.part(part).vector(table[int(op["index"])]).reshape(-1, 3)
        current = self.shape if part == "shape" else self.colour
        self._add_displacement(part, target - current, op["segments"])

    def transform(self, matrix, segments=()) -> None:
        """An affine transform (4x4, about the selection's centroid) of the face or a segment (5.1.3)."""
        matrix = np.asarray(matrix, np.float64)
        if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
            raise UserError("an affine transform must be a finite 4x4 matrix")
        if abs(np.linalg.det(matrix[:3, :3])) < 1e-6:
            raise UserError("the affine transform collapses the face (its 3x3 part is singular)")
        self.run({"op": "affine", "matrix": matrix.ravel().tolist(), "segments": list(_segment_key(segments))})

    def _op_affine(self, op: dict) -> None:
        matrix = np.asarray(op["matrix"], np.float64).reshape(4, 4)
        mask = selection_mask(self.model.segments, op["segments"], self.model.vertex_count)
        pivot = self.shape[mask].mean(axis=0) if mask is not None and mask.any() else self.shape.mean(axis=0)
        moved = (self.shape - pivot) @ matrix[:3, :3].T + pivot + matrix[:3, 3]
        self._add_displacement("shape", moved - self.shape, op["segments"])

    def add_detail(self, name: str, factor: float) -> None:
        """High-frequency detail vector ``name`` at ``factor`` (5.1.9; the thesis found 0.7 good)."""
        if name not in self.model.details:
            raise UserError(f"no detail vector {name!r} in this model (has: {', '.join(self.model.details) or 'none'})")
        if self.colour is None:
            raise UserError("detail vectors need a colour model")
        self.run({"op": "detail", "name": name, "factor": _finite(factor, "detail factor", 3.0)})

    def _op_detail(self, op: dict) -> None:
        key = self._key("detail", op["name"], ())
        delta = float(op["factor"]) - self.applied.get(key, 0.0)
        detail = np.asarray(self.model.details[op["name"]], np.float64).reshape(-1, 3)
        self._add("colour", detail, self.model.colour.project(detail), delta)
        self.applied[key] = float(op["factor"])

    # ------------------------------------------------------------------ constraints (3.2.3)
    def constrain(self, attribute: str, part: str = "shape", segments=(), database: bool = False) -> Constraint:
        """Store the attribute's current value(s) (Eq. 3.5) as a constraint; ``database`` also adapts every
        example of the database to it (5.1.7)."""
        parts = self.parts(part)
        values = {p: (self.value(attribute, p) if self.model.attribute(attribute).vector(p) is not None else None)
                  for p in ("shape", "colour") if p in parts}
        if all(v is None for v in values.values()):
            raise UserError(f"attribute {attribute!r} has no {part} vector to constrain")
        op = {"op": "constrain", "attribute": attribute, "shape": values.get("shape"),
              "colour": values.get("colour"), "segments": list(_segment_key(segments))}
        self.run(op)
        if database:
            self.run({"op": "constrain_database"})
        return self.constraints[-1]

    def _op_constrain(self, op: dict) -> None:
        self.constraints = [c for c in self.constraints if c.attribute != op["attribute"]]
        self.constraints.append(Constraint(op["attribute"], op.get("shape"), op.get("colour"),
                                           tuple(op.get("segments", ()))))

    def unconstrain(self, attribute: str) -> None:
        if all(c.attribute != attribute for c in self.constraints):
            raise UserError(f"{attribute!r} is not constrained")
        self.run({"op": "unconstrain", "attribute": attribute})

    def _op_unconstrain(self, op: dict) -> None:
        self.constraints = [c for c in self.constraints if c.attribute != op["attribute"]]

    def _constraint_system(self, part: str):
        active = [c for c in self.constraints if c.value(part) is not None]
        if not active or self.model.part(part) is None:
            return None
        model_part = self.model.part(part)
        targets = np.array([c.value(part) for c in active])
        duals = np.stack([self.model.attribute(c.attribute).vector(part) for c in active]) / model_part.sd ** 2
        corrections = [self.direction(c.attribute, part, c.segments) for c in active]
        gram = duals @ np.stack([coefficients for _, coefficients in corrections]).T   # G_ij = <E_j, ds_Ai>_M
        return targets, duals, corrections, gram

    def enforce_constraints(self) -> None:
        """Eq. 3.6: add ``sum_j mu_j ds_Aj`` so every constrained value is back at its stored value."""
        for part in ("shape", "colour"):
            system = self._constraint_system(part)
            if system is None:
                continue
            targets, duals, corrections, gram = system
            residual = targets - duals @ self.coefficients(part)
            mu = np.linalg.lstsq(gram, residual, rcond=None)[0]
            for amount, (offset, coefficients) in zip(mu, corrections):
                self._add(part, offset, coefficients, float(amount))

    def _op_constrain_database(self, op: dict) -> None:
        """Adapt every database example to the constraints (5.1.7, Fig. 5.8), in coefficients."""
        for part, table in self.database.items():
            system = self._constraint_system(part)
            if system is None:
                continue
            targets, duals, corrections, gram = system
            residual = targets[None, :] - table @ duals.T
            mu = np.linalg.lstsq(gram, residual.T, rcond=None)[0]
            table += mu.T @ np.stack([coefficients for _, coefficients in corrections])

    # ------------------------------------------------------------------ history
    def undo(self) -> None:
        """Take the last operation back (replays the history without it)."""
        if len(self.history) <= 1:
            raise UserError("nothing to undo")
        replayed = face_from_state(self.model, {**self.state(), "history": self.history[:-1]}, check=False)
        self.__init_from(replayed)

    def __init_from(self, other: "EditFace") -> None:
        for name in ("constraints", "history", "applied", "database", "alpha", "beta", "shape", "colour"):
            setattr(self, name, getattr(other, name))

    def state(self) -> dict:
        """The face as JSON-ready data: model fingerprint, history, constraints, coefficients (5.1.10)."""
        return {"format": FACE_FORMAT, "version": 1, "model": model_fingerprint(self.model),
                "model_name": self.model.name, "history": list(self.history),
                "constraints": [c.to_json() for c in self.constraints],
                "coefficients": {"shape": self.alpha.tolist(),
                                 "colour": None if self.beta is None else self.beta.tolist()}}

    def history_lines(self) -> list[str]:
        """The edit history in words (the panel's list)."""
        return [describe(op) for op in self.history]


def describe(op: dict) -> str:
    where = f" [{', '.join(op['segments'])}]" if op.get("segments") else ""
    kind = op.get("op")
    if kind == "create":
        return {"average": "average face", "random": f"random face (seed {op['seed']})",
                "example": f"example {op['index']}", "coefficients": "fitted face"}.get(op["kind"], op["kind"])
    if kind == "attribute" and "target" in op:
        return f"{op['name']} ({op['part']}) set to {op['target']:+.2f} (slider {op['value']:+.2f}){where}"
    if kind == "attribute":
        return f"{op['name']} ({op['part']}) = {op['value']:+.2f}{where}"
    if kind == "caricature":
        return f"caricature ({op['part']}) x{op['level']:.2f}{where}"
    if kind == "import":
        return f"import {op['part']} of example {op['index']}{where}"
    if kind == "affine":
        return f"affine transform{where}"
    if kind == "detail":
        return f"detail {op['name']} x{op['factor']:.2f}"
    if kind == "constrain":
        return f"constrain {op['attribute']}{where}"
    if kind == "unconstrain":
        return f"release {op['attribute']}"
    return "constraints applied to the database" if kind == "constrain_database" else str(kind)


def face_from_state(model: MorphableModel, state, check: bool = True, blender: SegmentBlender | None = None) -> EditFace:
    """Replay a saved face (:meth:`EditFace.state`, or its JSON text) on ``model``."""
    if isinstance(state, (str, bytes)):
        try:
            state = json.loads(state)
        except ValueError as error:
            raise UserError(f"not a saved morphable face (JSON error: {error})") from None
    if not isinstance(state, dict) or state.get("format") != FACE_FORMAT or not isinstance(state.get("history"), list):
        raise UserError(f"not a saved morphable face (expected format {FACE_FORMAT!r})")
    if state.get("version") != 1:
        raise UserError(f"saved face version {state.get('version')!r} is not read by this extension (reads 1)")
    if check and state.get("model") != model_fingerprint(model):
        raise UserError(f"the face was saved with model {state.get('model_name')!r}, not {model.name!r}; "
                        "load that model first")
    face = EditFace(model, blender)
    for op in state["history"]:
        if not isinstance(op, dict):
            raise UserError("saved face: every history entry must be an operation object")
        face.run(op)
    if check:
        stored = np.asarray((state.get("coefficients") or {}).get("shape") or [], np.float64)
        if stored.shape == face.alpha.shape and not np.allclose(stored, face.alpha, rtol=1e-6, atol=1e-9):
            raise UserError("the saved face does not replay to its stored coefficients; the file was edited "
                            "or the model changed")
    return face
