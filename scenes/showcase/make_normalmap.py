#!/usr/bin/env python3
"""Writes normalmap.png: a procedural tangent-space normal map (OpenGL convention, green = +v)
of hemispherical bumps on a grid plus diagonal grooves, strong enough (tilts up to ~70°) to show
the difference between classic and microfacet normal mapping. Pure Python (zlib + struct).

    python3 scenes/showcase/make_normalmap.py [--size 256] [-o scenes/showcase/normalmap.png]
"""
import argparse
import math
import struct
import zlib


def height_gradient(u, v):
    """Gradient (dh/du, dh/dv) of the height field at (u, v) in [0,1)^2."""
    cells = 8
    x = (u * cells) % 1.0 - 0.5
    y = (v * cells) % 1.0 - 0.5
    r2 = x * x + y * y
    gx = gy = 0.0
    rad = 0.42
    if r2 < rad * rad:
        h = math.sqrt(rad * rad - r2)
        gx += -x / max(h, 0.05) * cells * 0.06
        gy += -y / max(h, 0.05) * cells * 0.06
    # diagonal sinusoidal grooves
    k = 2.0 * math.pi * 12.0
    s = math.cos(k * (u + v))
    gx += 0.04 * k * s
    gy += 0.04 * k * s
    return gx, gy


def png(path, w, h, rows):
    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("-o", "--output", default="normalmap.png")
    a = ap.parse_args()
    n = a.size
    rows = []
    for j in range(n):
        row = []
        for i in range(n):
            u = (i + 0.5) / n
            v = (j + 0.5) / n
            gx, gy = height_gradient(u, v)
            # normal of the height field; image row 0 is v = 0 (Mitsuba: no v flip in textures)
            nx, ny, nz = -gx, -gy, 1.0
            l = math.sqrt(nx * nx + ny * ny + nz * nz)
            for c in (nx / l, ny / l, nz / l):
                row.append(max(0, min(255, int(round((0.5 * c + 0.5) * 255)))))
        rows.append(row)
    png(a.output, n, n, rows)


if __name__ == "__main__":
    main()
