# SPDX-License-Identifier: GPL-3.0-or-later
"""The morphable model of whole heads on the default character's topology (thesis 3.2, chapter 5): the
MPFB2 base mesh's head and neck stump with its own eyes, teeth and tongue, learned from seeded example heads
made of MakeHuman's CC0 modelling targets (``scripts/build_head_model.py`` writes
``assets/morph/mpfb2_heads.npz``).

Every vertex of the model is a vertex of the MPFB2 base mesh (``info["base_ids"]``), so an edited head is
written straight into the character's mesh (:func:`character_vertices`); the model's coordinates are the
default character's (metres, Z up, face along -Y). The lowest ring of the neck stump does not move in any
example (the examples are blended into the unchanged body over the stump, ``info["neck_ramp_m"]``), so a
head from the model joins the character's body without a seam.

The attributes (Eq. 3.4, Table 5.2 categories) are learned from ratings **measured on each example's mesh**
(:func:`measures`): distances between anthropometric landmarks, which are fixed vertices of the topology
(found once on the model's mean by :func:`find_landmarks`), and a volume; only the age is the age the
example was made with (MakeHuman's age scale: 1, 11, 25 and 90 years at slider 0, 0.1875, 0.5 and 1, the
mapping ``age_value`` in ``scripts/population_heads.py`` uses).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from ..assets import ASSETS_DIR
from ..core.errors import UserError
from ..core.geometry import vertex_areas, vertex_normals
from .editing import folded_against
from .model import MorphableModel, load_native

__all__ = ["HEAD_MODEL_FILE", "TOPOLOGY", "MEASURES", "head_model", "check_head_model", "find_landmarks",
           "measures", "albedo", "character_ids", "character_vertices", "folded_triangles", "mahalanobis_radius"]

HEAD_MODEL_FILE = ASSETS_DIR / "morph" / "mpfb2_heads.npz"
TOPOLOGY = "mpfb2_hm08_head"
MM = 1000.0
BASE_VERTICES = 19158          # the MPFB2 base mesh (hm08)
#: measure -> what it is (mm unless said): each an attribute's rating (``info["attributes"]``)
MEASURES = {
    "jaw_width": "bigonial width: gonion to gonion",
    "face_width": "bizygomatic width: zygion to zygion",
    "face_height": "morphological face height: nasion to menton",
    "nose_length": "nasion to pronasale",
    "nose_width": "alar width: alare to alare",
    "lip_thickness": "vermilion height: labrale superius to labrale inferius, vertically",
    "mouth_width": "cheilion to cheilion",
    "chin_projection": "pogonion in front of subnasale (along the face's forward axis)",
    "brow_ridge": "glabella in front of nasion",
    "eye_distance": "between the eyeballs' centres",
    "ear_length": "height of the ears (mean of both)",
    "head_height": "vertex (top of the head) to menton",
    "face_ratio": "face height over face width",
    "jaw_ratio": "jaw width over face width",
    "eye_ratio": "eye distance over face width",
    "nose_length_ratio": "nose length over face height",
    "nose_width_ratio": "alar width over face width",
    "mouth_ratio": "mouth width over face width",
    "lip_ratio": "vermilion height over face height",
    "ear_ratio": "ear height over head height",
    "fullness": "volume added over the cheeks and under the chin, relative to the model's mean, with the head "
                "first scaled to the mean's head height (cm^3)",
    "masculinity": "sexual-dimorphism score: mean z-score of brow ridge, nose length ratio, jaw ratio and minus "
                   "lip ratio (z against the model examples)",
}
#: the relative measures: name -> (numerator, denominator)
RATIOS = {"face_ratio": ("face_height", "face_width"), "jaw_ratio": ("jaw_width", "face_width"),
          "eye_ratio": ("eye_distance", "face_width"), "nose_length_ratio": ("nose_length", "face_height"),
          "nose_width_ratio": ("nose_width", "face_width"), "mouth_ratio": ("mouth_width", "face_width"),
          "lip_ratio": ("lip_thickness", "face_height"), "ear_ratio": ("ear_length", "head_height")}
DIMORPHISM = (("brow_ridge", 1.0), ("nose_length_ratio", 1.0), ("jaw_ratio", 1.0), ("lip_ratio", -1.0))


def check_head_model(model: MorphableModel, source: str = "the model") -> MorphableModel:
    """Refuse a model that is not on the character's head topology (another topology, a damaged file)."""
    info = model.info
    if info.get("topology") != TOPOLOGY:
        raise UserError(f"{source} is a model of the {info.get('topology') or 'unknown'!s} topology, not of the "
                        f"character's head ({TOPOLOGY}); it cannot reshape the character")
    ids = np.asarray(info.get("base_ids", []), np.int64)
    if ids.shape != (model.vertex_count,) or len(np.unique(ids)) != len(ids):
        raise UserError(f"{source}: its base-mesh vertex ids do not match its {model.vertex_count} vertices")
    if not isinstance(info.get("landmarks"), dict):
        raise UserError(f"{source}: it names no landmarks, so its attributes cannot be measured")
    return model


@lru_cache(maxsize=4)
def head_model(path: str | None = None) -> MorphableModel:
    """The shipped head model (or a model file on the same topology), loaded once."""
    path = Path(path) if path else HEAD_MODEL_FILE
    if not path.is_file():
        raise UserError(f"the head model {path.name} is missing; reinstall the extension (or run "
                        "scripts/build_head_model.py in a source checkout)")
    return check_head_model(load_native(path), str(path))


# ------------------------------------------------------------------------------------------ landmarks
def _profile(vertices: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """The midline vertices on the front silhouette (no vertex within 2 mm of height is 3 mm further
    forward), sorted from the top down."""
    mid = ids[np.abs(vertices[ids, 0]) < 1e-4]
    z, y = vertices[mid, 2], vertices[mid, 1]
    keep = [k for k in range(len(mid)) if not np.any((np.abs(z - z[k]) < 0.002) & (y < y[k] - 0.003))]
    mid = mid[keep]
    return mid[np.argsort(-vertices[mid, 2])]


def _extreme(vertices, profile, low, high, forward: bool) -> int:
    """The profile vertex between heights ``low`` and ``high`` furthest forward (or back)."""
    z = vertices[profile, 2]
    band = profile[(z > low) & (z < high)]
    if not len(band):
        raise UserError("the head's profile has no vertex where a landmark belongs; the mesh is not a head")
    y = vertices[band, 1]
    return int(band[np.argmin(y) if forward else np.argmax(y)])


def _lateral(vertices, candidates, side: int) -> int:
    return int(candidates[np.argmax(side * vertices[candidates, 0])])


def find_landmarks(vertices: np.ndarray, skin: np.ndarray, regions: dict[str, np.ndarray],
                   eyes: dict[str, np.ndarray]) -> dict[str, list[int]]:
    """Anthropometric landmarks as vertex ids of ``vertices`` (the model's mean; face along -Y, Z up):
    the midline ones on the front profile by turning points (forward / back maxima in order from the top
    down), the lateral ones as the outermost vertex of a region in a height band. ``skin``: ids of the head's
    skin; ``regions``: ``ears``, ``nose``, ``lips``, ``cheeks`` vertex ids; ``eyes``: ``L``/``R`` eyeball ids.
    Returns name -> vertex ids (one id, or several for regions)."""
    v, mm = vertices, 0.001
    profile = _profile(v, skin)
    face = profile[v[profile, 1] < np.median(v[skin, 1])]
    prn = int(face[np.argmin(v[face, 1])])
    z0 = v[prn, 2]
    n = _extreme(v, profile, z0 + 20 * mm, z0 + 70 * mm, False)
    g = _extreme(v, profile, v[n, 2], v[n, 2] + 40 * mm, True)
    sn = _extreme(v, profile, z0 - 25 * mm, z0 - 3 * mm, False)
    ls = _extreme(v, profile, v[sn, 2] - 20 * mm, v[sn, 2] - 2 * mm, True)
    sto = _extreme(v, profile, v[ls, 2] - 15 * mm, v[ls, 2] - 1 * mm, False)
    li = _extreme(v, profile, v[sto, 2] - 15 * mm, v[sto, 2] - 1 * mm, True)
    sl = _extreme(v, profile, v[li, 2] - 25 * mm, v[li, 2] - 1 * mm, False)
    pg = _extreme(v, profile, v[sl, 2] - 35 * mm, v[sl, 2] - 1 * mm, True)
    chin = profile[(v[profile, 2] < v[pg, 2]) & (v[profile, 1] < v[pg, 1] + 15 * mm)]
    me = int(chin[np.argmin(v[chin, 2])])
    top = int(skin[np.argmax(v[skin, 2])])
    ears = regions["ears"]
    in_front = skin[(v[skin, 1] < v[ears, 1].min()) & ~np.isin(skin, ears)]
    cheekbone = in_front[(v[in_front, 2] > z0) & (v[in_front, 2] < v[n, 2])]
    jaw = skin[(v[skin, 2] > v[me, 2]) & (v[skin, 2] < v[sto, 2]) & (v[skin, 1] < v[ears, 1].mean())
               & ~np.isin(skin, ears)]
    nose = regions["nose"]
    alar = nose[(v[nose, 2] > v[sn, 2] - 2 * mm) & (v[nose, 2] < z0) & (v[nose, 1] < v[sn, 1] + 8 * mm)]
    lips = regions["lips"]
    out = {"pronasale": [prn], "nasion": [n], "glabella": [g], "subnasale": [sn], "labrale_superius": [ls],
           "stomion": [sto], "labrale_inferius": [li], "sublabiale": [sl], "pogonion": [pg], "menton": [me],
           "vertex": [top]}
    for side, sign in (("L", 1), ("R", -1)):
        out[f"zygion_{side}"] = [_lateral(v, cheekbone, sign)]
        out[f"gonion_{side}"] = [_lateral(v, jaw, sign)]
        out[f"alare_{side}"] = [_lateral(v, alar, sign)]
        out[f"cheilion_{side}"] = [_lateral(v, lips, sign)]
        out[f"eye_{side}"] = [int(i) for i in eyes[side]]
        out[f"ear_{side}"] = [int(i) for i in ears[sign * v[ears, 0] > 0]]
    low = v[me, 2]
    submental = skin[(v[skin, 2] < low + 5 * mm) & (v[skin, 2] > low - 40 * mm) & (v[skin, 1] < v[me, 1] + 45 * mm)
                     & (np.abs(v[skin, 0]) < 45 * mm)]
    out["fullness"] = sorted({int(i) for i in np.concatenate([regions["cheeks"], submental])})
    return out


# ------------------------------------------------------------------------------------------ measures
def _point(vertices, landmarks, name) -> np.ndarray:
    return vertices[landmarks[name]].mean(axis=0)


def _distance(vertices, landmarks, a, b) -> float:
    return float(np.linalg.norm(_point(vertices, landmarks, a) - _point(vertices, landmarks, b)) * MM)


def measures(vertices: np.ndarray, model: MorphableModel) -> dict[str, float]:
    """Every :data:`MEASURES` entry of a head on the model's topology (vertices (n, 3), metres)."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    if v.shape[0] != model.vertex_count:
        raise UserError(f"a head of {v.shape[0]} vertices cannot be measured on a model of {model.vertex_count}")
    lm, info = model.info["landmarks"], model.info
    p = lambda name: _point(v, lm, name)       # noqa: E731
    out = {"jaw_width": _distance(v, lm, "gonion_L", "gonion_R"),
           "face_width": _distance(v, lm, "zygion_L", "zygion_R"),
           "face_height": _distance(v, lm, "nasion", "menton"),
           "nose_length": _distance(v, lm, "nasion", "pronasale"),
           "nose_width": _distance(v, lm, "alare_L", "alare_R"),
           "lip_thickness": float((p("labrale_superius")[2] - p("labrale_inferius")[2]) * MM),
           "mouth_width": _distance(v, lm, "cheilion_L", "cheilion_R"),
           "chin_projection": float((p("subnasale")[1] - p("pogonion")[1]) * MM),
           "brow_ridge": float((p("nasion")[1] - p("glabella")[1]) * MM),
           "eye_distance": _distance(v, lm, "eye_L", "eye_R"),
           "ear_length": 0.5 * MM * sum(float(np.ptp(v[lm[f"ear_{s}"], 2])) for s in "LR"),
           "head_height": float((p("vertex")[2] - p("menton")[2]) * MM)}
    out.update({name: out[a] / out[b] for name, (a, b) in RATIOS.items()})
    out["fullness"] = _fullness(v, model, out["head_height"])
    stats = info.get("measure_stats", {})
    if all(name in stats for name, _ in DIMORPHISM):
        out["masculinity"] = float(np.mean([sign * (out[name] - stats[name][0]) / stats[name][1]
                                            for name, sign in DIMORPHISM]))
    return out


@lru_cache(maxsize=8)
def _reference(model_id: int, mean_bytes: bytes, triangles_bytes: bytes, n: int):
    mean = np.frombuffer(mean_bytes).reshape(-1, 3)
    triangles = np.frombuffer(triangles_bytes, np.int64).reshape(-1, 3)
    return vertex_normals(mean, triangles), vertex_areas(mean, triangles)


def _fullness(v: np.ndarray, model: MorphableModel, height_mm: float) -> float:
    """Volume (cm^3) between the mean's surface and the head's over the fullness region: the outward
    normal displacement times each vertex's area on the mean, after scaling the head about its centroid to
    the mean's head height (a larger head is not a fuller one)."""
    mean = model.mean_vertices()
    lm = model.info["landmarks"]
    mean_height = float((mean[lm["vertex"], 2].mean() - mean[lm["menton"], 2].mean()) * MM)
    centre = v.mean(axis=0)
    v = mean.mean(axis=0) + (v - centre) * (mean_height / height_mm)
    normals, areas = _reference(id(model), np.ascontiguousarray(mean).tobytes(),
                                np.ascontiguousarray(model.triangles, np.int64).tobytes(), len(mean))
    ids = model.info["landmarks"]["fullness"]
    return float(np.sum(np.einsum("ij,ij->i", v[ids] - mean[ids], normals[ids]) * areas[ids]) * 1e6)


# ------------------------------------------------------------------------------------------ colour
SKIN, SCLERA, IRIS, TEETH, TONGUE = (0.78, 0.57, 0.47), (0.92, 0.92, 0.9), (0.18, 0.11, 0.07), (0.9, 0.88, 0.8), \
    (0.65, 0.3, 0.3)


def albedo(model: MorphableModel) -> np.ndarray:
    """A plain per-vertex colour for a head without a colour model (for the viewport and the contact
    sheets): skin, the eyeballs white with a dark iris where they look forward (-Y), teeth and tongue."""
    colour = np.tile(np.asarray(SKIN), (model.vertex_count, 1))
    parts, mean = model.info.get("parts", {}), model.mean_vertices()
    for side in ("eye_L", "eye_R"):
        ids = np.asarray(parts.get(side, []), np.int64)
        if len(ids):
            centre = 0.5 * (mean[ids].min(axis=0) + mean[ids].max(axis=0))
            direction = mean[ids] - centre
            direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-12)
            colour[ids] = np.where((-direction[:, 1] > 0.9)[:, None], IRIS, SCLERA)
    for role, value in (("teeth_upper", TEETH), ("teeth_lower", TEETH), ("tongue", TONGUE)):
        colour[np.asarray(parts.get(role, []), np.int64)] = value
    return colour


# ------------------------------------------------------------------------------------------ the character
def character_ids(model: MorphableModel, character_base_index: np.ndarray) -> np.ndarray:
    """The character's vertex id of each model vertex, given each character vertex's base-mesh id;
    refused when the character lacks one (another topology)."""
    base = np.asarray(character_base_index, np.int64)
    ids = np.asarray(model.info["base_ids"], np.int64)
    if base.ndim != 1 or (len(base) and (base.min() < 0 or base.max() >= BASE_VERTICES)):
        raise UserError("the character's base-mesh ids are not ids of the MPFB2 base mesh")
    lookup = np.full(BASE_VERTICES, -1, np.int64)
    lookup[base] = np.arange(len(base))
    local = lookup[ids]
    if (local < 0).any():
        raise UserError(f"the character lacks {int((local < 0).sum())} of the head model's vertices; it is not "
                        "the default character's topology")
    return local


def character_vertices(model: MorphableModel, character_base_index: np.ndarray, character: np.ndarray,
                       head: np.ndarray, local: np.ndarray | None = None) -> np.ndarray:
    """The character's vertices (k, 3) with its head replaced by ``head`` (the model's (n, 3) vertices);
    ``character_base_index`` gives each character vertex's base-mesh id (:func:`character_ids`)."""
    local = character_ids(model, character_base_index) if local is None else local
    out = np.array(character, np.float64, copy=True)
    out[local] = np.asarray(head, np.float64).reshape(-1, 3)
    return out


# ------------------------------------------------------------------------------------------ plausibility
def mahalanobis_radius(model: MorphableModel) -> float:
    """The plausible range of the model (3.2.2): the largest Mahalanobis norm ``||alpha / sigma||`` of its
    example faces (stored at build time; computed from the examples when missing)."""
    radius = model.info.get("mahalanobis_radius")
    if radius:
        return float(radius)
    table = model.examples.get("shape")
    if table is None:
        return float(np.sqrt(model.shape.components) * 2.0)
    return float(np.linalg.norm(table / model.shape.sd, axis=1).max())


def folded_triangles(vertices: np.ndarray, reference: np.ndarray, triangles: np.ndarray) -> int:
    """Triangles whose normal turned more than 90 degrees from the reference mesh's (folded over)."""
    return folded_against(vertices, reference, triangles)
