#!/usr/bin/env python3
"""Writes bumps_normal.png: a tangent-space normal map (n = 2 rgb - 1, +z up) of a 6 x 6 grid of
hemispherical bumps, 8-bit RGB, using only the standard library. Read it with raw=true."""
import math, struct, zlib

SIZE, CELLS = 256, 6

def normal(x, y):
    cx = (x + 0.5) / SIZE * CELLS
    cy = (y + 0.5) / SIZE * CELLS
    dx, dy = (cx % 1.0) - 0.5, (cy % 1.0) - 0.5
    r2 = (dx * dx + dy * dy) / 0.16  # bump radius 0.4 of a cell
    if r2 >= 1.0:
        return (0.0, 0.0, 1.0)
    # Image rows run top to bottom while v (and local y) runs up: flip dy.
    nx, ny = dx / 0.4, -dy / 0.4
    nz = math.sqrt(max(0.0, 1.0 - nx * nx - ny * ny))
    return (nx, ny, nz)

rows = []
for y in range(SIZE):
    row = bytearray([0])
    for x in range(SIZE):
        row += bytes(max(0, min(255, round((c * 0.5 + 0.5) * 255))) for c in normal(x, y))
    rows.append(bytes(row))

def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", SIZE, SIZE, 8, 2, 0, 0, 0))
png += chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b"")
with open(__file__.rsplit("/", 1)[0] + "/bumps_normal.png", "wb") as f:
    f.write(png)
