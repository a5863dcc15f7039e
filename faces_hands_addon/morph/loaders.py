# SPDX-License-Identifier: GPL-3.0-or-later
"""Models a user can bring, read into :class:`.model.MorphableModel` (metres, Z up, the face along -Y):

* the native ``.npz`` (:func:`.model.load_native`, format ``faces_hands.morph_model/1``);
* Basel Face Model 2009 ``.mat`` (``shapeMU``, ``shapePC``, ``shapeEV`` = standard deviations, ``texMU`` /
  ``texPC`` / ``texEV`` in 0..255, ``tl`` 1-based triangles; MATLAB v5, read by scipy);
* Basel Face Model 2017 / 2019 ``.h5`` (statismo layout: ``shape/model/mean``, ``pcaBasis``, ``pcaVariance``,
  ``shape/representer/cells``; ``color/...`` likewise; read by h5py);
* FLAME ``.npz`` conversions (``v_template``, ``f``, ``shapedirs`` (n, 3, 300 + 100): the 300 identity
  directions, scaled so a coefficient of 1 is one standard deviation). The original ``.pkl`` is refused:
  unpickling can run code;
* Surrey Face Model / eos ``.bin`` (cereal binary archive, MorphableModel versions 1-4: shape, colour,
  optional expression model, optional landmark names, texture coordinates).

Source axes are Y up, Z towards the viewer: ours ``(x, -z, y)``. Units are found from the size of the face
(millimetres, micrometres or metres) and said in ``model.info``.
"""
from __future__ import annotations

import json
import struct
import zipfile
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from .model import MorphableModel, PcaPart, load_native
from .segments import ROOT

__all__ = ["load_model", "SUFFIXES", "from_scaled_basis"]

SUFFIXES = (".npz", ".mat", ".h5", ".bin")
MAX_MODEL_BYTES = 4_000_000_000
Y_UP_TO_FH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def load_model(path: str | Path) -> MorphableModel:
    """Read a model file of any supported kind (module docstring); bad files raise UserError."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".pkl":
        raise UserError(f"{path.name}: FLAME .pkl files are not read (unpickling can run code); use a FLAME "
                        ".npz conversion (v_template, f, shapedirs)")
    if suffix not in SUFFIXES:
        raise UserError(f"{path.name}: use one of {', '.join(SUFFIXES)} (native, FLAME .npz, BFM .mat/.h5, eos .bin)")
    if path.stat().st_size > MAX_MODEL_BYTES:
        raise UserError(f"{path} is larger than 4 GB")
    if path.stat().st_size == 0:
        raise UserError(f"{path} is empty")
    reader = {".npz": _read_npz, ".mat": _read_bfm2009, ".h5": _read_statismo, ".bin": _read_eos}[suffix]
    try:
        model = reader(path)
    except UserError as error:
        if path.name in str(error):
            raise
        raise UserError(f"{path.name}: {error}") from None
    model.segments.setdefault(ROOT, np.ones(model.vertex_count, bool))
    return model.validate(str(path))


def _units(vertices: np.ndarray) -> tuple[float, str]:
    if not np.isfinite(vertices).all():
        raise UserError("the model's mean shape holds NaN or infinite coordinates; the file is damaged")
    extent = float(np.ptp(vertices, axis=0).max())
    for scale, name in ((1.0, "m"), (1e-2, "cm"), (1e-3, "mm"), (1e-6, "um")):
        if 0.05 <= extent * scale <= 0.6:
            return scale, name
    raise UserError(f"cannot tell the model's units: it is {extent:g} units across")


def _to_fh(vectors: np.ndarray, scale: float) -> np.ndarray:
    """(3n, ...) source coordinates -> ours, scaled, same layout."""
    shape = vectors.shape
    blocks = vectors.reshape(-1, 3, *shape[1:])
    return (scale * np.einsum("ij,vj...->vi...", Y_UP_TO_FH, blocks)).reshape(shape)


def from_scaled_basis(mean: np.ndarray, basis: np.ndarray, variances: np.ndarray) -> PcaPart:
    """A PCA part from ``mean + basis diag(sqrt(variances)) c``: kept as is when ``basis`` is orthonormal,
    else re-orthonormalised by an SVD of the scaled basis (same covariance, Eq. 3.2)."""
    mean, basis, variances = (np.asarray(a, np.float64) for a in (mean, basis, variances))
    if basis.ndim != 2 or basis.shape[0] != mean.shape[0] or variances.shape != (basis.shape[1],):
        raise UserError(f"the model's basis {basis.shape} does not fit its mean {mean.shape} and variances "
                        f"{variances.shape}")
    if not (np.isfinite(mean).all() and np.isfinite(basis).all() and np.isfinite(variances).all()):
        raise UserError("the model holds NaN or infinite numbers; the file is damaged")
    keep = variances > 0
    basis, variances = basis[:, keep], variances[keep]
    gram = basis.T @ basis
    if np.abs(gram - np.eye(len(gram))).max() < 1e-4:
        return PcaPart(mean, basis, np.sqrt(variances))
    u, singular, _ = np.linalg.svd(basis * np.sqrt(variances), full_matrices=False)
    keep = singular > 1e-12 * singular.max()
    return PcaPart(mean, u[:, keep], singular[keep])


def _model(path: Path, shape: PcaPart, triangles, colour: PcaPart | None, kind: str, units: str, **extra):
    return MorphableModel(name=path.stem, shape=shape, triangles=np.asarray(triangles, np.int64), colour=colour,
                          info={"source": kind, "file": path.name, "units": units, **extra.pop("info", {})}, **extra)


def _read_npz(path: Path) -> MorphableModel:
    try:
        with np.load(path, allow_pickle=False) as data:
            files = set(data.files)
            if "meta_json" in files:
                return load_native(path)
            if {"v_template", "f", "shapedirs"} <= files:
                return _flame(path, data["v_template"], data["f"], data["shapedirs"])
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
        raise UserError(f"{path.name}: not a readable .npz ({error})") from None
    raise UserError(f"{path.name}: an .npz that is neither a Faces & Hands model nor a FLAME conversion "
                    f"(has {', '.join(sorted(files)[:8])})")


def _flame(path: Path, template, triangles, directions) -> MorphableModel:
    template = np.asarray(template, np.float64)
    directions = np.asarray(directions, np.float64)
    if template.ndim != 2 or template.shape[1] != 3 or directions.shape[:2] != template.shape:
        raise UserError(f"{path.name}: FLAME arrays do not fit (v_template {template.shape}, shapedirs {directions.shape})")
    identity = directions[:, :, :min(300, directions.shape[2])]
    scale, units = _units(template)
    mean = _to_fh(template.reshape(-1), scale)
    basis = _to_fh(identity.reshape(-1, identity.shape[2]), scale)
    part = from_scaled_basis(mean, basis, np.ones(basis.shape[1]))
    return _model(path, part, triangles, None, "FLAME (.npz)", units,
                  info={"note": "identity directions only; FLAME's expression and pose parts are not used"})


def _read_bfm2009(path: Path) -> MorphableModel:
    from scipy.io import loadmat
    try:
        data = loadmat(str(path), variable_names=("shapeMU", "shapePC", "shapeEV", "texMU", "texPC", "texEV", "tl"))
    except Exception as error:  # scipy raises many kinds (IndexError, MatReadError, ...) on a foreign file
        raise UserError(f"{path.name}: not a readable MATLAB file ({type(error).__name__}: "
                        f"{(str(error).splitlines() or [''])[0]})") from None
    missing = [k for k in ("shapeMU", "shapePC", "shapeEV", "tl") if k not in data]
    if missing:
        raise UserError(f"{path.name}: not a Basel Face Model 2009 file (missing {', '.join(missing)})")
    mean = np.asarray(data["shapeMU"], np.float64).ravel()
    scale, units = _units(mean.reshape(-1, 3))
    shape = from_scaled_basis(_to_fh(mean, scale), _to_fh(np.asarray(data["shapePC"], np.float64), 1.0),
                              (scale * np.asarray(data["shapeEV"], np.float64).ravel()) ** 2)
    colour = None
    if all(k in data for k in ("texMU", "texPC", "texEV")):
        colour = from_scaled_basis(np.asarray(data["texMU"], np.float64).ravel() / 255.0,
                                   np.asarray(data["texPC"], np.float64),
                                   (np.asarray(data["texEV"], np.float64).ravel() / 255.0) ** 2)
    triangles = np.asarray(data["tl"], np.int64) - 1
    return _model(path, shape, triangles, colour, "Basel Face Model 2009 (.mat)", units)


def _read_statismo(path: Path) -> MorphableModel:
    try:
        import h5py
    except ImportError:
        raise UserError("reading .h5 models needs h5py, which this installation lacks; reinstall the extension") from None
    try:
        with h5py.File(path, "r") as file:
            if "shape" not in file or "model" not in file["shape"]:
                raise UserError(f"{path.name}: not a Basel Face Model 2017/2019 file (no shape/model group)")
            shape_group = file["shape"]
            mean = np.asarray(shape_group["model/mean"], np.float64).ravel()
            scale, units = _units(mean.reshape(-1, 3))
            shape = from_scaled_basis(_to_fh(mean, scale),
                                      _to_fh(np.asarray(shape_group["model/pcaBasis"], np.float64), 1.0),
                                      scale ** 2 * np.asarray(shape_group["model/pcaVariance"], np.float64).ravel())
            cells = np.asarray(shape_group["representer/cells"], np.int64)
            triangles = cells.T if cells.shape[0] == 3 and cells.shape[1] != 3 else cells
            colour = None
            if "color" in file and "model" in file["color"]:
                group = file["color/model"]
                colour = from_scaled_basis(np.asarray(group["mean"], np.float64).ravel(),
                                           np.asarray(group["pcaBasis"], np.float64),
                                           np.asarray(group["pcaVariance"], np.float64).ravel())
    except UserError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as error:
        raise UserError(f"{path.name}: not a readable Basel Face Model .h5 ({error})") from None
    return _model(path, shape, triangles, colour, "Basel Face Model 2017/2019 (.h5)", units)


class _Cereal:
    """A reader for cereal's binary archive as eos writes it (little-endian; sizes uint64; Eigen matrices
    as int32 rows, int32 cols, then column-major data)."""

    def __init__(self, path: Path):
        self.path, self.data, self.at = path, path.read_bytes(), 0

    def take(self, count: int) -> bytes:
        if count < 0 or self.at + count > len(self.data):
            raise UserError(f"{self.path.name}: the eos model file is truncated or not an eos .bin")
        chunk = self.data[self.at:self.at + count]
        self.at += count
        return chunk

    def unpack(self, fmt: str):
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def matrix(self, dtype=np.float32) -> np.ndarray:
        rows, cols = self.unpack("ii")
        if rows < 0 or cols < 0 or rows * cols > len(self.data):
            raise UserError(f"{self.path.name}: implausible matrix size {rows} x {cols}; the file is damaged")
        values = np.frombuffer(self.take(rows * cols * np.dtype(dtype).itemsize), dtype=dtype)
        return values.reshape(cols, rows).T.astype(np.float64)

    def size(self) -> int:
        (count,) = self.unpack("Q")
        if count > len(self.data):
            raise UserError(f"{self.path.name}: implausible element count {count}; the file is damaged")
        return count

    def array(self, fmt: str, width: int) -> np.ndarray:
        count = self.size()
        dtype = {"i": "<i4", "d": "<f8"}[fmt]
        return np.frombuffer(self.take(count * width * np.dtype(dtype).itemsize), dtype=dtype).reshape(count, width)

    def pca(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        mean, basis, eigenvalues = self.matrix().ravel(), self.matrix(), self.matrix().ravel()
        return mean, basis, eigenvalues, self.array("i", 3)

    def string(self) -> str:
        return self.take(self.size()).decode("utf-8", "replace")


def _read_eos(path: Path) -> MorphableModel:
    archive = _Cereal(path)
    (version,) = archive.unpack("I")
    if not 1 <= version <= 4:
        raise UserError(f"{path.name}: eos model version {version} is not read (1..4)")
    shape_mean, shape_basis, shape_ev, triangles = archive.pca()
    colour_mean, colour_basis, colour_ev, _ = archive.pca()
    landmarks = None
    if version >= 2 and archive.unpack("?")[0] is False:      # cereal optional: "nullopt" flag first
        (index,) = archive.unpack("i")
        if index == 0:
            archive.pca()
        else:
            for _ in range(archive.size()):
                archive.string()
                archive.matrix()
    if version >= 3 and archive.unpack("?")[0] is False:
        landmarks = {archive.string(): archive.unpack("i")[0] for _ in range(archive.size())}
    uvs = archive.array("d", 2) if archive.at < len(archive.data) else np.zeros((0, 2))
    if archive.at != len(archive.data) and version < 4:
        raise UserError(f"{path.name}: {len(archive.data) - archive.at} bytes left over; not an eos model of version {version}")
    if shape_mean.size == 0 or shape_mean.size % 3:
        raise UserError(f"{path.name}: the eos shape model is empty or not x, y, z per vertex")
    scale, units = _units(shape_mean.reshape(-1, 3))
    shape = from_scaled_basis(_to_fh(shape_mean, scale), _to_fh(shape_basis, 1.0), scale ** 2 * shape_ev)
    colour = (from_scaled_basis(colour_mean, colour_basis, colour_ev) if colour_mean.size else None)
    n = shape_mean.size // 3
    info = {"landmark_names": json.dumps(landmarks)} if landmarks else {}
    return _model(path, shape, triangles, colour, f"Surrey Face Model / eos (.bin, version {version})", units,
                  uvs=uvs if len(uvs) == n else None, info=info)
