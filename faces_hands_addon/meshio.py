# SPDX-License-Identifier: GPL-3.0-or-later
"""Generic, numpy-only readers for Wavefront OBJ, STL (binary and ASCII) and glTF 2.0 binary (GLB).

No ``bpy``: the engine reads files itself so the same code serves the add-on, batch runs and tests.
Readers return arrays in the FILE's own units and axes; ``faces_hands_addon.assets`` converts the
default assets to the project convention (metres, Z up, face looking along -Y). Anything malformed or
truncated raises :class:`~faces_hands_addon.errors.UserError` naming the file, never a raw
``struct.error`` / ``IndexError``.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .core.errors import UserError


@dataclass
class ObjData:
    """A polygon mesh read from OBJ. ``faces`` are triangles (polygons fan-triangulated).

    ``uvs``/``face_uvs`` are present when the file has ``vt`` entries: ``uvs[face_uvs[i, k]]`` is the
    texture coordinate of corner ``k`` of triangle ``i``. ``vertex_uvs`` is set when every vertex uses
    one texture coordinate only (as in the MediaPipe canonical face).
    """
    vertices: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None = None
    face_uvs: np.ndarray | None = None
    vertex_uvs: np.ndarray | None = None


def _bad(path: Path, what: str) -> UserError:
    return UserError(f"{Path(path).name}: {what}; re-extract the assets (`make assets`) or pick a valid file")


def read_obj(path: str | Path) -> ObjData:
    """Read ``v``, ``vt`` and ``f`` records of a Wavefront OBJ (1-based or negative indices)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise _bad(path, f"cannot read as UTF-8 text ({exc.__class__.__name__})") from None
    verts: list[list[float]] = []
    uvs: list[list[float]] = []
    tri_v: list[list[int]] = []
    tri_t: list[list[int]] = []
    for number, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        try:
            if parts[0] == "v":
                verts.append([float(p) for p in parts[1:4]])
                if len(verts[-1]) != 3:
                    raise ValueError("a vertex needs 3 coordinates")
            elif parts[0] == "vt":
                uvs.append([float(p) for p in parts[1:3]])
                if len(uvs[-1]) != 2:
                    raise ValueError("a texture coordinate needs 2 values")
            elif parts[0] == "f":
                corners = [c.split("/") for c in parts[1:]]
                if len(corners) < 3:
                    raise ValueError("a face needs at least 3 corners")
                vi = [_obj_index(c[0], len(verts)) for c in corners]
                ti = ([_obj_index(c[1], len(uvs)) for c in corners]
                      if all(len(c) > 1 and c[1] for c in corners) else None)
                for k in range(1, len(vi) - 1):
                    tri_v.append([vi[0], vi[k], vi[k + 1]])
                    if ti is not None:
                        tri_t.append([ti[0], ti[k], ti[k + 1]])
        except (ValueError, IndexError) as exc:
            raise _bad(path, f"line {number}: {exc}") from None
    if not verts or not tri_v:
        raise _bad(path, "no vertices or no faces (empty or truncated OBJ)")
    data = ObjData(np.asarray(verts, dtype=np.float64), np.asarray(tri_v, dtype=np.int64))
    if uvs and len(tri_t) == len(tri_v):
        data.uvs = np.asarray(uvs, dtype=np.float64)
        data.face_uvs = np.asarray(tri_t, dtype=np.int64)
        per_vertex = np.full(len(verts), -1, dtype=np.int64)
        per_vertex[data.faces.ravel()] = data.face_uvs.ravel()
        if (per_vertex[data.faces.ravel()] == data.face_uvs.ravel()).all() and (per_vertex >= 0).all():
            data.vertex_uvs = data.uvs[per_vertex]
    return data


def _obj_index(token: str, count: int) -> int:
    index = int(token)
    index = index - 1 if index > 0 else count + index
    if not 0 <= index < count:
        raise IndexError(f"index {token} refers to an element not defined before it")
    return index


# ------------------------------------------------------------------------------------------ STL

_STL_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])


def read_stl(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a binary or ASCII STL -> ``(vertices (N,3) float64, faces (M,3) int64)``.

    STL stores three corners per triangle; exactly equal corners are merged into one vertex
    (vertices keep the order of their first appearance). Triangles that collapse to fewer than three
    distinct vertices are dropped.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _bad(path, f"cannot read ({exc.strerror})") from None
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count and count > 0:
            corners = np.frombuffer(data, _STL_RECORD, count=count, offset=84)["corners"]
            return _merge_corners(path, corners.reshape(-1, 3).astype(np.float64))
    if data.lstrip()[:5].lower() == b"solid" and b"facet" in data:
        return _merge_corners(path, _ascii_stl_corners(path, data))
    if len(data) >= 84:
        raise _bad(path, f"binary STL of {len(data)} bytes cannot hold the {count} triangles its header "
                         "announces (truncated?)")
    raise _bad(path, "too short to be an STL file")


def _ascii_stl_corners(path: Path, data: bytes) -> np.ndarray:
    try:
        tokens = data.decode("ascii").split()
    except UnicodeDecodeError:
        raise _bad(path, "ASCII STL with non-ASCII bytes") from None
    values = []
    for i, token in enumerate(tokens):
        if token == "vertex":
            try:
                values.append([float(t) for t in tokens[i + 1:i + 4]])
            except ValueError:
                raise _bad(path, "malformed 'vertex' line in ASCII STL") from None
            if len(values[-1]) != 3:
                raise _bad(path, "ASCII STL ends inside a 'vertex' line (truncated?)")
    if not values or len(values) % 3 or tokens.count("endfacet") * 3 != len(values):
        raise _bad(path, "ASCII STL with incomplete facets (truncated?)")
    return np.asarray(values, dtype=np.float64)


def _merge_corners(path: Path, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if not np.isfinite(corners).all():
        raise _bad(path, "STL with non-finite coordinates")
    unique, first, inverse = np.unique(corners, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")      # renumber by first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    faces = rank[inverse.reshape(-1)].reshape(-1, 3).astype(np.int64)
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    return unique[order], faces[keep]


# ------------------------------------------------------------------------------------------ GLB

@dataclass
class GltfNode:
    name: str
    parent: int                      # index into GlbData.nodes, -1 for a root
    matrix: np.ndarray               # 4x4 local rest transform (file axes)
    mesh: int | None = None
    skin: int | None = None
    children: list[int] = field(default_factory=list)


@dataclass
class GltfPrimitive:
    positions: np.ndarray            # (N,3) float64
    indices: np.ndarray              # (M,3) int64
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None    # glTF convention: v runs downwards
    joints: np.ndarray | None = None  # (N,4) int64, indices into the skin's joint list
    weights: np.ndarray | None = None  # (N,4) float64


@dataclass
class GltfSkin:
    joints: list[int]                # node indices
    inverse_bind: np.ndarray         # (J,4,4)


@dataclass
class GlbData:
    nodes: list[GltfNode]
    meshes: list[list[GltfPrimitive]]
    skins: list[GltfSkin]

    def world_matrix(self, index: int) -> np.ndarray:
        """Rest transform of node ``index`` in the file's world frame (parents applied)."""
        matrix = self.nodes[index].matrix
        parent = self.nodes[index].parent
        while parent >= 0:
            matrix = self.nodes[parent].matrix @ matrix
            parent = self.nodes[parent].parent
        return matrix


_COMPONENTS = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def read_glb(path: str | Path) -> GlbData:
    """Minimal glTF 2.0 binary reader: triangle meshes, skins and the node hierarchy.

    Supports what skinned character assets use (accessors over the GLB BIN chunk, interleaved or
    not, normalized integers, TRS or matrix nodes); rejects sparse accessors, external buffers and
    non-triangle primitives with a :class:`UserError`.
    """
    path = Path(path)
    try:
        blob = path.read_bytes()
    except OSError as exc:
        raise _bad(path, f"cannot read ({exc.strerror})") from None
    try:
        return _parse_glb(path, blob)
    except UserError:
        raise
    except (struct.error, KeyError, IndexError, ValueError, TypeError) as exc:
        raise _bad(path, f"malformed or truncated GLB ({exc.__class__.__name__}: {exc})") from None


def glb_document(path: str | Path) -> dict:
    """The JSON document of a GLB file (e.g. to list its morph targets and animations)."""
    path = Path(path)
    try:
        return _glb_chunks(path, path.read_bytes())[0]
    except OSError as exc:
        raise _bad(path, f"cannot read ({exc.strerror})") from None
    except (struct.error, KeyError, ValueError, UnicodeDecodeError) as exc:
        raise _bad(path, f"malformed or truncated GLB ({exc.__class__.__name__}: {exc})") from None


def _glb_chunks(path: Path, blob: bytes) -> tuple[dict, bytes]:
    """The JSON document and the binary chunk of a GLB file (header and chunk sizes checked)."""
    if len(blob) < 20:
        raise _bad(path, "too short to be a GLB file")
    magic, version, length = struct.unpack_from("<III", blob, 0)
    if magic != 0x46546C67 or version != 2:
        raise _bad(path, "not a glTF 2.0 binary (bad magic or version)")
    if length != len(blob):
        raise _bad(path, f"GLB header announces {length} bytes but the file has {len(blob)} (truncated?)")
    chunks, offset = {}, 12
    while offset < length:
        size, kind = struct.unpack_from("<II", blob, offset)
        if offset + 8 + size > length:
            raise _bad(path, "GLB chunk runs past the end of the file (truncated?)")
        chunks.setdefault(kind, blob[offset + 8:offset + 8 + size])
        offset += 8 + size
    gltf = json.loads(chunks[0x4E4F534A].decode("utf-8"))
    for buffer in gltf.get("buffers", []):
        if "uri" in buffer:
            raise _bad(path, "external buffers are not supported (GLB with embedded BIN only)")
    return gltf, chunks.get(0x004E4942, b"")


def _accessor(path: Path, gltf: dict, binary: bytes, index: int) -> np.ndarray:
    """Accessor ``index`` as a (count, width) array (strides honoured, bounds checked)."""
    acc = gltf["accessors"][index]
    if "sparse" in acc:
        raise _bad(path, "sparse accessors are not supported")
    dtype = np.dtype(_COMPONENTS[acc["componentType"]])
    width, count = _WIDTH[acc["type"]], acc["count"]
    view = gltf["bufferViews"][acc["bufferView"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride") or width * dtype.itemsize
    end = start + stride * (count - 1) + width * dtype.itemsize
    if count < 1 or end > len(binary) or end > view.get("byteOffset", 0) + view["byteLength"]:
        raise _bad(path, f"accessor {index} reaches past its buffer (truncated?)")
    raw = np.lib.stride_tricks.as_strided(
        np.frombuffer(binary, np.uint8, count=end - start, offset=start),
        shape=(count, width * dtype.itemsize), strides=(stride, 1))
    values = np.ascontiguousarray(raw).view(dtype).reshape(count, width)
    if acc.get("normalized") and dtype.kind in "iu":
        values = values.astype(np.float64) / np.iinfo(dtype).max
    return values


def _primitive(path: Path, prim: dict, accessor) -> GltfPrimitive:
    if prim.get("mode", 4) != 4:
        raise _bad(path, "only triangle primitives are supported")
    attrs = prim["attributes"]
    positions = accessor(attrs["POSITION"]).astype(np.float64)
    if "indices" in prim:
        flat = accessor(prim["indices"]).astype(np.int64).ravel()
    else:
        flat = np.arange(len(positions), dtype=np.int64)
    if len(flat) % 3 or (len(flat) and (flat.min() < 0 or flat.max() >= len(positions))):
        raise _bad(path, "triangle indices out of range")
    p = GltfPrimitive(positions, flat.reshape(-1, 3))
    if "NORMAL" in attrs:
        p.normals = accessor(attrs["NORMAL"]).astype(np.float64)
    if "TEXCOORD_0" in attrs:
        p.uvs = accessor(attrs["TEXCOORD_0"]).astype(np.float64)
    if "JOINTS_0" in attrs:
        p.joints = accessor(attrs["JOINTS_0"]).astype(np.int64)
        p.weights = accessor(attrs["WEIGHTS_0"]).astype(np.float64)
    return p


def _parse_glb(path: Path, blob: bytes) -> GlbData:
    gltf, binary = _glb_chunks(path, blob)

    def accessor(index: int) -> np.ndarray:
        return _accessor(path, gltf, binary, index)

    nodes = []
    for i, node in enumerate(gltf.get("nodes", [])):
        nodes.append(GltfNode(node.get("name", f"node{i}"), -1, _node_matrix(node),
                              node.get("mesh"), node.get("skin"), list(node.get("children", []))))
    for i, node in enumerate(nodes):
        for child in node.children:
            nodes[child].parent = i
    meshes = [[_primitive(path, prim, accessor) for prim in mesh["primitives"]] for mesh in gltf.get("meshes", [])]
    skins = []
    for skin in gltf.get("skins", []):
        joints = list(skin["joints"])
        if "inverseBindMatrices" in skin:
            inverse_bind = accessor(skin["inverseBindMatrices"]).astype(np.float64)
            inverse_bind = inverse_bind.reshape(-1, 4, 4).transpose(0, 2, 1)  # column-major
        else:
            inverse_bind = np.tile(np.eye(4), (len(joints), 1, 1))
        skins.append(GltfSkin(joints, inverse_bind))
    return GlbData(nodes, meshes, skins)


def _node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", (0.0, 0.0, 0.0, 1.0))
    rot = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    matrix = np.eye(4)
    matrix[:3, :3] = rot * np.asarray(node.get("scale", (1.0, 1.0, 1.0)), dtype=np.float64)
    matrix[:3, 3] = node.get("translation", (0.0, 0.0, 0.0))
    return matrix
