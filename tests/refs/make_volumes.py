#!/usr/bin/env python3
"""Writes the small heterogeneous-medium grids of tests/data/volumes/ as Mitsuba .vol files
(version 3, float32, x fastest, then y, then z, channels innermost):

    blob.vol             24 x 20 x 16, 1 channel: two overlapping Gaussian density blobs (smooth,
                         asymmetric, so that a transposed or mirrored grid renders differently)
    blob_transposed.vol  the same values with the x and y axes exchanged (20 x 24 x 16): the
                         sensitivity variant of the render test
    checker.vol          8 x 8 x 8, 3 channels: a 3-D checkerboard of two chromatic extinctions
                         (sharp variation, for the nearest filter)
    albedo_grid.vol      16 x 12 x 8, 3 channels: a smooth chromatic albedo for a homogeneous medium
                         (red grows with x², green oscillates in y, blue falls with x·z; values
                         0.1 .. 0.95); prints its mean (the constant-albedo sensitivity variant)
    albedo_grid_flipped.vol  the same mirrored in x (the other sensitivity variant)
    ramp_box.vol         6 x 4 x 2, 1 channel, bounding box (-1, 0, 2) .. (2, 1, 3): value x + 10 y
                         + 100 z at voxel (x, y, z), for the loader's use_grid_bbox and index-order
                         checks

    python3 tests/refs/make_volumes.py
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "data", "volumes")


def write(path, n, channels, f, bbox=(0, 0, 0, 1, 1, 1)):
    nx, ny, nz = n
    with open(path, "wb") as o:
        o.write(b"VOL" + bytes([3]) + struct.pack("<i", 1))
        o.write(struct.pack("<iiii", nx, ny, nz, channels))
        o.write(struct.pack("<6f", *bbox))
        for z in range(nz):
            for y in range(ny):
                for x in range(nx):
                    v = f(x, y, z)
                    if channels == 1:
                        v = (v,)
                    o.write(struct.pack("<%df" % channels, *v))


def blob_at(u, v, w):
    """Density at voxel-centre coordinates (u, v, w) in [0, 1]^3."""
    def g(c, s):
        d2 = (u - c[0]) ** 2 + (v - c[1]) ** 2 + (w - c[2]) ** 2
        return math.exp(-d2 / (2 * s * s))
    return 1.0 * g((0.35, 0.6, 0.5), 0.17) + 0.8 * g((0.72, 0.3, 0.45), 0.12)


def main():
    os.makedirs(OUT, exist_ok=True)
    n = (24, 20, 16)

    def blob(x, y, z):
        return blob_at((x + 0.5) / n[0], (y + 0.5) / n[1], (z + 0.5) / n[2])

    write(os.path.join(OUT, "blob.vol"), n, 1, blob)
    # Transposed: voxel (x, y, z) of the new grid holds the old (y, x, z).
    write(os.path.join(OUT, "blob_transposed.vol"), (n[1], n[0], n[2]), 1,
          lambda x, y, z: blob(y, x, z))

    def checker(x, y, z):
        return (2.5, 1.0, 0.2) if (x + y + z) % 2 else (0.1, 0.5, 1.5)

    write(os.path.join(OUT, "checker.vol"), (8, 8, 8), 3, checker)
    na = (16, 12, 8)

    def albedo(x, y, z):
        u, v, w = (x + 0.5) / na[0], (y + 0.5) / na[1], (z + 0.5) / na[2]
        return (0.1 + 0.85 * u * u,
                0.2 + 0.35 * (1 + math.cos(2 * math.pi * v)),
                0.9 - 0.7 * u * w)

    write(os.path.join(OUT, "albedo_grid.vol"), na, 3, albedo)
    write(os.path.join(OUT, "albedo_grid_flipped.vol"), na, 3,
          lambda x, y, z: albedo(na[0] - 1 - x, y, z))
    vals = [albedo(x, y, z) for z in range(na[2]) for y in range(na[1]) for x in range(na[0])]
    print("albedo_grid.vol mean: %s" % ", ".join(
        "%.6f" % (sum(v[c] for v in vals) / len(vals)) for c in range(3)))
    write(os.path.join(OUT, "ramp_box.vol"), (6, 4, 2), 1,
          lambda x, y, z: x + 10.0 * y + 100.0 * z, bbox=(-1, 0, 2, 2, 1, 3))


if __name__ == "__main__":
    main()
