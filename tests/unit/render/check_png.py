#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Check a PNG file with Python's standard library only: signature, every chunk's CRC, the
IHDR fields, and that the inflated pixel data has one filter byte plus 3 bytes per pixel per
row. Prints WIDTHxHEIGHT; exits 1 with a message on any problem."""
import struct
import sys
import zlib

path = sys.argv[1]
data = open(path, "rb").read()
if data[:8] != b"\x89PNG\r\n\x1a\n":
    sys.exit(f"{path}: not a PNG signature")
pos, idat, header, chunks = 8, b"", None, []
while pos < len(data):
    (length,) = struct.unpack(">I", data[pos : pos + 4])
    kind = data[pos + 4 : pos + 8]
    body = data[pos + 8 : pos + 8 + length]
    (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
    if zlib.crc32(kind + body) != crc:
        sys.exit(f"{path}: bad CRC in chunk {kind!r}")
    chunks.append(kind)
    if kind == b"IHDR":
        header = struct.unpack(">IIBBBBB", body)
    elif kind == b"IDAT":
        idat += body
    pos += 12 + length
if not chunks or chunks[0] != b"IHDR" or chunks[-1] != b"IEND" or header is None:
    sys.exit(f"{path}: chunks out of order: {chunks}")
width, height, depth, color_type, _, _, interlace = header
if (depth, color_type, interlace) != (8, 2, 0):
    sys.exit(f"{path}: expected 8-bit RGB, not interlaced, got {header}")
pixels = zlib.decompress(idat)
if len(pixels) != height * (1 + 3 * width):
    sys.exit(f"{path}: {len(pixels)} bytes of pixel data for {width}x{height}")
print(f"{width}x{height}")
