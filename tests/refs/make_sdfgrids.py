#!/usr/bin/env python3
"""Writes the small SDF grids of tests/data/sdfgrid/ as Mitsuba .vol files (version 3, float32,
one channel, x fastest), and with --points prints Mitsuba 3.9.1's (scalar_rgb) ray_intersect of
the rays used by tests/scene/sdfgrid.rs as Rust rows (o, d, t, p, n, sh_frame.n, or a miss).

    python3 tests/refs/make_sdfgrids.py
    /work/.venv-mitsuba/bin/python tests/refs/make_sdfgrids.py --points
"""
import math
import os
import random
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "data", "sdfgrid")


def write(path, nx, ny, nz, f):
    with open(path, "wb") as o:
        o.write(b"VOL" + bytes([3]) + struct.pack("<i", 1))
        o.write(struct.pack("<iiii", nx, ny, nz, 1))
        o.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        for z in range(nz):
            for y in range(ny):
                for x in range(nx):
                    o.write(struct.pack("<f", f(x / (nx - 1), y / (ny - 1), z / (nz - 1))))


def torus(x, y, z):
    """A torus about the y axis through the cube's centre (radii 0.28 and 0.12)."""
    x, y, z = x - 0.5, y - 0.5, z - 0.5
    return math.hypot(math.hypot(x, z) - 0.28, y) - 0.12


def blob(x, y, z):
    """A wavy ellipsoid, on a grid of unequal y and x = z sizes."""
    r = math.sqrt((x - 0.45) ** 2 / 0.9 + (y - 0.5) ** 2 + (z - 0.55) ** 2 * 1.2)
    return r - 0.33 + 0.05 * math.sin(9 * x) * math.cos(7 * y)


# name, file, normals, to_world (XML), grid
CASES = [
    ("torus_smooth", "torus16.vol", "smooth", ""),
    ("torus_analytic", "torus16.vol", "analytic",
     '<transform name="to_world"><scale x="2" y="1.5" z="1"/><translate x="-1" y="0.2"/></transform>'),
    ("blob_smooth", "blob.vol", "smooth",
     '<transform name="to_world"><scale value="1.5"/><translate z="-0.3"/></transform>'),
]


def points():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    for name, fn, normals, xf in CASES:
        xml = (f'<scene version="3.0.0"><shape type="sdfgrid"><string name="filename" '
               f'value="{os.path.join(OUT, fn)}"/><string name="normals" value="{normals}"/>'
               f'{xf}</shape></scene>')
        sc = mi.load_string(xml)
        bb = sc.shapes()[0].bbox()
        lo, hi = [float(v) for v in bb.min], [float(v) for v in bb.max]
        random.seed(7)
        print(f"// {name}")
        for _ in range(12):
            t = [lo[k] + (hi[k] - lo[k]) * random.uniform(0.25, 0.75) for k in range(3)]
            axis = random.randrange(3)
            o = [lo[k] + (hi[k] - lo[k]) * random.uniform(-0.1, 1.1) for k in range(3)]
            o[axis] = hi[axis] + 2.0 if random.random() < 0.5 else lo[axis] - 2.0
            d = [t[k] - o[k] for k in range(3)]
            n = math.sqrt(sum(v * v for v in d))
            d = [v / n for v in d]
            si = sc.ray_intersect(mi.Ray3f(mi.Point3f(o), mi.Vector3f(d)))
            f = lambda v: "[" + ", ".join(f"{float(x):.7}" for x in v) + "]"
            if not si.is_valid():
                print(f"({f(o)}, {f(d)}, None),")
            else:
                print(f"({f(o)}, {f(d)}, Some(({float(si.t):.7}, {f(si.p)}, {f(si.n)}, {f(si.sh_frame.n)}))),")


if __name__ == "__main__":
    if "--points" in sys.argv:
        points()
    else:
        os.makedirs(OUT, exist_ok=True)
        write(os.path.join(OUT, "torus16.vol"), 16, 16, 16, torus)
        write(os.path.join(OUT, "blob.vol"), 12, 9, 12, blob)
