"""Photographs checked from their bytes before Blender decodes them: the format by its first bytes, the size
a header declares (a 200-megapixel header is refused before any pixel exists), a JPEG cut inside its scan, a
PNG without its end chunk, EXIF orientation and 35 mm focal length, CMYK and grey components; pixels turned
by every EXIF orientation and alpha composited."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from faces_hands_addon.core.errors import UserError
from faces_hands_addon.photo.images import check_photo_file, orient, working_pixels


def _exif(orientation: int, focal_35mm: int) -> bytes:
    """An APP1 Exif segment (little endian): IFD0 with the orientation and a pointer to an EXIF IFD with the
    35 mm focal length."""
    ifd0 = struct.pack("<H", 2) + struct.pack("<HHII", 0x0112, 3, 1, orientation) \
        + struct.pack("<HHII", 0x8769, 4, 1, 8 + 2 + 24 + 4) + struct.pack("<I", 0)
    exif_ifd = struct.pack("<H", 1) + struct.pack("<HHII", 0xA405, 3, 1, focal_35mm) + struct.pack("<I", 0)
    tiff = b"II*\x00" + struct.pack("<I", 8) + ifd0 + exif_ifd
    body = b"Exif\x00\x00" + tiff
    return b"\xff\xe1" + struct.pack(">H", len(body) + 2) + body


def _jpeg(width: int, height: int, components: int = 3, exif: bytes = b"", end: bool = True) -> bytes:
    sof = struct.pack(">BHHB", 8, height, width, components) + b"\x01\x11\x00" * components
    sos = struct.pack(">B", components) + b"\x01\x00" * components + b"\x00\x3f\x00"
    data = b"\xff\xd8" + exif + b"\xff\xc0" + struct.pack(">H", len(sof) + 2) + sof \
        + b"\xff\xda" + struct.pack(">H", len(sos) + 2) + sos + b"\x12\x34\xff\x00\x56" * 20
    return data + (b"\xff\xd9" if end else b"")


def _png(width: int, height: int, colour: int = 2, bits: int = 8, end: bool = True) -> bytes:
    def chunk(name: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + name + body + struct.pack(">I", zlib.crc32(name + body))
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bits, colour, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(b"\x00" * 64))
    return data + (chunk(b"IEND", b"") if end else b"")


def test_headers_say_what_the_picture_is(tmp_path):
    path = tmp_path / "turned.jpg"
    path.write_bytes(_jpeg(640, 480, exif=_exif(6, 85)))
    photo = check_photo_file(path)
    assert (photo.kind, photo.width, photo.height, photo.orientation, photo.focal_35mm) == ("JPEG", 640, 480, 6, 85.0)
    path.write_bytes(_jpeg(640, 480, components=4))
    assert check_photo_file(path).notes == ("CMYK",)
    path.write_bytes(_jpeg(640, 480, components=1))
    assert check_photo_file(path).notes == ("grey",)
    png = tmp_path / "deep.png"
    png.write_bytes(_png(300, 200, colour=4, bits=16))
    photo = check_photo_file(png)
    assert (photo.kind, photo.width, photo.bits, photo.alpha) == ("PNG", 300, 16, True)
    assert photo.notes == ("grey", "16 bit", "alpha")


@pytest.mark.parametrize("name, data, message", [
    ("cut.jpg", _jpeg(640, 480, end=False), "cut off: the JPEG data ends before its end marker"),
    ("cut.png", _png(640, 480, end=False), "cut off: the PNG has no end chunk"),
    ("huge.jpg", _jpeg(20000, 10000), "200 megapixels"),
    ("tiny.png", _png(40, 30), "too small for a face"),
    ("notes.jpg", b"these are not the pixels you are looking for\n" * 4, "not a picture"),
    ("empty.png", b"", "is empty"),
])
def test_bad_files_are_refused_before_decoding(tmp_path, name, data, message):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(UserError, match=message):
        check_photo_file(path)


def test_every_exif_orientation_shows_the_picture_upright():
    upright = np.arange(4 * 6 * 3, dtype=np.float32).reshape(4, 6, 3)
    stored = {1: upright, 2: upright[:, ::-1], 3: upright[::-1, ::-1], 4: upright[::-1],
              5: upright.transpose(1, 0, 2), 6: np.rot90(upright, 1), 7: np.rot90(upright, 2).transpose(1, 0, 2),
              8: np.rot90(upright, -1)}
    for orientation, pixels in stored.items():
        assert np.array_equal(orient(np.ascontiguousarray(pixels), orientation), upright), orientation


def test_grey_and_alpha_pixels_become_colour_over_mid_grey():
    grey = np.full((70, 80, 1), 0.2, np.float32)
    assert np.allclose(working_pixels(grey), 0.2)
    rgba = np.zeros((70, 80, 4), np.float32)
    rgba[..., 0] = 1.0                          # red, fully transparent on the left half
    rgba[:, 40:, 3] = 1.0
    out = working_pixels(rgba)
    assert np.allclose(out[:, :40], 0.5) and np.allclose(out[:, 40:], [1.0, 0.0, 0.0])
