# SPDX-License-Identifier: GPL-3.0-or-later
"""Example meshes for "Build Model from Meshes" (5.1.10): a folder of OBJ or PLY files of one topology,
read as Blender's importers would place them (OBJ: Y up -> Z up; PLY: as written)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..meshio import read_obj

__all__ = ["read_example_folder", "read_ply"]

_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
              "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
              "int32": "i4", "uint32": "u4", "float32": "f4", "float64": "f8"}


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (x, y, z) and triangles of an ASCII or binary little-endian PLY file."""
    data = path.read_bytes()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply") or end < 0:
        raise UserError(f"{path.name}: not a PLY file")
    header = data[:end].decode("ascii", "replace").splitlines()
    body = data[end + len(b"end_header\n"):]
    fmt = next((line.split()[1] for line in header if line.startswith("format")), "")
    elements, current = [], None
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            current = [words[1], int(words[2]), []]
            elements.append(current)
        elif words[:1] == ["property"] and current is not None:
            current[2].append(words[1:])
    try:
        if fmt == "ascii":
            return _ply_ascii(body, elements)
        if fmt == "binary_little_endian":
            return _ply_binary(body, elements)
    except (ValueError, IndexError, KeyError):
        raise UserError(f"{path.name}: the PLY data is truncated or malformed") from None
    raise UserError(f"{path.name}: PLY format {fmt!r} is not read (ascii or binary_little_endian)")


def _ply_ascii(body: bytes, elements) -> tuple[np.ndarray, np.ndarray]:
    lines = iter(body.decode("ascii").splitlines())
    vertices = faces = None
    for name, count, properties in elements:
        rows = [next(lines).split() for _ in range(count)]
        if name == "vertex":
            names = [p[-1] for p in properties]
            vertices = np.array([[float(r[names.index(a)]) for a in "xyz"] for r in rows])
        elif name == "face":
            faces = np.array([[int(v) for v in r[1:4]] for r in rows if r[0] == "3"])
    return vertices, faces


def _ply_binary(body: bytes, elements) -> tuple[np.ndarray, np.ndarray]:
    at, vertices, faces = 0, None, None
    for name, count, properties in elements:
        if properties and properties[0][0] == "list":
            count_type, index_type = _PLY_TYPES[properties[0][1]], _PLY_TYPES[properties[0][2]]
            row = np.dtype([("n", count_type), ("v", index_type, 3)])
            table = np.frombuffer(body, row, count, at)
            if (table["n"] != 3).any():
                raise ValueError("only triangles")
            faces, at = table["v"].astype(np.int64), at + row.itemsize * count
        else:
            row = np.dtype([(p[-1], _PLY_TYPES[p[0]]) for p in properties]).newbyteorder("<")
            table = np.frombuffer(body, row, count, at)
            if name == "vertex":
                vertices = np.stack([table[a].astype(np.float64) for a in "xyz"], axis=1)
            at += row.itemsize * count
    return vertices, faces


def read_example_folder(folder: str | Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Names (file stems), vertices (N, n, 3) and the triangles of every OBJ/PLY file in ``folder``
    (sorted by name); every file must have the first file's vertex count and triangles."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"{folder} is not a folder")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".obj", ".ply"))
    if not files:
        raise UserError(f"{folder} has no .obj or .ply files")
    names, shapes, triangles = [], [], None
    for path in files:
        if path.suffix.lower() == ".obj":
            obj = read_obj(path)
            vertices = obj.vertices @ np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]).T
            faces = obj.faces
        else:
            vertices, faces = read_ply(path)
        if vertices is None or faces is None:
            raise UserError(f"{path.name}: no vertices or faces")
        if triangles is None:
            triangles = faces
        elif len(vertices) != len(shapes[0]) or faces.shape != triangles.shape or not np.array_equal(faces, triangles):
            raise UserError(f"{path.name} has another topology than {files[0].name} ({len(vertices)} vertices, "
                            f"{len(faces)} triangles, against {len(shapes[0])} and {len(triangles)}); a morphable "
                            "model needs meshes in correspondence")
        names.append(path.stem)
        shapes.append(np.asarray(vertices, np.float64))
    return names, np.array(shapes), np.asarray(triangles, np.int64)
