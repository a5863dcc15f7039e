# SPDX-License-Identifier: GPL-3.0-or-later
"""Articulation target presets: per phone (class), a target T_sp for every speech parameter p and the
Cohen-Massaro dominance parameters (alpha, theta_back, theta_fwd, peak offset, c), thesis 3.1.3.

Two presets ship in ``presets/speech/`` and are plain, editable JSON:

* ``articulation.json`` (``"kind": "muscles"``) -- the speech parameters of 3.1.3 "Muscles":
  orbicularis oris upper/lower and protrusion, mentalis L/R, risorius L/R, depressor labii inferioris
  L/R, jaw opening and the tongue (control names of CONTRIBUTING.md).
* ``visemes.json`` (``"kind": "visemes"``) -- one-hot weights on the 15 Meta viseme shape keys, so
  the same coarticulation drives characters without a muscle rig. Classes are viseme names; their
  phones default to :data:`speech.phonemes.VISEME_OF_PHONE`.

Schema (both kinds)::

    {"format": "faces_hands.speech_targets", "version": 1, "kind": "muscles" | "visemes",
     "parameters": {"jaw_open": {"rest": 0, "range": [0, 1]}, ...},      # muscles only
     "defaults": {"alpha": 1, "theta_back": 25, "theta_fwd": 25, "peak_offset": 0, "c": 1,
                  "peak": "center", "alpha_at": "peak"},
     "unspecified_alpha": 0.1,       # alpha of parameters a class gives no target for
     "phases": {"closure_release": ["p", "b"], "closure": ["m", "f", "v"], "closure_fraction": 0.6},
     "release": {"targets": "next", "dominance": {...}},
     "classes": {"name": {"phones": [...], "targets": {"param": value},
                          "dominance": {...}, "parameter_dominance": {"param": {...}}}}}

``theta_back`` (theta<- of the thesis) applies before the dominance peak (tau >= 0), ``theta_fwd``
(theta->) after it; both in 1/s. ``peak_offset`` (t_off) is in seconds, measured from the segment
centre, or from its start when ``"peak": "start"``. ``"alpha_at": "edges"`` makes ``alpha`` the
dominance at the segment's start and end instead of at its peak: the segment's own magnitude becomes
``alpha * exp(theta * (duration / 2) ** c)``, so a closure of any length is held from its first to its
last key frame (3.1.3: "by assigning a high magnitude to the dominance function, the lips come
sufficiently close to their targets") while its reach into neighbours stays the same.
A target name without ``_L``/``_R`` sets both sides.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from .phonemes import PHONES, VISEME_OF_PHONE, VISEMES

PRESET_DIR = Path(__file__).resolve().parents[2] / "presets" / "speech"
FORMAT = "faces_hands.speech_targets"
DOMINANCE_KEYS = ("alpha", "theta_back", "theta_fwd", "peak_offset", "c", "peak", "alpha_at")
PHASES = ("normal", "closure", "closure_release")


@dataclass(frozen=True)
class Dominance:
    """Per-parameter dominance arrays (one entry per parameter)."""

    alpha: np.ndarray
    theta_back: np.ndarray
    theta_fwd: np.ndarray
    peak_offset: np.ndarray
    c: np.ndarray
    peak_at_start: bool


@dataclass(frozen=True)
class TargetSet:
    """A compiled preset. Row ``row_of[phone]`` of ``targets``/``alpha``/... belongs to that phone."""

    kind: str
    parameters: tuple[str, ...]
    rest: np.ndarray
    ranges: dict[str, tuple[float, float]]
    row_of: dict[str, int]
    targets: np.ndarray      # (rows, P)
    alpha: np.ndarray        # (rows, P)
    theta_back: np.ndarray   # (rows, P)
    theta_fwd: np.ndarray    # (rows, P)
    peak_offset: np.ndarray  # (rows, P)
    c: np.ndarray            # (rows, P)
    peak_at_start: np.ndarray  # (rows,) bool
    alpha_at_edges: np.ndarray  # (rows,) bool: alpha is the dominance at the segment's start and end
    phase_of: dict[str, str]
    closure_fraction: float
    release_targets: np.ndarray | None  # (P,) or None for "the next segment's targets"
    release: Dominance
    source: str

    def phase(self, phone: str) -> str:
        return self.phase_of.get(phone, "normal")


def _fail(source: str, message: str):
    raise UserError(f"{source}: {message}")


def _number(source, where, value, low=None, high=None, positive=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        _fail(source, f"{where} must be a number, not {value!r}")
    if positive and value <= 0:
        _fail(source, f"{where} must be greater than 0, not {value}")
    if low is not None and value < low:
        _fail(source, f"{where} must be at least {low}, not {value}")
    if high is not None and value > high:
        _fail(source, f"{where} must be at most {high}, not {value}")
    return float(value)


def _dominance(source, where, spec, base) -> dict:
    if not isinstance(spec, dict):
        _fail(source, f"{where} must be an object with {', '.join(DOMINANCE_KEYS)}")
    unknown = set(spec) - set(DOMINANCE_KEYS)
    if unknown:
        _fail(source, f"{where} has unknown keys {sorted(unknown)}; use {', '.join(DOMINANCE_KEYS)}")
    out = dict(base)
    for key, value in spec.items():
        if key == "peak":
            if value not in ("center", "start"):
                _fail(source, f"{where}.peak must be 'center' or 'start', not {value!r}")
            out[key] = value
        elif key == "alpha_at":
            if value not in ("peak", "edges"):
                _fail(source, f"{where}.alpha_at must be 'peak' or 'edges', not {value!r}")
            out[key] = value
        elif key in ("alpha", "theta_back", "theta_fwd"):
            out[key] = _number(source, f"{where}.{key}", value, low=0.0)
        elif key == "c":
            out[key] = _number(source, f"{where}.c", value, positive=True)
        else:
            out[key] = _number(source, f"{where}.{key}", value)
    return out


def _expand(source, where, name, parameters) -> list[str]:
    """A parameter name, or a side-less name that stands for its _L and _R parameters."""
    if name in parameters:
        return [name]
    sides = [f"{name}_L", f"{name}_R"]
    if all(s in parameters for s in sides):
        return sides
    _fail(source, f"{where}: unknown parameter {name!r}; known: {', '.join(parameters)}")


def _phone_list(source, where, phones) -> list[str]:
    if not isinstance(phones, list) or not all(isinstance(p, str) for p in phones):
        _fail(source, f"{where}.phones must be a list of phone names")
    for p in phones:
        if p not in PHONES:
            _fail(source, f"{where}: unknown phone {p!r}; known phones: {', '.join(PHONES)}")
    return phones


def compile_target_set(data: dict, source: str = "preset") -> TargetSet:
    """Validate a preset dictionary (see the module docstring) and compile it to arrays."""
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        _fail(source, f"not a speech target preset (\"format\" must be \"{FORMAT}\")")
    if data.get("version") != 1:
        _fail(source, f"unsupported version {data.get('version')!r}; this add-on reads version 1")
    kind = data.get("kind")
    if kind not in ("muscles", "visemes"):
        _fail(source, f"\"kind\" must be \"muscles\" or \"visemes\", not {kind!r}")

    if kind == "visemes":
        parameters = list(VISEMES)
        rest = {v: 0.0 for v in VISEMES}
        ranges = {v: (0.0, 1.0) for v in VISEMES}
    else:
        spec = data.get("parameters")
        if not isinstance(spec, dict) or not spec:
            _fail(source, "\"parameters\" must map each parameter name to {\"rest\", \"range\"}")
        parameters, rest, ranges = [], {}, {}
        for name, entry in spec.items():
            if not isinstance(entry, dict) or "range" not in entry:
                _fail(source, f"parameter {name!r} needs a \"range\": [low, high]")
            rng = entry["range"]
            if not (isinstance(rng, list) and len(rng) == 2):
                _fail(source, f"parameter {name!r}: range must be [low, high]")
            low = _number(source, f"{name}.range[0]", rng[0])
            high = _number(source, f"{name}.range[1]", rng[1])
            if high <= low:
                _fail(source, f"parameter {name!r}: range low must be below high")
            parameters.append(name)
            ranges[name] = (low, high)
            rest[name] = _number(source, f"{name}.rest", entry.get("rest", 0.0), low, high)

    defaults = _dominance(source, "defaults", data.get("defaults", {}),
                          {"alpha": 1.0, "theta_back": 25.0, "theta_fwd": 25.0, "peak_offset": 0.0,
                           "c": 1.0, "peak": "center", "alpha_at": "peak"})
    unspecified_alpha = _number(source, "unspecified_alpha", data.get("unspecified_alpha", 0.1), low=0.0)

    phases_spec = data.get("phases", {})
    phase_of: dict[str, str] = {}
    for phase in ("closure_release", "closure"):
        for p in _phone_list(source, f"phases.{phase}", phases_spec.get(phase, [])):
            if p in phase_of:
                _fail(source, f"phone {p!r} is in two phase lists")
            phase_of[p] = phase
    closure_fraction = _number(source, "phases.closure_fraction", phases_spec.get("closure_fraction", 0.6),
                               low=0.05, high=0.95)

    classes = data.get("classes")
    if not isinstance(classes, dict) or not classes:
        _fail(source, "\"classes\" must map class names to {\"phones\", \"targets\", \"dominance\"}")
    explicit: dict[str, str] = {}
    for cname, cls in classes.items():
        if not isinstance(cls, dict):
            _fail(source, f"class {cname!r} must be an object")
        if kind == "visemes" and cname not in VISEMES:
            _fail(source, f"class {cname!r} is not a viseme name; use one of {', '.join(VISEMES)}")
        for p in _phone_list(source, f"classes.{cname}", cls.get("phones", [])):
            if p in explicit:
                _fail(source, f"phone {p!r} is in classes {explicit[p]!r} and {cname!r}")
            explicit[p] = cname
    class_of = dict(explicit)
    if kind == "visemes":
        for p, viseme in VISEME_OF_PHONE.items():
            if p not in class_of and viseme in classes:
                class_of[p] = viseme
    default_class = "default" if "default" in classes else None
    missing = [p for p in PHONES if p not in class_of]
    if missing and default_class is None:
        _fail(source, f"no class for the phones {', '.join(missing)}; add them to a class or add a "
                      "\"default\" class")
    for p in missing:
        class_of[p] = default_class

    P = len(parameters)
    index = {name: i for i, name in enumerate(parameters)}
    rest_vector = np.array([rest[n] for n in parameters])
    compiled: dict[str, tuple] = {}
    for cname, cls in classes.items():
        unknown = set(cls) - {"phones", "targets", "dominance", "parameter_dominance", "description"}
        if unknown:
            _fail(source, f"class {cname!r} has unknown keys {sorted(unknown)}")
        dom = _dominance(source, f"classes.{cname}.dominance", cls.get("dominance", {}), defaults)
        target = rest_vector.copy()
        specified = np.zeros(P, dtype=bool)
        if kind == "visemes":
            if "targets" in cls:
                _fail(source, f"class {cname!r}: viseme classes take no targets (they are one-hot)")
            target[:] = 0.0
            target[index[cname]] = 1.0
            specified[:] = True
        else:
            targets = cls.get("targets", {})
            if not isinstance(targets, dict):
                _fail(source, f"class {cname!r}: targets must map parameters to values")
            for name, value in targets.items():
                for full in _expand(source, f"class {cname!r}", name, parameters):
                    target[index[full]] = _number(source, f"classes.{cname}.targets.{name}", value,
                                                  *ranges[full])
                    specified[index[full]] = True
        per = {k: np.full(P, dom[k], dtype=float) for k in ("alpha", "theta_back", "theta_fwd",
                                                            "peak_offset", "c")}
        per["alpha"][~specified] = unspecified_alpha
        for name, spec in (cls.get("parameter_dominance") or {}).items():
            override = _dominance(source, f"classes.{cname}.parameter_dominance.{name}", spec, dom)
            for full in _expand(source, f"class {cname!r}", name, parameters):
                for k in per:
                    per[k][index[full]] = override[k]
        compiled[cname] = (target, per, dom["peak"] == "start", dom["alpha_at"] == "edges")

    rows = list(PHONES)
    row_of = {p: i for i, p in enumerate(rows)}
    stack = {k: np.stack([compiled[class_of[p]][1][k] for p in rows]) for k in
             ("alpha", "theta_back", "theta_fwd", "peak_offset", "c")}

    release_spec = data.get("release", {"targets": "next"})
    if not isinstance(release_spec, dict) or set(release_spec) - {"targets", "dominance", "description"}:
        _fail(source, "release must be an object with \"targets\" and \"dominance\"")
    release_dom = _dominance(source, "release.dominance", release_spec.get("dominance", {}), defaults)
    release_targets = release_spec.get("targets", "next")
    if release_targets == "next":
        release_vector = None
    elif isinstance(release_targets, dict):
        release_vector = rest_vector.copy() if kind == "muscles" else np.zeros(P)
        for name, value in release_targets.items():
            for full in _expand(source, "release", name, parameters):
                release_vector[index[full]] = _number(source, f"release.targets.{name}", value, *ranges[full])
    else:
        _fail(source, "release.targets must be \"next\" (the following segment's targets) or an "
                      "object of parameter targets")
    release = Dominance(*(np.full(P, release_dom[k], dtype=float) for k in
                          ("alpha", "theta_back", "theta_fwd", "peak_offset", "c")), True)

    return TargetSet(kind=kind, parameters=tuple(parameters), rest=rest_vector, ranges=ranges,
                     row_of=row_of, targets=np.stack([compiled[class_of[p]][0] for p in rows]),
                     alpha=stack["alpha"], theta_back=stack["theta_back"], theta_fwd=stack["theta_fwd"],
                     peak_offset=stack["peak_offset"], c=stack["c"],
                     peak_at_start=np.array([compiled[class_of[p]][2] for p in rows]),
                     alpha_at_edges=np.array([compiled[class_of[p]][3] for p in rows]),
                     phase_of=phase_of, closure_fraction=closure_fraction,
                     release_targets=release_vector, release=release, source=source)


def load_target_set(path: str | os.PathLike) -> TargetSet:
    """Read and validate a preset file (UserError with the file name and the problem)."""
    path = os.fspath(path)
    name = os.path.basename(path)
    try:
        with open(path, encoding="utf-8") as handle:
            data = json.load(handle)
    except FileNotFoundError:
        raise UserError(f"preset {path!r} does not exist") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{name}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    return compile_target_set(data, name)


def load_articulation(path: str | os.PathLike | None = None) -> TargetSet:
    """The muscle/jaw/tongue targets (default ``presets/speech/articulation.json``)."""
    return load_target_set(path or PRESET_DIR / "articulation.json")


def load_viseme_targets(path: str | os.PathLike | None = None) -> TargetSet:
    """The one-hot viseme targets (default ``presets/speech/visemes.json``)."""
    return load_target_set(path or PRESET_DIR / "visemes.json")
