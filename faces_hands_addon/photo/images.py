# SPDX-License-Identifier: GPL-3.0-or-later
"""A photograph before and after Blender decodes it: its file checked from its bytes (what it is, its size,
whether it is complete, how it is turned), and its pixels made into the one form the photo work uses.

Blender decodes the picture (``bpy.data.images.load`` in the operators); this module reads, in bounded
memory, what a decoder would trust or ignore:

* the format from the first bytes (JPEG, PNG, WebP, TIFF, BMP), never the file name;
* the pixel size the header declares, refused above :data:`MAX_PIXELS` before anything is decoded;
* a JPEG's segments up to its scan and its end marker (a truncated file ends inside its scan), its colour
  components (1 grey, 3 YCbCr, 4 CMYK/YCCK), the EXIF orientation (tag 0x0112, which Blender's loader does not
  apply) and the EXIF focal length in 35 mm terms (tag 0xA405), used for the camera when present;
* a PNG's chunks (lengths inside the file, IHDR first, IEND last), its bit depth and colour type (grey, alpha).

:func:`working_pixels` turns decoded pixels (any channel count, any bit depth as floats in 0..1, rows from
the top) into (H, W, 3) float32 sRGB values with the EXIF orientation applied and alpha composited over mid
grey, at most :data:`WORK_SIDE` pixels on the long side (the operators ask Blender to scale larger pictures
before reading them, so a 40-megapixel photo never exists here as floats at full size).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import UserError

__all__ = ["PhotoFile", "check_photo_file", "working_pixels", "orient", "oriented_size", "MAX_PIXELS",
           "MAX_FILE_BYTES", "WORK_SIDE", "FORMATS"]

MAX_PIXELS = 150_000_000          # a 150-megapixel picture; larger ones are refused before decoding
MAX_FILE_BYTES = 400_000_000
WORK_SIDE = 4096                  # px on the long side the photo work runs at
MIN_SIDE = 64
FORMATS = ("JPEG", "PNG", "WebP", "TIFF", "BMP")
_MAGIC = ((b"\xff\xd8\xff", "JPEG"), (b"\x89PNG\r\n\x1a\n", "PNG"), (b"II*\x00", "TIFF"), (b"MM\x00*", "TIFF"),
          (b"BM", "BMP"))


@dataclass
class PhotoFile:
    """What the bytes of a picture say: ``kind`` (one of :data:`FORMATS`), ``width`` x ``height`` as stored
    (0 when the header does not say), ``orientation`` (EXIF 1..8, 1 = as stored), ``channels`` (colour
    components the file stores, 0 unknown), ``bits`` per component, ``alpha``, ``focal_35mm`` (mm, 0 unknown),
    ``notes`` (what a user should know: grey, CMYK, 16 bit, turned, alpha)."""
    path: Path
    kind: str
    width: int = 0
    height: int = 0
    orientation: int = 1
    channels: int = 0
    bits: int = 8
    alpha: bool = False
    focal_35mm: float = 0.0
    notes: tuple[str, ...] = ()


def check_photo_file(path, what: str = "the photo") -> PhotoFile:
    """The checked header of ``path`` or a UserError naming what is wrong (module docstring)."""
    text = str(path) if path is not None else ""
    if not text.strip():
        raise UserError(f"{what} is an empty path; name a picture file (JPEG or PNG)")
    file = Path(text).expanduser()
    if not file.is_file():
        raise UserError(f"{what} {file} does not exist" if not file.exists() else f"{what} {file} is not a file")
    size = file.stat().st_size
    if size == 0:
        raise UserError(f"{what} {file} is empty")
    if size > MAX_FILE_BYTES:
        raise UserError(f"{what} {file} is {size / 1e6:.0f} MB; pictures up to {MAX_FILE_BYTES // 1_000_000} MB "
                        "are read")
    with open(file, "rb") as handle:
        head = handle.read(64)
    kind = next((name for magic, name in _MAGIC if head.startswith(magic)), None)
    if kind is None and head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        kind = "WebP"
    if kind is None:
        raise UserError(f"{what} {file.name} is not a picture Faces & Hands reads ({', '.join(FORMATS)}); "
                        "its first bytes are no image header")
    photo = PhotoFile(file, kind)
    try:
        if kind == "JPEG":
            _read_jpeg(file.read_bytes(), photo)
        elif kind == "PNG":
            _read_png(file, size, photo)
        elif kind == "WebP":
            _read_webp(head, photo)
        elif kind == "BMP":
            photo.width, photo.height = struct.unpack_from("<ii", head, 18)
            photo.height = abs(photo.height)
    except (struct.error, IndexError, ValueError) as error:
        raise UserError(f"{what} {file.name} is a damaged {kind} file ({error})") from None
    _check_size(photo, what)
    return photo


def _check_size(photo: PhotoFile, what: str) -> None:
    name = photo.path.name
    if photo.width and photo.height:
        if photo.width * photo.height > MAX_PIXELS:
            raise UserError(f"{what} {name} is {photo.width}x{photo.height} "
                            f"({photo.width * photo.height / 1e6:.0f} megapixels); the largest read is "
                            f"{MAX_PIXELS / 1e6:.0f} megapixels: scale it down first")
        if min(photo.width, photo.height) < MIN_SIDE:
            raise UserError(f"{what} {name} is {photo.width}x{photo.height} pixels: too small for a face")


# ------------------------------------------------------------------------------------------------- JPEG
def _read_jpeg(data: bytes, photo: PhotoFile) -> None:
    """Segments from SOI to the first scan; then the end marker must follow (module docstring)."""
    at, size, scan = 2, len(data), None
    while at < size:
        if data[at] != 0xFF:
            raise ValueError(f"no segment marker at byte {at}")
        marker = data[at + 1]
        if marker == 0xFF:                          # fill byte
            at += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            at += 2
            continue
        length = struct.unpack_from(">H", data, at + 2)[0]
        if length < 2 or at + 2 + length > size:
            raise UserError(f"{photo.path.name} is cut off: a JPEG segment runs past the end of the file")
        body = data[at + 4:at + 2 + length]
        if marker in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
            photo.bits, photo.height, photo.width, photo.channels = struct.unpack_from(">BHHB", body, 0)
        elif marker == 0xE1 and body.startswith(b"Exif\x00\x00"):
            _read_exif(body[6:], photo)
        elif marker == 0xDA:
            scan = at + 2 + length
            break
        at += 2 + length
    if scan is None or not photo.width:
        raise UserError(f"{photo.path.name} is cut off or damaged: its JPEG header has no image size or scan")
    if data.find(b"\xff\xd9", scan) < 0:
        raise UserError(f"{photo.path.name} is cut off: the JPEG data ends before its end marker "
                        f"({size:,} bytes); copy the whole file again")
    notes = []
    if photo.channels == 1:
        notes.append("grey")
    elif photo.channels == 4:
        notes.append("CMYK")
    if photo.orientation != 1:
        notes.append(f"EXIF orientation {photo.orientation}")
    photo.notes = tuple(notes)


def _read_exif(tiff: bytes, photo: PhotoFile) -> None:
    """Orientation (IFD0 tag 0x0112) and the 35 mm focal length (EXIF IFD tag 0xA405) of a TIFF block."""
    if len(tiff) < 8 or tiff[:2] not in (b"II", b"MM"):
        return
    order = "<" if tiff[:2] == b"II" else ">"

    def entries(offset: int):
        if not 0 < offset <= len(tiff) - 2:
            return
        count = struct.unpack_from(order + "H", tiff, offset)[0]
        for k in range(min(count, 512)):
            at = offset + 2 + 12 * k
            if at + 12 > len(tiff):
                return
            tag, kind, _ = struct.unpack_from(order + "HHI", tiff, at)
            yield tag, kind, at + 8

    exif_ifd = 0
    for tag, kind, value_at in entries(struct.unpack_from(order + "I", tiff, 4)[0]):
        if tag == 0x0112 and kind == 3:
            value = struct.unpack_from(order + "H", tiff, value_at)[0]
            photo.orientation = value if 1 <= value <= 8 else 1
        elif tag == 0x8769:
            exif_ifd = struct.unpack_from(order + "I", tiff, value_at)[0]
    for tag, kind, value_at in entries(exif_ifd):
        if tag == 0xA405 and kind == 3:
            photo.focal_35mm = float(struct.unpack_from(order + "H", tiff, value_at)[0])


# -------------------------------------------------------------------------------------------------- PNG
def _read_png(file: Path, size: int, photo: PhotoFile) -> None:
    """Chunk lengths inside the file, IHDR first, IEND at the end (module docstring)."""
    seen_end, first = False, True
    with open(file, "rb") as handle:
        handle.seek(8)
        at = 8
        while at < size:
            header = handle.read(8)
            if len(header) < 8:
                break
            length, name = struct.unpack(">I4s", header)
            if at + 12 + length > size:
                raise UserError(f"{file.name} is cut off: a PNG chunk ({name.decode('latin-1')!r}) runs past the "
                                "end of the file")
            if first:
                if name != b"IHDR" or length != 13:
                    raise ValueError("the first chunk is not IHDR")
                w, h, bits, colour = struct.unpack(">IIBB", handle.read(10))
                handle.seek(3 + 4, 1)
                photo.width, photo.height, photo.bits = w, h, bits
                photo.channels = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}.get(colour, 0)
                photo.alpha = colour in (4, 6)
                first = False
            else:
                if name == b"tRNS":
                    photo.alpha = True
                handle.seek(length + 4, 1)
            at += 12 + length
            if name == b"IEND":
                seen_end = True
                break
    if not seen_end:
        raise UserError(f"{file.name} is cut off: the PNG has no end chunk (IEND); copy the whole file again")
    notes = (["grey"] if photo.channels in (1, 2) else []) + ([f"{photo.bits} bit"] if photo.bits > 8 else []) \
        + (["alpha"] if photo.alpha else [])
    photo.notes = tuple(notes)


def _read_webp(head: bytes, photo: PhotoFile) -> None:
    chunk = head[12:16]
    if chunk == b"VP8X":
        photo.width = 1 + int.from_bytes(head[24:27], "little")
        photo.height = 1 + int.from_bytes(head[27:30], "little")
    elif chunk == b"VP8 ":
        photo.width, photo.height = (v & 0x3FFF for v in struct.unpack_from("<HH", head, 26))
    elif chunk == b"VP8L":
        bits = int.from_bytes(head[21:25], "little")
        photo.width, photo.height = 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)


# ------------------------------------------------------------------------------------------------ pixels
def oriented_size(photo: PhotoFile, width: int, height: int) -> tuple[int, int]:
    """(width, height) after the EXIF orientation (5..8 swap the sides)."""
    return (height, width) if photo.orientation >= 5 else (width, height)


def orient(pixels: np.ndarray, orientation: int) -> np.ndarray:
    """Rows-from-the-top pixels as stored -> as meant to be seen (EXIF orientation 1..8)."""
    ops = {1: (), 2: ("flip_x",), 3: ("rot180",), 4: ("flip_y",), 5: ("transpose",), 6: ("rot_cw",),
           7: ("transverse",), 8: ("rot_ccw",)}[int(orientation) if 1 <= int(orientation) <= 8 else 1]
    for op in ops:
        if op == "flip_x":
            pixels = pixels[:, ::-1]
        elif op == "flip_y":
            pixels = pixels[::-1]
        elif op == "rot180":
            pixels = pixels[::-1, ::-1]
        elif op == "transpose":
            pixels = pixels.transpose(1, 0, 2)
        elif op == "rot_cw":
            pixels = pixels.transpose(1, 0, 2)[:, ::-1]
        elif op == "rot_ccw":
            pixels = pixels.transpose(1, 0, 2)[::-1]
        else:
            pixels = pixels[::-1, ::-1].transpose(1, 0, 2)
    return np.ascontiguousarray(pixels)


def working_pixels(pixels: np.ndarray, orientation: int = 1) -> np.ndarray:
    """(H, W, 3) float32 sRGB in 0..1 from decoded pixels (H, W, C), C = 1 (grey), 2 (grey + alpha), 3 or 4
    (alpha composited over mid grey), rows from the top, then turned by the EXIF ``orientation``."""
    pixels = np.asarray(pixels, np.float32)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 2, 3, 4) or min(pixels.shape[:2]) < MIN_SIDE:
        raise UserError(f"the picture's pixels have the shape {pixels.shape}; expected a colour or grey image of "
                        f"at least {MIN_SIDE}x{MIN_SIDE}")
    if max(pixels.shape[:2]) > WORK_SIDE:
        raise UserError(f"the picture is {pixels.shape[1]}x{pixels.shape[0]} pixels here; scale it to "
                        f"{WORK_SIDE} on the long side first")
    channels = pixels.shape[2]
    colour = pixels[..., :3] if channels >= 3 else np.repeat(pixels[..., :1], 3, axis=2)
    if channels in (2, 4):
        alpha = np.clip(pixels[..., -1:], 0.0, 1.0)
        colour = colour * alpha + 0.5 * (1.0 - alpha)
    colour = np.nan_to_num(np.clip(colour, 0.0, 1.0), nan=0.5)
    return orient(colour, orientation).astype(np.float32)
