# SPDX-License-Identifier: GPL-3.0-or-later
"""A fixed creation time-stamp in binary FBX files, so the same scene exports to the same bytes.

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

__all__ = ["FIXED_STAMP", "fix_creation_stamp"]

MAGIC = b"Kaydara FBX Binary  \x00"
FIXED_STAMP = (("Year", 1970), ("Month", 1), ("Day", 1), ("Hour", 10), ("Minute", 0), ("Second", 0),
               ("Millisecond", 0))
_HEADER_SPAN = 512     # the time-stamp sits in the first few hundred bytes of the header extension


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
