#!/usr/bin/env python3
"""Writes the million-triangle benchmark scene of issue 18 (standard library only, deterministic:
the same bytes on every run):

  million_terrain.ply  rolling hills, a (N x N)-vertex height field with analytic vertex normals:
                       2 (N - 1)^2 triangles (N = 720: 1,033,922), diffuse;
  million_spheres.ply  12 UV spheres (96 x 48 quads each, 9,024 triangles per sphere) resting on
                       the hills, rough gold;
  million.xml          the scene (Mitsuba 3 XML, loads in groove and Mitsuba 3): both meshes, an
                       area light, a dim sky; parameters $spp, $res (width), $height.

Total 1,142,210 triangles at the default N. The meshes are binary little-endian PLY (~29 MB) and
are not committed (.gitignore); the XML is committed and written here again, identically.

The files go to scenes/bench/million/ (a folder of their own: `groove bench` and the scene sweeps
take every scenes/bench/*.xml, and this scene needs its generated meshes).

Usage (from the repository root):  python3 scenes/bench/make_million.py [--n N] [--out DIR]
"""
import argparse
import math
import os
import struct

SIZE = 24.0  # the terrain spans [-SIZE/2, SIZE/2] in x and z


def height(x, z):
    """Hills: a few sines of incommensurate frequencies (y up)."""
    return (0.9 * math.sin(0.31 * x + 0.4) * math.cos(0.27 * z - 0.3)
            + 0.35 * math.sin(0.83 * x - 0.61 * z + 1.1)
            + 0.12 * math.sin(2.3 * x + 1.7 * z) * math.cos(1.9 * z - 0.5)
            + 0.04 * math.sin(6.1 * x - 4.3 * z + 0.2))


def gradient(x, z):
    """(dh/dx, dh/dz) of `height`, in closed form."""
    a = 0.31 * x + 0.4
    b = 0.27 * z - 0.3
    c = 0.83 * x - 0.61 * z + 1.1
    d = 2.3 * x + 1.7 * z
    e = 1.9 * z - 0.5
    f = 6.1 * x - 4.3 * z + 0.2
    dx = (0.9 * 0.31 * math.cos(a) * math.cos(b)
          + 0.35 * 0.83 * math.cos(c)
          + 0.12 * 2.3 * math.cos(d) * math.cos(e)
          + 0.04 * 6.1 * math.cos(f))
    dz = (-0.9 * 0.27 * math.sin(a) * math.sin(b)
          - 0.35 * 0.61 * math.cos(c)
          + 0.12 * (1.7 * math.cos(d) * math.cos(e) - 1.9 * math.sin(d) * math.sin(e))
          - 0.04 * 4.3 * math.cos(f))
    return dx, dz


def header(nv, nf):
    return ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {nv}\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            f"element face {nf}\n"
            "property list uchar int vertex_indices\nend_header\n").encode("ascii")


def write_ply(path, verts, faces):
    """verts: list of (x, y, z, nx, ny, nz); faces: list of (a, b, c), counter-clockwise seen
    from the side the normals point to."""
    vfmt = struct.Struct("<6f")
    ffmt = struct.Struct("<B3i")
    with open(path, "wb") as fh:
        fh.write(header(len(verts), len(faces)))
        fh.write(b"".join(vfmt.pack(*v) for v in verts))
        fh.write(b"".join(ffmt.pack(3, *f) for f in faces))


def terrain(n):
    verts = []
    for j in range(n):
        z = -SIZE / 2 + SIZE * j / (n - 1)
        for i in range(n):
            x = -SIZE / 2 + SIZE * i / (n - 1)
            dx, dz = gradient(x, z)
            inv = 1.0 / math.sqrt(dx * dx + 1.0 + dz * dz)
            verts.append((x, height(x, z), z, -dx * inv, inv, -dz * inv))
    faces = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            b, c, d = a + 1, a + n, a + n + 1
            # Up (+y) facing: (a, c, b) and (b, c, d) are counter-clockwise seen from above.
            faces.append((a, c, b))
            faces.append((b, c, d))
    return verts, faces


SPHERES = [(-6.0, -3.0, 0.9), (-3.5, -5.0, 0.7), (-1.0, -2.5, 1.0), (1.8, -4.5, 0.8),
           (4.5, -2.0, 1.1), (6.5, -5.5, 0.6), (-5.0, 1.5, 0.8), (-2.0, 2.5, 0.9),
           (1.0, 1.0, 0.7), (3.5, 3.0, 1.0), (6.0, 1.0, 0.8), (0.0, 5.0, 1.2)]


def spheres(nu=96, nv=48):
    verts, faces = [], []
    for cx, cz, r in SPHERES:
        cy = height(cx, cz) + 0.8 * r  # sunk a little into the ground
        base = len(verts)
        for j in range(nv + 1):
            t = math.pi * j / nv
            for i in range(nu + 1):
                p = 2 * math.pi * i / nu
                n = (math.sin(t) * math.cos(p), math.cos(t), math.sin(t) * math.sin(p))
                verts.append((cx + r * n[0], cy + r * n[1], cz + r * n[2], *n))
        for j in range(nv):
            for i in range(nu):
                a = base + j * (nu + 1) + i
                b, c, d = a + 1, a + nu + 1, a + nu + 2
                # Outward: the rows go from the north pole down, φ toward +z.
                if j != 0:
                    faces.append((a, b, c))
                if j != nv - 1:
                    faces.append((b, d, c))
    return verts, faces


XML = """<?xml version="1.0"?>
<!-- Benchmark (issue 18): {ntri:,} triangles, written by scenes/bench/make_million.py (run it
     first: the PLY meshes are not committed). Rolling hills (a {n} x {n} height field, diffuse)
     with 12 rough-gold spheres as meshes, an area light and a dim sky. Loads in groove and
     Mitsuba 3. Parameters: $spp, $res (width), $height. -->
<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="240"/>
    <default name="height" value="160"/>

    <integrator type="path">
        <integer name="max_depth" value="6"/>
    </integrator>

    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world">
            <lookat origin="0, 6.5, 14" target="0, 0, -1.5" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$height"/>
            <rfilter type="box"/>
        </film>
    </sensor>

    <shape type="ply">
        <string name="filename" value="million_terrain.ply"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.42, 0.38, 0.28"/>
        </bsdf>
    </shape>

    <shape type="ply">
        <string name="filename" value="million_spheres.ply"/>
        <bsdf type="roughconductor">
            <string name="material" value="Au"/>
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.2"/>
        </bsdf>
    </shape>

    <shape type="rectangle">
        <transform name="to_world">
            <scale x="4" y="3"/>
            <rotate x="1" angle="70"/>
            <translate x="-3" y="9" z="4"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="6"/>
        </emitter>
    </shape>
    <emitter type="constant">
        <rgb name="radiance" value="0.12, 0.14, 0.18"/>
    </emitter>
</scene>
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=720, help="terrain vertices per side (default 720)")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                  "million"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    tv, tf = terrain(a.n)
    write_ply(os.path.join(a.out, "million_terrain.ply"), tv, tf)
    sv, sf = spheres()
    write_ply(os.path.join(a.out, "million_spheres.ply"), sv, sf)
    ntri = len(tf) + len(sf)
    with open(os.path.join(a.out, "million.xml"), "w") as fh:
        fh.write(XML.format(ntri=ntri, n=a.n))
    print(f"{ntri:,} triangles ({len(tf):,} terrain, {len(sf):,} spheres) -> {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
