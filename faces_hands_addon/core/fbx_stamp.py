# SPDX-License-Identifier: GPL-3.0-or-later
"""Binary FBX files made reproducible: the same scene exports to the same bytes.

Two things change from run to run in what Blender's FBX exporter writes: the creation time-stamp, and the
objects' 64-bit ids, which it derives from Python's ``hash()`` of their names (salted afresh in every
process). :func:`fix_creation_stamp` sets the first to a fixed moment; :func:`fix_object_ids` renumbers the
second in the order the objects appear in the file (every reference to an id, in connections and
properties, renumbered with it). Neither changes the file's length or structure.

Blender's FBX exporter writes a fixed ``CreationTime`` string ("1970-01-01 10:00:00:000") and ``FileId``
but the wall-clock time into the header's ``FBXHeaderExtension/CreationTimeStamp`` node (Year ... Millisecond,
int32 properties). This module rewrites those fields, in place and without changing the file's length, to
the same fixed moment. Binary FBX layout: a node record is end offset, property count, property list length
(uint32 each for FBX 7.4), a length-prefixed name, then its properties; an int32 property is ``b"I"`` and 4
little-endian bytes.
"""
from __future__ import annotations

import struct

from .errors import UserError

__all__ = ["FIXED_STAMP", "FIRST_ID", "fix_creation_stamp", "fix_object_ids", "reproducible"]

MAGIC = b"Kaydara FBX Binary  \x00"
FIXED_STAMP = (("Year", 1970), ("Month", 1), ("Day", 1), ("Hour", 10), ("Minute", 0), ("Second", 0),
               ("Millisecond", 0))
_HEADER_SPAN = 512
FIRST_ID = 1_000_000_000         # renumbered ids count up from here (in Blender's own range, clear of 0: the root)
_ID_OWNERS = (b"Objects", b"Documents")
_SCALAR = {ord("Y"): 2, ord("C"): 1, ord("I"): 4, ord("F"): 4, ord("D"): 8, ord("L"): 8}     # the time-stamp sits in the first few hundred bytes of the header extension


def fix_creation_stamp(data: bytes) -> bytes:
    """``data`` (a binary FBX file) with its creation time-stamp set to ``FIXED_STAMP``; other bytes kept."""
    if not data.startswith(MAGIC):
        raise UserError("not a binary FBX file (its header is missing)")
    start = data.find(b"\x11CreationTimeStamp")
    if start < 0:
        return data
    out = bytearray(data)
    window = slice(start, start + _HEADER_SPAN)
    for field, value in FIXED_STAMP:
        tag = bytes([len(field)]) + field.encode("ascii") + b"I"
        at = data.find(tag, window.start, window.stop)
        if at < 0:
            raise UserError(f"FBX time-stamp field {field} not found; the file layout is not the expected one")
        at += len(tag)
        out[at:at + 4] = struct.pack("<i", value)
    return bytes(out)


def _walk(data: bytes, at: int, end: int, wide: bool, parent: bytes, found: list) -> None:
    """Append ``(parent name, node name, [(offset of an int64 property's value, value), ...])`` for every
    node record from ``at`` to ``end`` and below."""
    header = struct.Struct("<QQQ" if wide else "<III")
    while at + header.size < end:
        node_end, count, list_length = header.unpack_from(data, at)
        if node_end == 0:
            return
        name_length = data[at + header.size]
        start = at + header.size + 1
        name = data[start:start + name_length]
        cursor, longs = start + name_length, []
        for _ in range(count):
            code = data[cursor]
            cursor += 1
            if code == ord("L"):
                longs.append((cursor, struct.unpack_from("<q", data, cursor)[0]))
            if code in _SCALAR:
                cursor += _SCALAR[code]
            elif code in (ord("S"), ord("R")):
                cursor += 4 + struct.unpack_from("<I", data, cursor)[0]
            else:                                       # an array: length, encoding, stored bytes
                cursor += 12 + struct.unpack_from("<I", data, cursor + 8)[0]
        found.append((parent, name, longs))
        if cursor < node_end:
            _walk(data, cursor, node_end, wide, name, found)
        at = node_end


def fix_object_ids(data: bytes) -> bytes:
    """``data`` (a binary FBX file) with the ids of its objects and documents renumbered from
    :data:`FIRST_ID` in the order they appear, every int64 property that names one renumbered with it."""
    if not data.startswith(MAGIC):
        raise UserError("not a binary FBX file (its header is missing)")
    version = struct.unpack_from("<I", data, 23)[0]
    nodes: list = []
    try:
        _walk(data, 27, len(data), version >= 7500, b"", nodes)
    except (struct.error, IndexError):
        raise UserError("the FBX file's node records do not add up; it was not written completely") from None
    renumbered = {}
    for parent, _, longs in nodes:
        if parent in _ID_OWNERS and longs and longs[0][1] not in renumbered:
            renumbered[longs[0][1]] = FIRST_ID + len(renumbered)
    out = bytearray(data)
    for _, _, longs in nodes:
        for offset, value in longs:
            if value in renumbered:
                struct.pack_into("<q", out, offset, renumbered[value])
    return bytes(out)


def reproducible(data: bytes) -> bytes:
    """Both fixes (module docstring): the bytes one scene always exports to."""
    return fix_object_ids(fix_creation_stamp(data))
