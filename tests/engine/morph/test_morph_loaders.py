"""Every loader on small synthetic files written by the test itself in that format (native .npz, BFM 2009
.mat, BFM 2017 .h5, FLAME .npz, eos .bin), and the bad inputs: truncated, wrong format, NaN, pickles."""
from __future__ import annotations

import struct

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.morph import build, loaders, model as model_module

N_VERTICES, K = 30, 5


def _source(seed=0, scale=1000.0):
    """A small model in source conventions (Y up, Z to the viewer, millimetres)."""
    rng = np.random.default_rng(seed)
    mean = (rng.uniform(-70, 70, (N_VERTICES, 3)) * np.array([1.0, 1.3, 0.4])) * scale / 1000.0
    basis, _ = np.linalg.qr(rng.standard_normal((3 * N_VERTICES, K)))
    sd = np.array([5.0, 3.0, 2.0, 1.0, 0.5]) * scale / 1000.0
    triangles = np.array([[i, i + 1, i + 2] for i in range(N_VERTICES - 2)])
    return mean, basis, sd, triangles


def _expected_mean(mean, scale):
    return (mean @ loaders.Y_UP_TO_FH.T) * scale


def _check(loaded, mean, sd, scale):
    assert loaded.vertex_count == N_VERTICES
    assert np.allclose(loaded.mean_vertices(), _expected_mean(mean, scale), atol=1e-9)
    assert np.allclose(np.sort(loaded.shape.sd), np.sort(sd * scale), rtol=1e-5)


def test_native_round_trip_is_exact_and_deterministic(tmp_path):
    rng = np.random.default_rng(0)
    shapes = rng.standard_normal((8, N_VERTICES, 3)) * 0.01
    model = build.build_model("native", shapes, _source()[3], shapes * 0 + 0.5 + 0.01 * rng.standard_normal(shapes.shape),
                              labels={"a": rng.standard_normal(8)}, segments={"face": np.ones(N_VERTICES, bool)})
    first, second = tmp_path / "a.npz", tmp_path / "b.npz"
    model_module.save_model(model, first)
    model_module.save_model(model, second)
    assert first.read_bytes() == second.read_bytes()
    loaded = loaders.load_model(first)
    assert np.array_equal(loaded.shape.basis, model.shape.basis)
    assert np.array_equal(loaded.attributes["a"].colour, model.attributes["a"].colour)
    assert loaded.example_names == model.example_names


def test_bfm2009_mat(tmp_path):
    from scipy.io import savemat
    mean, basis, sd, triangles = _source(1, scale=1e6)          # BFM 2009 is in micrometres
    path = tmp_path / "01_MorphableModel.mat"
    savemat(path, {"shapeMU": mean.reshape(-1, 1), "shapePC": basis, "shapeEV": sd.reshape(-1, 1),
                   "texMU": np.full((3 * N_VERTICES, 1), 128.0), "texPC": basis, "texEV": np.ones((K, 1)) * 10,
                   "tl": triangles + 1})
    loaded = loaders.load_model(path)
    _check(loaded, mean, sd, 1e-6)
    assert loaded.info["units"] == "um" and np.array_equal(loaded.triangles, triangles)
    assert np.allclose(loaded.colour.mean, 128 / 255) and np.allclose(loaded.colour.sd, 10 / 255)


def test_bfm2017_h5(tmp_path):
    h5py = pytest.importorskip("h5py")
    mean, basis, sd, triangles = _source(2)
    path = tmp_path / "model2017-1_face12_nomouth.h5"
    with h5py.File(path, "w") as file:
        file["shape/model/mean"] = mean.ravel().astype(np.float32)
        file["shape/model/pcaBasis"] = basis.astype(np.float32)
        file["shape/model/pcaVariance"] = (sd ** 2).astype(np.float32)
        file["shape/representer/cells"] = triangles.T.astype(np.uint32)
        file["color/model/mean"] = np.full(3 * N_VERTICES, 0.6, np.float32)
        file["color/model/pcaBasis"] = basis.astype(np.float32)
        file["color/model/pcaVariance"] = np.full(K, 0.01, np.float32)
    loaded = loaders.load_model(path)
    _check(loaded, mean, sd, 1e-3)
    assert np.array_equal(loaded.triangles, triangles) and loaded.colour.components == K


def test_flame_npz_conversion(tmp_path):
    mean, basis, sd, triangles = _source(3, scale=1.0)            # FLAME is in metres
    directions = (basis * sd).reshape(N_VERTICES, 3, K)
    path = tmp_path / "generic_model.npz"
    np.savez(path, v_template=mean, f=triangles, shapedirs=np.concatenate([directions, directions[:, :, :2]], 2))
    loaded = loaders.load_model(path)
    assert loaded.info["units"] == "m"
    assert np.allclose(loaded.mean_vertices(), _expected_mean(mean, 1.0))
    assert loaded.shape.components <= K + 2
    pkl = tmp_path / "generic_model.pkl"
    pkl.write_bytes(b"\x80\x02cos\nsystem\n.")
    with pytest.raises(UserError, match="not read"):
        loaders.load_model(pkl)


def _eos_bytes(mean, basis, eigenvalues, triangles, version=4, landmarks=None, uvs=None):
    def matrix(values):
        values = np.atleast_2d(np.asarray(values, np.float32))
        values = values.T if values.shape[0] == 1 else values
        return struct.pack("<ii", *values.shape) + np.asfortranarray(values).tobytes(order="F")

    def pca(m, b, e, t):
        return (matrix(m.reshape(-1, 1)) + matrix(b) + matrix(e.reshape(-1, 1)) + struct.pack("<Q", len(t))
                + np.asarray(t, "<i4").tobytes())

    out = struct.pack("<I", version) + pca(mean.ravel(), basis, eigenvalues, triangles)
    out += pca(np.zeros(0), np.zeros((0, 0)), np.zeros(0), [])
    if version >= 2:
        out += struct.pack("<?", True)                            # no expression model
    if version >= 3:
        if landmarks:
            out += struct.pack("<?", False) + struct.pack("<Q", len(landmarks))
            for name, index in landmarks.items():
                out += struct.pack("<Q", len(name)) + name.encode() + struct.pack("<i", index)
        else:
            out += struct.pack("<?", True)
    uvs = np.zeros((len(mean), 2)) if uvs is None else uvs
    out += struct.pack("<Q", len(uvs)) + np.asarray(uvs, "<f8").tobytes()
    if version >= 4:
        out += struct.pack("<Q", 0)
    return out


def test_eos_bin(tmp_path):
    mean, basis, sd, triangles = _source(4)
    path = tmp_path / "sfm_shape_3448.bin"
    uvs = np.random.default_rng(0).random((N_VERTICES, 2))
    path.write_bytes(_eos_bytes(mean, basis, sd ** 2, triangles, landmarks={"center.nose.tip": 3}, uvs=uvs))
    loaded = loaders.load_model(path)
    _check(loaded, mean, sd, 1e-3)
    assert "center.nose.tip" in loaded.info["landmark_names"] and np.allclose(loaded.uvs, uvs)
    truncated = tmp_path / "truncated.bin"
    truncated.write_bytes(path.read_bytes()[:-400])
    with pytest.raises(UserError, match="truncated"):
        loaders.load_model(truncated)


def test_bad_files_are_refused_with_a_clear_message(tmp_path):
    mean, basis, sd, triangles = _source(5)
    good = tmp_path / "good.npz"
    np.savez(good, v_template=mean, f=triangles, shapedirs=(basis * sd).reshape(N_VERTICES, 3, K))
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(UserError, match="not a readable .npz"):
        loaders.load_model(truncated)
    wrong = tmp_path / "wrong.mat"
    wrong.write_text("hello, I am no MATLAB file")
    with pytest.raises(UserError, match="wrong.mat"):
        loaders.load_model(wrong)
    nan = tmp_path / "nan.npz"
    poisoned = mean.copy()
    poisoned[4, 1] = np.nan
    np.savez(nan, v_template=poisoned, f=triangles, shapedirs=(basis * sd).reshape(N_VERTICES, 3, K))
    with pytest.raises(UserError, match="nan.npz: .*NaN"):
        loaders.load_model(nan)
    other = tmp_path / "other.npz"
    np.savez(other, weights=np.ones(3))
    with pytest.raises(UserError, match="neither a Faces & Hands model nor a FLAME"):
        loaders.load_model(other)
    for name, message in (("model.obj", "use one of"), ("missing.npz", "does not exist")):
        if name == "model.obj":
            (tmp_path / name).write_text("v 0 0 0")
        with pytest.raises(UserError, match=message):
            loaders.load_model(tmp_path / name)
