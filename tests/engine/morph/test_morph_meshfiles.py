"""Build Model from a folder (5.1.10): OBJ and PLY (ASCII and binary) examples written by the test, the
labels CSV, and the refusals (another topology, truncated PLY, missing rows)."""
from __future__ import annotations

import struct

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.morph import build, meshfiles

TRIANGLES = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 2], [2, 4, 5], [3, 2, 5]])


def _vertices(seed):
    base = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], float) * 0.05
    return base + 0.002 * np.random.default_rng(seed).standard_normal(base.shape)


def _obj(path, vertices, triangles=TRIANGLES):
    lines = [f"v {x} {y} {z}" for x, y, z in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles]
    path.write_text("\n".join(lines) + "\n")


def _ply_binary(path, vertices, triangles=TRIANGLES):
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(vertices)}\nproperty float x\n"
              f"property float y\nproperty float z\nelement face {len(triangles)}\n"
              "property list uchar int vertex_indices\nend_header\n").encode()
    body = np.asarray(vertices, "<f4").tobytes()
    body += b"".join(struct.pack("<B3i", 3, *t) for t in triangles)
    path.write_bytes(header + body)


def _ply_ascii(path, vertices, triangles=TRIANGLES):
    text = (f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(triangles)}\nproperty list uchar int vertex_indices\nend_header\n")
    text += "".join(f"{x} {y} {z}\n" for x, y, z in vertices) + "".join(f"3 {a} {b} {c}\n" for a, b, c in triangles)
    path.write_text(text)


def test_folder_of_obj_and_ply_builds_a_model_with_labels(tmp_path):
    examples = [_vertices(i) for i in range(4)]
    _obj(tmp_path / "a.obj", examples[0])
    _ply_binary(tmp_path / "b.ply", examples[1])
    _ply_ascii(tmp_path / "c.ply", examples[2])
    _ply_binary(tmp_path / "d.ply", examples[3])
    names, shapes, triangles = meshfiles.read_example_folder(tmp_path)
    assert names == ["a", "b", "c", "d"] and np.array_equal(triangles, TRIANGLES)
    assert np.allclose(shapes[0], examples[0] @ np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]).T)  # OBJ: Y up
    assert np.allclose(shapes[1], examples[1], atol=1e-7) and np.allclose(shapes[2], examples[2], atol=1e-7)
    labels, rows = build.read_labels_csv("name,weight\na,1\nb,2\nc,3\nd,5\n", names)
    model = build.build_model("folder", shapes, triangles, labels=labels, example_names=names, example_labels=rows)
    assert model.shape.components == 3 and "weight" in model.attributes


def test_folder_refusals(tmp_path):
    for i in range(3):
        _ply_binary(tmp_path / f"m{i}.ply", _vertices(i))
    _ply_binary(tmp_path / "z.ply", np.vstack([_vertices(9), [[0.3, 0.3, 0.0]]]))
    with pytest.raises(UserError, match="z.ply has another topology"):
        meshfiles.read_example_folder(tmp_path)
    (tmp_path / "z.ply").write_bytes((tmp_path / "m0.ply").read_bytes()[:-20])
    with pytest.raises(UserError, match="truncated or malformed"):
        meshfiles.read_example_folder(tmp_path)
    with pytest.raises(UserError, match="has no .obj or .ply"):
        (tmp_path / "empty").mkdir()
        meshfiles.read_example_folder(tmp_path / "empty")
