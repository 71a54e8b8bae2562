#!/usr/bin/env python3
"""Writes tests/data/textures/blend_weight.png (byte by byte, no imaging library;
deterministic): a 4x4 8-bit grey PNG whose texels are 0, 1 and values between (read raw with
nearest filtering), the textured weight of the stream renderer's `blendbsdf` tests
(tests/data/scenes/stream_blend.xml): a chunk of 8 paths on it mixes lanes with w = 0, w = 1 and
0 < w < 1.

Run: python3 tests/data/textures/make_blend_weight.py (from anywhere).
"""
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))

TEXELS = [
    [0, 255, 128, 0],
    [255, 64, 0, 200],
    [128, 0, 255, 32],
    [0, 180, 255, 0],
]


def chunk(kind, data):
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)


def main():
    h, w = len(TEXELS), len(TEXELS[0])
    raw = b"".join(b"\x00" + bytes(row) for row in TEXELS)
    png = (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw, 9))
        + chunk(b"IEND", b"")
    )
    with open(os.path.join(HERE, "blend_weight.png"), "wb") as f:
        f.write(png)


if __name__ == "__main__":
    main()
