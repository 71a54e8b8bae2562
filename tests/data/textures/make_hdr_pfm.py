#!/usr/bin/env python3
"""Writes the small Radiance RGBE / PFM / PLY assets of groove's `.hdr`, `.pfm` and
`mesh_attribute` render tests (byte by byte, no imaging library; deterministic):

    tests/data/textures/hdr_rle.hdr      16x8 RGBE, run-length encoded scanlines (runs and literals)
    tests/data/textures/pfm_rgb_be.pfm   8x6 colour PFM, big-endian (scale 1)
    tests/data/textures/pfm_grey_le.pfm  6x4 grey PFM, little-endian, scale -0.5 (values halved)
    tests/data/envmaps/sky_rle.hdr       32x16 RGBE lat-long sky with a bright sun, run-length encoded
    tests/data/geometry/attr_grid.ply    3x3-vertex grid (8 triangles), binary little-endian, float
                                         vertex colours `red green blue` and a face property `shade_x`
    tests/data/geometry/attr_types.ply   one triangle whose extra properties have every PLY type
                                         (how Mitsuba converts each: tests/scene/mesh_attribute.rs)

Run: python3 tests/data/textures/make_hdr_pfm.py (from anywhere).
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.dirname(HERE)


def rgbe(c):
    """Float RGB to RGBE bytes (Mitsuba's / Walter's rgbe_from_float)."""
    m = max(c)
    if m < 1e-32:
        return bytes([0, 0, 0, 0])
    f, e = math.frexp(m)
    s = f * 256.0 / m
    return bytes([int(c[0] * s), int(c[1] * s), int(c[2] * s), e + 128])


def rle_plane(data):
    """One byte plane as runs (>= 3 equal bytes) and literal spans."""
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        run = 1
        while i + run < n and run < 127 and data[i + run] == data[i]:
            run += 1
        if run >= 3:
            out += bytes([128 + run, data[i]])
            i += run
            continue
        j = i
        while j < n and j - i < 128:
            r = 1
            while j + r < n and r < 3 and data[j + r] == data[j]:
                r += 1
            if r >= 3:
                break
            j += 1
        out += bytes([j - i]) + bytes(data[i:j])
        i = j
    return bytes(out)


def write_hdr(path, w, h, px):
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\n# groove test asset\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(("-Y %d +X %d\n" % (h, w)).encode())
        for y in range(h):
            row = [rgbe(px(x, y)) for x in range(w)]
            f.write(bytes([2, 2, w >> 8, w & 255]))
            for ch in range(4):
                f.write(rle_plane(bytes(p[ch] for p in row)))


def write_pfm(path, w, h, chans, scale, px):
    little = scale < 0
    fmt = ("<" if little else ">") + "f"
    with open(path, "wb") as f:
        f.write(("PF\n" if chans == 3 else "Pf\n").encode())
        f.write(("%d %d\n%s\n" % (w, h, repr(scale))).encode())
        for y in reversed(range(h)):  # bottom row first
            for x in range(w):
                for v in px(x, y)[:chans]:
                    f.write(struct.pack(fmt, v))


def tile(x, y):
    # Blocks of constant colour (runs) next to gradients (literals), some values above 1.
    if x < 6:
        return (0.9, 0.2, 0.1) if y < 4 else (0.1, 0.6, 0.9)
    return (0.05 + 0.06 * x, 0.1 + 0.1 * y, 1.4 if (x + y) % 2 else 0.3)


def sky(x, y):
    u, v = (x + 0.5) / 32, (y + 0.5) / 16
    base = (0.25 + 0.5 * (1 - v), 0.3 + 0.5 * (1 - v), 0.45 + 0.6 * (1 - v))
    if y >= 8:
        base = (0.2, 0.17, 0.12)
    if abs(x - 9) <= 1 and y in (4, 5):
        base = (40.0, 34.0, 25.0)
    return base


write_hdr(os.path.join(HERE, "hdr_rle.hdr"), 16, 8, tile)
write_pfm(os.path.join(HERE, "pfm_rgb_be.pfm"), 8, 6, 3, 1.0,
          lambda x, y: (0.1 + 0.1 * x, 0.9 - 0.15 * y, 0.5 if (x // 2 + y // 2) % 2 else 0.05))
write_pfm(os.path.join(HERE, "pfm_grey_le.pfm"), 6, 4, 1, -0.5,
          lambda x, y: (0.3 + 0.25 * x + (0.6 if y % 2 else 0.0),))
write_hdr(os.path.join(DATA, "envmaps", "sky_rle.hdr"), 32, 16, sky)

# 3x3 vertex grid in the XY plane ([-1, 1]^2), 8 triangles.
verts, faces = [], []
for j in range(3):
    for i in range(3):
        verts.append((i - 1.0, j - 1.0, 0.0, 0.2 + 0.4 * i, 0.9 - 0.35 * j, 0.15 + 0.3 * ((i + j) % 2)))
for j in range(2):
    for i in range(2):
        a, b, c, d = 3 * j + i, 3 * j + i + 1, 3 * (j + 1) + i + 1, 3 * (j + 1) + i
        faces.append((a, b, c, 0.1 + 0.25 * (2 * j + i)))
        faces.append((a, c, d, 0.9 - 0.2 * (2 * j + i)))
with open(os.path.join(DATA, "geometry", "attr_grid.ply"), "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\ncomment groove mesh_attribute test\n"
             "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
             "property float red\nproperty float green\nproperty float blue\n"
             "element face %d\nproperty list uchar int vertex_indices\nproperty float shade_x\n"
             "end_header\n" % (len(verts), len(faces))).encode())
    for v in verts:
        f.write(struct.pack("<6f", *v))
    for a, b, c, s in faces:
        f.write(struct.pack("<B3if", 3, a, b, c, s))

# One triangle, extra properties of every type (values at the types' extremes).
vprops = [("uchar", "red", "B"), ("uchar", "green", "B"), ("uchar", "blue", "B"),
          ("ushort", "k_0", "H"), ("char", "c_x", "b"), ("char", "c_y", "b"), ("char", "c_z", "b"),
          ("int", "big_0", "i"), ("uint", "ub_0", "I"), ("short", "s_1", "h"),
          ("float", "f_r", "f"), ("float", "f_g", "f"), ("float", "f_b", "f"), ("double", "d_x", "d")]
vrows = [(255, 128, 0, 65535, 127, -128, 7, 2147483647, 4000000000, -32767, 0.25, 2.0, -1.0, 0.125),
         (0, 255, 64, 1000, 0, 5, -5, -2147483647, 7, 100, 1.0, 0.0, 0.5, -3.5),
         (10, 20, 30, 3, 60, -60, 1, 4, 0, 32767, 0.0, 0.0, 0.0, 1e-3)]
with open(os.path.join(DATA, "geometry", "attr_types.ply"), "wb") as f:
    f.write(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
            b"property float x\nproperty float y\nproperty float z\n")
    for t, n, _ in vprops:
        f.write(("property %s %s\n" % (t, n)).encode())
    f.write(b"element face 1\nproperty list uchar int vertex_indices\n"
            b"property uchar r\nproperty uchar g\nproperty uchar b\nproperty ushort w_0\nend_header\n")
    fmt = "<3f" + "".join(c for _, _, c in vprops)
    for p, r in zip([(0, 0, 0), (1, 0, 0), (0, 1, 0)], vrows):
        f.write(struct.pack(fmt, *p, *r))
    f.write(struct.pack("<B3iBBBH", 3, 0, 1, 2, 200, 100, 50, 40000))
