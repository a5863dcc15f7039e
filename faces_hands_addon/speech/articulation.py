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

import os
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError
from ..core.presets import PresetFormat, read_preset, read_preset_file, register_format
from .phonemes import PHONES, VISEME_OF_PHONE, VISEMES

FORMAT = register_format(PresetFormat("faces_hands.speech_targets", 1, required=("kind", "classes"),
                                     shape={"kind": str, "classes": {str: {}}, "parameters": {str: {}}}))
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
    class_of: dict[str, str] = field(default_factory=dict)   # phone -> the preset class it belongs to

    def phase(self, phone: str) -> str:
        return self.phase_of.get(phone, "normal")

    @property
    def class_names(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(self.class_of.values()))


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


def _parameter_table(source: str, data: dict, kind: str):
    """The preset's parameters, their rest values and ranges (visemes: the 15 viseme weights)."""
    if kind == "visemes":
        return list(VISEMES), {v: 0.0 for v in VISEMES}, {v: (0.0, 1.0) for v in VISEMES}
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
    return parameters, rest, ranges


def _phase_table(source: str, data: dict) -> tuple[dict[str, str], float]:
    """Which phones are closures (3.1.3: /p b/ closure + release, /m f v/ closure) and the closure share."""
    phases_spec = data.get("phases", {})
    phase_of: dict[str, str] = {}
    for phase in ("closure_release", "closure"):
        for p in _phone_list(source, f"phases.{phase}", phases_spec.get(phase, [])):
            if p in phase_of:
                _fail(source, f"phone {p!r} is in two phase lists")
            phase_of[p] = phase
    closure_fraction = _number(source, "phases.closure_fraction", phases_spec.get("closure_fraction", 0.6),
                               low=0.05, high=0.95)
    return phase_of, closure_fraction


def _class_of_phone(source: str, classes, kind: str) -> dict[str, str]:
    """Phone -> class name: the classes' phone lists, then (visemes) the engine's viseme table, then the
    ``default`` class."""
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
    return class_of


@dataclass(frozen=True)
class _Table:
    """What compiling a class needs to know about the preset's parameters."""
    kind: str
    parameters: list
    index: dict
    rest: np.ndarray
    ranges: dict
    defaults: dict
    unspecified_alpha: float


def _compile_class(source: str, cname: str, cls: dict, table: _Table):
    """One class -> (target vector, per-parameter dominance arrays, peak at start?, alpha at edges?)."""
    unknown = set(cls) - {"phones", "targets", "dominance", "parameter_dominance", "description"}
    if unknown:
        _fail(source, f"class {cname!r} has unknown keys {sorted(unknown)}")
    dom = _dominance(source, f"classes.{cname}.dominance", cls.get("dominance", {}), table.defaults)
    count = len(table.parameters)
    target = table.rest.copy()
    specified = np.zeros(count, dtype=bool)
    if table.kind == "visemes":
        if "targets" in cls:
            _fail(source, f"class {cname!r}: viseme classes take no targets (they are one-hot)")
        target[:] = 0.0
        target[table.index[cname]] = 1.0
        specified[:] = True
    else:
        targets = cls.get("targets", {})
        if not isinstance(targets, dict):
            _fail(source, f"class {cname!r}: targets must map parameters to values")
        for name, value in targets.items():
            for full in _expand(source, f"class {cname!r}", name, table.parameters):
                target[table.index[full]] = _number(source, f"classes.{cname}.targets.{name}", value,
                                                    *table.ranges[full])
                specified[table.index[full]] = True
    per = {k: np.full(count, dom[k], dtype=float) for k in ("alpha", "theta_back", "theta_fwd", "peak_offset", "c")}
    per["alpha"][~specified] = table.unspecified_alpha
    for name, spec in (cls.get("parameter_dominance") or {}).items():
        override = _dominance(source, f"classes.{cname}.parameter_dominance.{name}", spec, dom)
        for full in _expand(source, f"class {cname!r}", name, table.parameters):
            for k in per:
                per[k][table.index[full]] = override[k]
    return target, per, dom["peak"] == "start", dom["alpha_at"] == "edges"


def _release_phase(source: str, data: dict, table: _Table):
    """The release after a closure (3.1.3): its targets (None = the next segment's) and dominance."""
    release_spec = data.get("release", {"targets": "next"})
    if not isinstance(release_spec, dict) or set(release_spec) - {"targets", "dominance", "description"}:
        _fail(source, "release must be an object with \"targets\" and \"dominance\"")
    release_dom = _dominance(source, "release.dominance", release_spec.get("dominance", {}), table.defaults)
    release_targets = release_spec.get("targets", "next")
    count = len(table.parameters)
    if release_targets == "next":
        release_vector = None
    elif isinstance(release_targets, dict):
        release_vector = table.rest.copy() if table.kind == "muscles" else np.zeros(count)
        for name, value in release_targets.items():
            for full in _expand(source, "release", name, table.parameters):
                release_vector[table.index[full]] = _number(source, f"release.targets.{name}", value,
                                                             *table.ranges[full])
    else:
        _fail(source, "release.targets must be \"next\" (the following segment's targets) or an "
                      "object of parameter targets")
    release = Dominance(*(np.full(count, release_dom[k], dtype=float) for k in
                          ("alpha", "theta_back", "theta_fwd", "peak_offset", "c")), True)
    return release_vector, release


def compile_target_set(data: dict, source: str = "preset") -> TargetSet:
    """Validate a preset dictionary (see the module docstring) and compile it to arrays."""
    if not isinstance(data, dict) or data.get("format") != FORMAT.name:
        _fail(source, f"not a speech target preset (\"format\" must be \"{FORMAT.name}\")")
    if data.get("version") != 1:
        _fail(source, f"unsupported version {data.get('version')!r}; this add-on reads version 1")
    kind = data.get("kind")
    if kind not in ("muscles", "visemes"):
        _fail(source, f"\"kind\" must be \"muscles\" or \"visemes\", not {kind!r}")
    parameters, rest, ranges = _parameter_table(source, data, kind)
    defaults = _dominance(source, "defaults", data.get("defaults", {}),
                          {"alpha": 1.0, "theta_back": 25.0, "theta_fwd": 25.0, "peak_offset": 0.0,
                           "c": 1.0, "peak": "center", "alpha_at": "peak"})
    unspecified_alpha = _number(source, "unspecified_alpha", data.get("unspecified_alpha", 0.1), low=0.0)
    phase_of, closure_fraction = _phase_table(source, data)
    classes = data.get("classes")
    class_of = _class_of_phone(source, classes, kind)
    table = _Table(kind, parameters, {name: i for i, name in enumerate(parameters)},
                   np.array([rest[n] for n in parameters]), ranges, defaults, unspecified_alpha)
    compiled = {cname: _compile_class(source, cname, cls, table) for cname, cls in classes.items()}
    rows = list(PHONES)
    stack = {k: np.stack([compiled[class_of[p]][1][k] for p in rows]) for k in
             ("alpha", "theta_back", "theta_fwd", "peak_offset", "c")}
    release_vector, release = _release_phase(source, data, table)
    return TargetSet(kind=kind, parameters=tuple(parameters), rest=table.rest, ranges=ranges,
                     row_of={p: i for i, p in enumerate(rows)},
                     targets=np.stack([compiled[class_of[p]][0] for p in rows]),
                     alpha=stack["alpha"], theta_back=stack["theta_back"], theta_fwd=stack["theta_fwd"],
                     peak_offset=stack["peak_offset"], c=stack["c"],
                     peak_at_start=np.array([compiled[class_of[p]][2] for p in rows]),
                     alpha_at_edges=np.array([compiled[class_of[p]][3] for p in rows]),
                     phase_of=phase_of, closure_fraction=closure_fraction,
                     release_targets=release_vector, release=release, source=source,
                     class_of={p: class_of[p] for p in rows})


def load_target_set(path: str | os.PathLike) -> TargetSet:
    """Read and validate a preset file (UserError with the file name and the problem)."""
    doc, source = read_preset_file(path, FORMAT.name)
    return compile_target_set(doc, os.path.basename(source))


def _shipped_or_user(name: str) -> TargetSet:
    doc, source = read_preset(f"speech/{name}", FORMAT.name)
    return compile_target_set(doc, os.path.basename(source))


def load_articulation(path: str | os.PathLike | None = None) -> TargetSet:
    """The muscle/jaw/tongue targets (default ``presets/speech/articulation.json``, or the user's copy)."""
    return load_target_set(path) if path else _shipped_or_user("articulation.json")


def load_viseme_targets(path: str | os.PathLike | None = None) -> TargetSet:
    """The one-hot viseme targets (default ``presets/speech/visemes.json``, or the user's copy)."""
    return load_target_set(path) if path else _shipped_or_user("visemes.json")


def class_controls(name: str, path: str | os.PathLike | None = None) -> dict[str, float]:
    """The mouth shape of one articulation class as control values (side-less names expanded to _L and
    _R): the single definition the viseme expressions start from (``presets/expressions/visemes.json``)."""
    doc, source = read_preset_file(path, FORMAT.name) if path else read_preset("speech/articulation.json",
                                                                                FORMAT.name)
    target_set = compile_target_set(doc, os.path.basename(source))
    cls = doc["classes"].get(name)
    if cls is None:
        raise UserError(f"{os.path.basename(source)}: no articulation class {name!r}; classes: "
                        f"{', '.join(doc['classes'])}")
    out = {}
    for parameter, value in (cls.get("targets") or {}).items():
        for full in _expand(source, f"class {name!r}", parameter, target_set.parameters):
            out[full] = float(value)
    return out
