# SPDX-License-Identifier: GPL-3.0-or-later
"""Files made by other programs, checked before a foreign importer sees them.

Blender's importers trust the sizes a file states: a 5 KB file of random bytes behind an FBX header asks the
FBX parser for a property table of four billion entries per node (17.7 GB of memory before it fails). So a
path is resolved first (a symlink loop, a folder, an unreadable or empty file are refused by name), its
size is bounded, and its header and the sizes it declares are read here, in bounded memory, against the
file's real length:

* binary FBX (7.x): every node record's end offset lies inside its parent and the file, its property list
  fits in the record, every array property's stored bytes fit in the list, and no array unpacks to more than
  :data:`MAX_UNPACKED_BYTES` (a zlib bomb); ASCII FBX, which Blender does not read, is refused by name;
* GLB / glTF 2.0: the chunk lengths add up to the file, the JSON parses, every buffer view lies inside its
  buffer and every accessor inside its view; a .gltf names only data: URIs or files beside it;
* PLY: the header's element counts fit the file's bytes (binary) or lines (ASCII);
* STL: a binary file's triangle count matches its length, an ASCII file starts with ``solid``;
* OBJ: text without NUL bytes.

What passes still goes to the importer in a child process with a memory limit (``operators.adapters.
foreign_import``): these checks bound what a file claims, the child bounds what the importer does with it.
"""
from __future__ import annotations

import errno
import json
import struct
from pathlib import Path

from .errors import UserError

__all__ = ["MAX_FOREIGN_BYTES", "MAX_UNPACKED_BYTES", "FORMATS", "check_path", "check_foreign_file", "read_text"]

MAX_FOREIGN_BYTES = 1_000_000_000      # larger than any head or character we take; the importer needs several x
MAX_UNPACKED_BYTES = 1_000_000_000     # FBX arrays unpacked, all together
FBX_MAGIC = b"Kaydara FBX Binary  \x00"
FORMATS = (".fbx", ".glb", ".gltf", ".obj", ".ply", ".stl")
_GLTF_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_GLTF_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_FBX_ARRAY_ITEM = {ord("f"): 4, ord("d"): 8, ord("l"): 8, ord("i"): 4, ord("b"): 1}
_FBX_SCALAR = {ord("Y"): 2, ord("C"): 1, ord("I"): 4, ord("F"): 4, ord("D"): 8, ord("L"): 8}
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}


def check_path(path, what: str = "the file") -> Path:
    """``path`` resolved to an existing, readable, non-empty regular file; a UserError naming the problem
    (empty argument, NUL byte, symlink loop, missing, a folder, unreadable, empty) otherwise."""
    text = str(path) if path is not None else ""
    if not text.strip():
        raise UserError(f"{what} is an empty path; name a file")
    if "\0" in text:
        raise UserError(f"{what} {text!r} contains a NUL byte; name a file")
    try:
        resolved = Path(text).expanduser().resolve(strict=True)
    except FileNotFoundError:
        raise UserError(f"{text} does not exist") from None
    except (RuntimeError, OSError) as error:       # a symlink loop (RuntimeError before Python 3.13), ELOOP, EACCES
        loop = getattr(error, "errno", None) == errno.ELOOP or "loop" in str(error).lower()
        reason = "a symbolic link that points back to itself" if loop else str(error)
        raise UserError(f"{text} cannot be opened: {reason}") from None
    if resolved.is_dir():
        raise UserError(f"{text} is a folder; name a file")
    if not resolved.is_file():
        raise UserError(f"{text} is not a regular file")
    try:
        with open(resolved, "rb") as handle:
            handle.read(1)
    except OSError as error:
        raise UserError(f"{text} cannot be read: {error.strerror or error}") from None
    if resolved.stat().st_size == 0:
        raise UserError(f"{text} is empty")
    return resolved


def read_text(path, what: str, max_bytes: int) -> str:
    """The UTF-8 text of ``path`` (see :func:`check_path`), at most ``max_bytes`` long, without NUL bytes
    (which Python's csv module reads as data since 3.11): a UserError naming the problem otherwise."""
    resolved = check_path(path, what)
    if resolved.stat().st_size > max_bytes:
        raise UserError(f"{path} is larger than {max_bytes / 1e6:g} MB")
    try:
        text = resolved.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise UserError(f"{path} is not UTF-8 text ({error})") from None
    if "\0" in text:
        raise UserError(f"{path} contains a NUL byte at character {text.index(chr(0))}: not a text file")
    return text


def check_foreign_file(path, what: str = "the file", formats=FORMATS) -> Path:
    """``path`` (see :func:`check_path`) of one of ``formats`` (suffixes), within :data:`MAX_FOREIGN_BYTES`,
    whose header and declared sizes are consistent with its length (module docstring)."""
    resolved = check_path(path, what)
    suffix = resolved.suffix.lower()
    if suffix not in formats:
        raise UserError(f"{path}: {what} must be one of {', '.join(formats)}")
    size = resolved.stat().st_size
    if size > MAX_FOREIGN_BYTES:
        raise UserError(f"{path} is larger than {MAX_FOREIGN_BYTES // 1_000_000_000} GB")
    checker = {".fbx": _check_fbx, ".glb": _check_glb, ".gltf": _check_gltf, ".obj": _check_obj,
               ".ply": _check_ply, ".stl": _check_stl}[suffix]
    try:
        checker(resolved, size)
    except UserError as error:
        raise UserError(f"{path} is not a readable {suffix[1:].upper()} file: {error}") from None
    except (struct.error, ValueError, IndexError, UnicodeDecodeError) as error:
        raise UserError(f"{path} is not a readable {suffix[1:].upper()} file ({error})") from None
    return resolved


# ------------------------------------------------------------------------------------------------ FBX
def _check_fbx(path: Path, size: int) -> None:
    with open(path, "rb") as handle:
        head = handle.read(27)
        if not head.startswith(FBX_MAGIC):
            if head.lstrip().startswith(b";"):
                raise UserError("an ASCII FBX, which Blender does not import; save it as binary FBX")
            raise UserError("its header is not an FBX header")
        version = struct.unpack_from("<I", head, 23)[0]
        if not 7000 <= version < 8000:
            raise UserError(f"FBX version {version} (Blender reads 7.x)")
        wide = version >= 7500
        budget = [MAX_UNPACKED_BYTES]
        _fbx_nodes(handle, 27, size, wide, budget, depth=0)


def _fbx_nodes(handle, at: int, end: int, wide: bool, budget: list, depth: int) -> int:
    """Walk the node records from ``at`` up to ``end`` (a parent's end, or the file's); returns where the
    list stopped (after its null record, or at ``end``)."""
    if depth > 64:
        raise UserError("nodes nested more than 64 deep")
    header = struct.Struct("<QQQ" if wide else "<III")
    while at + header.size <= end:
        handle.seek(at)
        node_end, count, list_length = header.unpack(handle.read(header.size))
        name_length = handle.read(1)
        if node_end == 0:                                     # the null record that closes a list
            return at + header.size + 1
        if not at < node_end <= end:
            raise UserError(f"a node at byte {at} ends at {node_end}, outside its parent (..{end})")
        start = at + header.size + 1 + (name_length[0] if name_length else 0)
        if start + list_length > node_end or count > list_length:
            raise UserError(f"a node at byte {at} declares {count} properties in {list_length} bytes "
                            f"it does not have")
        _fbx_properties(handle, start, start + list_length, count, budget)
        if start + list_length < node_end:
            _fbx_nodes(handle, start + list_length, node_end, wide, budget, depth + 1)
        at = node_end
    return at


def _fbx_properties(handle, at: int, end: int, count: int, budget: list) -> None:
    handle.seek(at)
    for _ in range(count):
        if at >= end:
            raise UserError(f"properties run past their list at byte {at}")
        code = handle.read(1)[0]
        at += 1
        if code in _FBX_SCALAR:
            at += _FBX_SCALAR[code]
        elif code in (ord("S"), ord("R")):
            at += 4 + struct.unpack("<I", handle.read(4))[0]
        elif code in _FBX_ARRAY_ITEM:
            length, encoding, stored = struct.unpack("<III", handle.read(12))
            unpacked = length * _FBX_ARRAY_ITEM[code]
            if (encoding == 0 and stored != unpacked) or encoding not in (0, 1):
                raise UserError(f"an array at byte {at} is stored in {stored} bytes for {length} items")
            budget[0] -= unpacked
            if budget[0] < 0:
                raise UserError(f"its arrays unpack to more than {MAX_UNPACKED_BYTES // 1_000_000} MB")
            at += 12 + stored
        else:
            raise UserError(f"unknown property type {code!r} at byte {at - 1}")
        if at > end:
            raise UserError(f"a property runs past its list at byte {at}")
        handle.seek(at)


# ------------------------------------------------------------------------------------------------ glTF
def _check_glb(path: Path, size: int) -> None:
    with open(path, "rb") as handle:
        magic, version, length = struct.unpack("<4sII", handle.read(12))
        if magic != b"glTF":
            raise UserError("its header is not a GLB header")
        if version != 2:
            raise UserError(f"glTF version {version} (Blender reads 2)")
        if length != size:
            raise UserError(f"its header says {length} bytes, the file has {size}")
        json_length, kind = struct.unpack("<I4s", handle.read(8))
        if kind != b"JSON" or 20 + json_length > size:
            raise UserError("its first chunk is not a JSON chunk inside the file")
        document = json.loads(handle.read(json_length))
        binary = 0
        if 20 + json_length + 8 <= size:
            binary, kind = struct.unpack("<I4s", handle.read(8))
            if kind != b"BIN\x00" or 28 + json_length + binary > size:
                raise UserError("its second chunk is not a BIN chunk inside the file")
    _check_gltf_document(document, lambda index, buffer: binary if index == 0 and "uri" not in buffer else None,
                         path)


def _check_gltf(path: Path, size: int) -> None:
    document = json.loads(path.read_text(encoding="utf-8"))
    _check_gltf_document(document, lambda index, buffer: None, path)


def _buffer_length(buffer: dict, embedded, folder: Path) -> int:
    uri = buffer.get("uri")
    if embedded is not None:
        return embedded
    if not isinstance(uri, str):
        raise UserError("a buffer has neither data nor a file")
    if uri.startswith("data:"):
        return len(uri) * 3 // 4
    target = (folder / uri).resolve()
    if folder.resolve() not in target.parents or not target.is_file():
        raise UserError(f"buffer file {uri!r} is not a file beside it")
    return target.stat().st_size


def _check_gltf_document(document, embedded, path: Path) -> None:
    if not isinstance(document, dict) or not str(document.get("asset", {}).get("version", "")).startswith("2"):
        raise UserError("its JSON is not a glTF 2.0 document")
    buffers = [_buffer_length(b, embedded(i, b), path.parent) for i, b in enumerate(document.get("buffers", []))]
    views = []
    for view in document.get("bufferViews", []):
        start, length = int(view.get("byteOffset", 0)), int(view["byteLength"])
        if not 0 <= view["buffer"] < len(buffers) or start < 0 or start + length > buffers[view["buffer"]]:
            raise UserError("a buffer view lies outside its buffer")
        views.append(length)
    for accessor in document.get("accessors", []):
        count = int(accessor["count"])
        item = _GLTF_COMPONENT_BYTES[accessor["componentType"]] * _GLTF_WIDTH[accessor["type"]]
        if "bufferView" in accessor:
            view = accessor["bufferView"]
            if not 0 <= view < len(views):
                raise UserError("an accessor names a buffer view that does not exist")
            stride = int(document["bufferViews"][view].get("byteStride") or item)
            if count < 0 or int(accessor.get("byteOffset", 0)) + max(count - 1, 0) * stride + item > views[view]:
                raise UserError(f"an accessor of {count} items lies outside its buffer view")
        elif count * item > MAX_UNPACKED_BYTES:
            raise UserError(f"an accessor of {count} items is larger than the file could hold")
    for image in document.get("images", []):
        uri = image.get("uri")
        if isinstance(uri, str) and not uri.startswith("data:") and (
                Path(uri).is_absolute() or ".." in Path(uri).parts):
            raise UserError(f"image {uri!r} lies outside the file's folder")


# ------------------------------------------------------------------------------------- PLY, STL, OBJ
def _check_ply(path: Path, size: int) -> None:
    with open(path, "rb") as handle:
        if handle.readline().strip() != b"ply":
            raise UserError("its header does not start with 'ply'")
        fmt, elements, lines = None, [], 1
        while True:
            line = handle.readline(1024)
            lines += 1
            if not line or lines > 10_000:
                raise UserError("its header has no end_header line")
            words = line.decode("ascii").split()
            if not words or words[0] in ("comment", "obj_info"):
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append([words[1], int(words[2]), 0])
            elif words[0] == "property" and elements:
                elements[-1][2] += _PLY_SIZES.get(words[-2] if words[1] == "list" else words[1], 1)
        body = size - handle.tell()
    least = sum(count * max(row, 1) for _, count, row in elements) if fmt != "ascii" else sum(
        count for _, count, _ in elements)
    if any(count < 0 for _, count, _ in elements) or least > body:
        raise UserError(f"its header declares {sum(c for _, c, _ in elements)} items in {body} bytes")


def _check_stl(path: Path, size: int) -> None:
    with open(path, "rb") as handle:
        head = handle.read(84)
    if len(head) == 84 and 84 + 50 * struct.unpack_from("<I", head, 80)[0] == size:
        return
    if not head.lstrip().lower().startswith(b"solid"):
        raise UserError("neither a binary STL (its triangle count does not match its length) nor ASCII STL")


def _check_obj(path: Path, size: int) -> None:
    with open(path, "rb") as handle:
        while chunk := handle.read(1 << 20):
            if b"\0" in chunk:
                raise UserError("it contains NUL bytes; an OBJ file is text")
