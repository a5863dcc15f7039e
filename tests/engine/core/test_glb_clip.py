"""A take's clip written into a still GLB (anim.glb_clip): the layout glTF clients read, checked by hand on a
tiny file, and the pose quaternions against the Euler matrices the character's drivers use."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from faces_hands_addon.anim.glb_clip import Clip, add_clip, euler_quaternions, glb_bytes, glb_parts
from faces_hands_addon.character.head import euler_matrix
from faces_hands_addon.core.errors import UserError

REST = [0.0, 0.0, np.sin(0.25), np.cos(0.25)]          # x, y, z, w: half a radian about z


def _still() -> bytes:
    positions = np.zeros((3, 3), "<f4").tobytes()
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
           "nodes": [{"name": "Body", "mesh": 0}, {"name": "head", "rotation": REST}],
           "meshes": [{"name": "Body", "weights": [0.0, 0.5, 0.0],
                       "extras": {"targetNames": ["jawOpen", "kept", "mouthClose"]},
                       "primitives": [{"attributes": {"POSITION": 0}}]}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                          "min": [0, 0, 0], "max": [0, 0, 0]}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(positions)}],
           "buffers": [{"byteLength": len(positions)}]}
    return glb_bytes(doc, positions)


def _accessor(doc, binary, index):
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC4": 4, "VEC3": 3}[a["type"]]
    assert view["byteOffset"] % 4 == 0 and a["componentType"] == 5126
    return np.frombuffer(binary, "<f4", a["count"] * width, view["byteOffset"]).reshape(a["count"], width)


def _quat_matrix(w, x, y, z):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_euler_quaternions_turn_as_blenders_xyz_euler_matrices():
    rng = np.random.default_rng(5)
    angles = rng.uniform(-1.2, 1.2, (20, 3))
    for angle, q in zip(angles, euler_quaternions(angles)):
        np.testing.assert_allclose(_quat_matrix(*q), euler_matrix(angle)[:3, :3], atol=1e-12)


def test_the_clip_is_written_where_clients_read_it():
    times = np.array([0.0, 1 / 30, 2 / 30])
    pose = euler_quaternions(np.array([[0, 0, 0], [0.1, 0, 0], [0.2, -0.1, 0.05]]))
    clip = Clip("line1", times, {"Body": {"jawOpen": np.array([0.0, 0.5, 1.0]), "mouthClose": np.array([0.2, 0.1, 0.0])}},
                {"head": pose})
    blob = add_clip(_still(), clip)
    assert add_clip(_still(), clip) == blob                          # same input, same bytes
    assert struct.unpack_from("<I", blob, 8)[0] == len(blob)
    doc, binary = glb_parts(blob)
    assert doc["buffers"][0]["byteLength"] == len(binary)
    animation = doc["animations"][0]
    assert animation["name"] == "line1" and len(animation["channels"]) == 2
    by_path = {c["target"]["path"]: animation["samplers"][c["sampler"]] for c in animation["channels"]}
    np.testing.assert_allclose(_accessor(doc, binary, by_path["weights"]["input"]).ravel(), times, atol=1e-7)
    assert doc["accessors"][by_path["weights"]["input"]]["max"] == [pytest.approx(2 / 30)]
    weights = _accessor(doc, binary, by_path["weights"]["output"]).reshape(3, 3)      # frame-major
    np.testing.assert_allclose(weights, [[0.0, 0.5, 0.2], [0.5, 0.5, 0.1], [1.0, 0.5, 0.0]], atol=1e-7)
    assert doc["meshes"][0]["weights"] == pytest.approx([0.0, 0.5, 0.2])             # the first frame
    rotation = _accessor(doc, binary, by_path["rotation"]["output"])
    rest = _quat_matrix(REST[3], *REST[:3])
    for q, expected in zip(rotation, pose):
        np.testing.assert_allclose(_quat_matrix(q[3], *q[:3]), rest @ _quat_matrix(*expected), atol=1e-6)
    assert all(a["interpolation"] == "LINEAR" for a in animation["samplers"])
    assert json.dumps(doc["nodes"][1]["rotation"]) == json.dumps(REST)              # the rest is kept


@pytest.mark.parametrize("clip, message", [
    (Clip("x", np.array([0.0, 0.1]), {"Body": {"smile": np.zeros(2)}}), "no morph targets smile"),
    (Clip("x", np.array([0.0, 0.1]), {"Body": {"jawOpen": np.zeros(3)}}), "3 values for 2 key times"),
    (Clip("x", np.array([0.1, 0.1])), "increasing key times"),
    (Clip("x", np.array([0.0, 0.1]), rotations={"neck": np.zeros((2, 4))}), "0 nodes named 'neck'"),
    (Clip("x", np.array([0.0, 0.1]), rotations={"head": np.zeros((3, 4))}), "for 2 key times"),
])
def test_a_clip_that_does_not_fit_the_file_is_refused(clip, message):
    with pytest.raises(UserError, match=message):
        add_clip(_still(), clip)


def test_not_a_glb_is_refused():
    with pytest.raises(UserError, match="not a GLB"):
        glb_parts(b"PK\x03\x04" + bytes(40))
