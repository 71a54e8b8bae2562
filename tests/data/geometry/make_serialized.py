#!/usr/bin/env python3
"""Write the Mitsuba `serialized` mesh fixtures used by tests/data/scenes/serialized.xml.

    /work/.venv-mitsuba/bin/python tests/data/geometry/make_serialized.py

(any Python 3 with numpy works; zlib and struct are in the standard library). Written next to this
script, both little endian, every mesh a header (u16 0x041C, u16 version) + one zlib stream, and
the end-of-file dictionary of mesh offsets + u32 count:

* `two_meshes_v4.serialized` (version 4, u64 dictionary offsets):
  mesh 0 "uv_sphere": a 10 x 20 latitude-longitude sphere, single precision, with the analytic
  (unit, radial) vertex normals and uvs u = longitude / 2pi, v = latitude / pi;
  mesh 1 "blob": a once-subdivided octahedron pushed out to a bumpy radius, double precision, with
  stored normals and per-vertex colours (the scene loads it with face_normals = true, so both are
  read past and the blob is flat shaded).
* `torus_v3.serialized` (version 3: no name, u32 dictionary offsets): one 8 x 16 torus with
  positions and faces only, so the loader computes vertex normals.

Mitsuba 3.9.1 loading these files (tests/refs/make_refs.py job `serialized`) is the check that
this writer and groove's reader agree with the format.
"""
import os
import struct
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))

HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS = 0x1, 0x2, 0x8
SINGLE, DOUBLE = 0x1000, 0x2000


def mesh_stream(version, name, pos, faces, normals=None, uvs=None, colors=None, double=False):
    """One mesh: the uncompressed header and the zlib-compressed body."""
    flags = DOUBLE if double else SINGLE
    flags |= HAS_NORMALS if normals is not None else 0
    flags |= HAS_TEXCOORDS if uvs is not None else 0
    flags |= HAS_COLORS if colors is not None else 0
    ft = "<f8" if double else "<f4"
    body = struct.pack("<I", flags)
    if version == 4:
        body += name.encode("utf-8") + b"\0"
    body += struct.pack("<QQ", len(pos), len(faces))
    for arr in (pos, normals, uvs, colors):
        if arr is not None:
            body += np.ascontiguousarray(arr, dtype=ft).tobytes()
    body += np.ascontiguousarray(faces, dtype="<u4").tobytes()
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body, 9)


def write_file(path, version, streams):
    out = bytearray()
    offsets = []
    for s in streams:
        offsets.append(len(out))
        out += s
    fmt = "<Q" if version == 4 else "<I"
    for o in offsets:
        out += struct.pack(fmt, o)
    out += struct.pack("<I", len(streams))
    with open(path, "wb") as f:
        f.write(out)
    print(f"{os.path.relpath(path)}: {len(out)} bytes, {len(streams)} mesh(es)")


def uv_sphere(n_lat=10, n_lon=20):
    """Vertices on a (n_lat + 1) x (n_lon + 1) grid (seam and poles duplicated for the uvs)."""
    pos, nrm, uv = [], [], []
    for i in range(n_lat + 1):
        theta = np.pi * i / n_lat
        for j in range(n_lon + 1):
            phi = 2 * np.pi * j / n_lon
            p = [np.sin(theta) * np.cos(phi), np.cos(theta), -np.sin(theta) * np.sin(phi)]
            pos.append(p)
            nrm.append(p)
            uv.append([j / n_lon, i / n_lat])
    faces = []
    w = n_lon + 1
    for i in range(n_lat):
        for j in range(n_lon):
            a, b, c, d = i * w + j, i * w + j + 1, (i + 1) * w + j, (i + 1) * w + j + 1
            # Counter-clockwise seen from outside: outward geometric normals.
            if i != 0:
                faces.append([a, c, b])
            if i != n_lat - 1:
                faces.append([b, c, d])
    return np.array(pos), np.array(faces), np.array(nrm), np.array(uv)


def blob():
    """An octahedron subdivided once (18 vertices, 32 faces), radius 1 + 0.15 sin(3x) cos(2y)."""
    v = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    f = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    mid = {}

    def midpoint(a, b):
        k = (min(a, b), max(a, b))
        if k not in mid:
            m = np.add(v[a], v[b]) / 2.0
            v.append(list(m / np.linalg.norm(m)))
            mid[k] = len(v) - 1
        return mid[k]

    faces = []
    for a, b, c in f:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        faces += [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
    v = np.array(v, dtype=np.float64)
    r = 1.0 + 0.15 * np.sin(3 * v[:, 0]) * np.cos(2 * v[:, 1])
    pos = v * r[:, None]
    colors = np.stack([r - 0.8, np.full(len(v), 0.5), 1.0 - v[:, 2] ** 2], axis=1)
    return pos, np.array(faces), v, colors


def torus(n_major=16, n_minor=8, R=1.0, r=0.35):
    """Positions and faces only (no seam duplication: a closed, manifold torus)."""
    pos = []
    for i in range(n_major):
        u = 2 * np.pi * i / n_major
        for j in range(n_minor):
            t = 2 * np.pi * j / n_minor
            pos.append([(R + r * np.cos(t)) * np.cos(u), r * np.sin(t), -(R + r * np.cos(t)) * np.sin(u)])
    faces = []
    for i in range(n_major):
        for j in range(n_minor):
            a = i * n_minor + j
            b = ((i + 1) % n_major) * n_minor + j
            c = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
            d = i * n_minor + (j + 1) % n_minor
            faces += [[a, b, c], [a, c, d]]
    return np.array(pos), np.array(faces)


def check_outward(pos, faces, centre_of):
    """Every face's geometric normal (p1 - p0) x (p2 - p0) points away from `centre_of(centroid)`."""
    a, b, c = (pos[faces[:, k]] for k in range(3))
    ng = np.cross(b - a, c - a)
    cen = (a + b + c) / 3.0
    out = np.einsum("ij,ij->i", ng, cen - centre_of(cen))
    assert (out > 0).all(), f"{(out <= 0).sum()} inward faces"


def ring_centre(cen, R=1.0):
    """The nearest point of the torus's core circle (radius R in the xz plane)."""
    d = cen * [1, 0, 1]
    return d / np.linalg.norm(d, axis=1, keepdims=True) * R


def main():
    p, f, n, uv = uv_sphere()
    bp, bf, bn, bc = blob()
    check_outward(p, f, np.zeros_like)
    check_outward(bp, bf, np.zeros_like)
    write_file(os.path.join(HERE, "two_meshes_v4.serialized"), 4, [
        mesh_stream(4, "uv_sphere", p, f, normals=n, uvs=uv),
        mesh_stream(4, "blob", bp, bf, normals=bn, colors=bc, double=True),
    ])
    tp, tf = torus()
    check_outward(tp, tf, ring_centre)
    write_file(os.path.join(HERE, "torus_v3.serialized"), 3, [mesh_stream(3, "", tp, tf)])


if __name__ == "__main__":
    main()
