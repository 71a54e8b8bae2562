#!/usr/bin/env python3
"""Writes the small OBJ meshes of the emitter / transform render tests (run from anywhere):

- ball.obj: a unit UV sphere (16 x 10) with smooth vertex normals (the normals of a non-unit
  `<rotate>` follow Mitsuba's quirky matrix: tests/data/scenes/rotate_axis.xml);
- quad_emit.obj / quad_emit_degenerate.obj: the unit quad [-1,1]^2 (z = 0, normal +z) as two
  triangles, and the same quad with five zero-area triangles between them (repeated and
  collinear vertices), for tests/data/scenes/degenerate_mesh.xml;
- flat_line.obj: three triangles of zero area (all vertices on a line), a mesh that cannot be hit
  or sampled.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, text):
    with open(os.path.join(HERE, name), "w") as f:
        f.write(text)


def ball(nu=16, nv=10):
    lines = ["# unit UV sphere with smooth normals (make_test_meshes.py)"]
    verts = []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu):
            ph = 2 * math.pi * i / nu
            verts.append((math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)))
    for v in verts:
        lines.append("v %.6f %.6f %.6f" % v)
    for v in verts:
        lines.append("vn %.6f %.6f %.6f" % v)
    for j in range(nv):
        for i in range(nu):
            a = j * nu + i + 1
            b = j * nu + (i + 1) % nu + 1
            c = a + nu
            d = b + nu
            # Counter-clockwise seen from outside (normals point outwards).
            if j != 0:
                lines.append("f %d//%d %d//%d %d//%d" % (a, a, b, b, c, c))
            if j != nv - 1:
                lines.append("f %d//%d %d//%d %d//%d" % (b, b, d, d, c, c))
    return "\n".join(lines) + "\n"


QUAD_V = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv 0 0 0\nv 0.5 0.5 0\n"

write("ball.obj", ball())
write("quad_emit.obj", "# unit quad, two triangles\n" + QUAD_V + "f 1 2 3\nf 1 3 4\n")
write(
    "quad_emit_degenerate.obj",
    "# unit quad, two triangles, five zero-area ones around them\n"
    + QUAD_V
    + "f 1 1 2\nf 1 2 3\nf 5 6 3\nf 2 2 2\nf 1 3 4\nf 1 5 3\nf 4 4 1\n",
)
write("flat_line.obj", "# three zero-area triangles\nv 0 0 0\nv 1 1 1\nv 2 2 2\nv 3 3 3\n"
      "f 1 2 3\nf 2 3 4\nf 1 2 4\n")
