# SPDX-License-Identifier: GPL-3.0-or-later
"""A take's clip written into a rig's still GLB: the file a take's export gives, without Blender sampling it.

A character's take export (skin with its fixed targets, armature, skin weights, materials) is the same on
every line of a jobs run; only the animation differs. Blender's glTF exporter writes the still part again on
each line (1.9 s on the default character: 211 morph targets over 13,886 vertices) and samples the clip by
evaluating the whole scene once per frame (2.3-3.1 s: the skin's targets and armature deform included).
Here the still part is exported once (Blender, no animation) and each line's clip goes in as plain data
from the engine (one-way: the bake's fitted weights and the take's head turn, never read back from
Blender): one ``weights`` channel for the skin (glTF morph weights, in the mesh's ``extras.targetNames``
order) and a ``rotation`` channel per turned bone, linear, one key per frame from 0 s. Bones that do not
move keep their node's rest transform (glTF needs no channel for them).

A bone node's rotation in the file is its rest rotation relative to its parent followed by the pose
rotation in its own rest frame (glTF ``rotation`` = parent-relative rest x pose basis, as Blender's exporter
writes a child bone); :func:`bone_rotations` gives the latter from the pose's Euler angles.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError

__all__ = ["Clip", "add_clip", "glb_parts", "glb_bytes", "euler_quaternions", "quaternion_product"]

_FLOAT = 5126
_GLB_MAGIC, _JSON, _BIN = b"glTF", 0x4E4F534A, 0x004E4942


@dataclass
class Clip:
    """One animation: ``times`` (T,) seconds from 0; ``weights``: mesh node name -> {target name: (T,)};
    ``rotations``: node name -> (T, 4) pose quaternions (w, x, y, z) in the node's rest frame."""
    name: str
    times: np.ndarray
    weights: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    rotations: dict[str, np.ndarray] = field(default_factory=dict)


def glb_parts(blob: bytes) -> tuple[dict, bytes]:
    """The JSON document and BIN chunk of GLB bytes ``blob`` (a file this extension exported)."""
    if len(blob) < 20 or blob[:4] != _GLB_MAGIC:
        raise UserError("not a GLB file")
    length = struct.unpack_from("<I", blob, 8)[0]
    offset, doc, binary = 12, None, b""
    while offset + 8 <= min(length, len(blob)):
        size, kind = struct.unpack_from("<II", blob, offset)
        chunk = blob[offset + 8:offset + 8 + size]
        if kind == _JSON and doc is None:
            doc = json.loads(chunk.decode("utf-8"))
        elif kind == _BIN and not binary:
            binary = bytes(chunk)
        offset += 8 + size
    if doc is None:
        raise UserError("the GLB has no JSON chunk")
    return doc, binary


def glb_bytes(doc: dict, binary: bytes) -> bytes:
    """GLB bytes of ``doc`` and ``binary`` (chunks padded to 4 bytes: JSON with spaces, BIN with zeros)."""
    text = json.dumps(doc, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    text += b" " * (-len(text) % 4)
    binary = binary + b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<I", len(text)) + struct.pack("<I", _JSON) + text
    if binary:
        chunks += struct.pack("<I", len(binary)) + struct.pack("<I", _BIN) + binary
    return struct.pack("<4sII", _GLB_MAGIC, 2, 12 + len(chunks)) + chunks


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of (..., 4) quaternions (w, x, y, z)."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, np.float64), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, np.float64), -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def euler_quaternions(angles: np.ndarray) -> np.ndarray:
    """(T, 4) quaternions (w, x, y, z) of (T, 3) XYZ Euler angles (Blender's order: X first, then Y, then Z;
    the rotation ``Rz @ Ry @ Rx`` of ``character.head.euler_matrix``)."""
    angles = np.asarray(angles, np.float64).reshape(-1, 3)
    half = angles / 2.0
    one = np.zeros((len(angles), 4))
    axes = []
    for axis in range(3):
        q = one.copy()
        q[:, 0] = np.cos(half[:, axis])
        q[:, axis + 1] = np.sin(half[:, axis])
        axes.append(q)
    return quaternion_product(axes[2], quaternion_product(axes[1], axes[0]))


def _node_index(doc: dict, name: str) -> int:
    found = [i for i, node in enumerate(doc.get("nodes", [])) if node.get("name") == name]
    if len(found) != 1:
        raise UserError(f"the still GLB has {len(found)} nodes named {name!r}, not one")
    return found[0]


class _Writer:
    """Appends float accessors to a document's one buffer."""

    def __init__(self, doc: dict, binary: bytes):
        self.doc, self.binary = doc, bytearray(binary + b"\0" * (-len(binary) % 4))
        if len(doc.get("buffers", [])) != 1:
            raise UserError("the still GLB must hold exactly one buffer")

    def accessor(self, values: np.ndarray, kind: str, bounds: bool = False) -> int:
        data = np.ascontiguousarray(values, dtype="<f4")
        views, accessors = self.doc.setdefault("bufferViews", []), self.doc.setdefault("accessors", [])
        views.append({"buffer": 0, "byteOffset": len(self.binary), "byteLength": data.nbytes})
        self.binary += data.tobytes()
        count = len(data) if kind == "SCALAR" and data.ndim == 1 else data.size // {"SCALAR": 1, "VEC4": 4}[kind]
        entry = {"bufferView": len(views) - 1, "componentType": _FLOAT, "count": int(count), "type": kind}
        if bounds:
            entry.update(min=[float(data.min())], max=[float(data.max())])
        accessors.append(entry)
        return len(accessors) - 1

    def finish(self) -> bytes:
        self.doc["buffers"][0]["byteLength"] = len(self.binary)
        return bytes(self.binary)


def add_clip(still: bytes, clip: Clip) -> bytes:
    """GLB bytes: ``still`` (a GLB without animation) with ``clip`` as its one animation (module docstring).
    Targets of a mesh that ``clip`` does not name keep the mesh's default weight; the mesh's default
    weights become the clip's first frame (what a client shows before it plays)."""
    doc, binary = glb_parts(still)
    times = np.asarray(clip.times, np.float64)
    if times.ndim != 1 or not len(times) or np.any(np.diff(times) <= 0) or times[0] < 0:
        raise UserError("a clip needs increasing key times from 0 s")
    writer = _Writer(doc, binary)
    time_accessor = writer.accessor(times.astype(np.float32), "SCALAR", bounds=True)
    channels, samplers = [], []

    def channel(node: int, path: str, output: int) -> None:
        samplers.append({"input": time_accessor, "interpolation": "LINEAR", "output": output})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    for node_name, by_target in sorted(clip.weights.items()):
        node = _node_index(doc, node_name)
        mesh = doc["meshes"][doc["nodes"][node]["mesh"]]
        names = list(mesh.get("extras", {}).get("targetNames", []))
        unknown = sorted(set(by_target) - set(names))
        if unknown:
            raise UserError(f"mesh {node_name!r} has no morph targets {', '.join(unknown[:5])}")
        default = np.asarray(mesh.get("weights", [0.0] * len(names)), np.float64)
        table = np.repeat(default[None, :], len(times), axis=0)
        for column, name in enumerate(names):
            if name in by_target:
                values = np.asarray(by_target[name], np.float64)
                if values.shape != times.shape:
                    raise UserError(f"target {name!r}: {values.shape[0]} values for {len(times)} key times")
                table[:, column] = values
        table = table.astype(np.float32)
        mesh["weights"] = [float(v) for v in table[0]]
        channel(node, "weights", writer.accessor(table.ravel(), "SCALAR"))
    for node_name, pose in sorted(clip.rotations.items()):
        node = _node_index(doc, node_name)
        pose = np.asarray(pose, np.float64)
        if pose.shape != (len(times), 4):
            raise UserError(f"bone {node_name!r}: rotations of shape {pose.shape} for {len(times)} key times")
        x, y, z, w = doc["nodes"][node].get("rotation", [0.0, 0.0, 0.0, 1.0])
        turned = quaternion_product(np.array([w, x, y, z]), pose)
        turned /= np.linalg.norm(turned, axis=1, keepdims=True)
        channel(node, "rotation", writer.accessor(turned[:, [1, 2, 3, 0]], "VEC4"))
    doc["animations"] = [{"name": clip.name, "channels": channels, "samplers": samplers}]
    return glb_bytes(doc, writer.finish())
