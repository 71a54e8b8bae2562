#!/usr/bin/env python3
"""Tier A against Embree as a visible mesh grows (issue 18): the Cornell box (Mitsuba's cbox-rgb,
38 triangles) with a latitude-longitude sphere of N triangles floating in view, left of the
large box (radius 100, so it covers about 5 % of the image and is seen by many bounces), rendered
by the stream renderer under `GROOVE_TIER=brute` and `GROOVE_TIER=embree`; instructions per
sample counted with `callgrind.sh` (one thread, `GROOVE_LANES=8`).

Usage: docs/bench/tier_triangles.py GROOVE_BINARY CBOX_DIR OUTDIR [N...]
  CBOX_DIR holds cbox-rgb.xml's fragments/ and meshes/ (the shared Mitsuba Cornell box).
  N defaults to 0 64 128 256 512 (sphere triangles; 0: no sphere).
  SPP (environment) default 2; RES (environment) the image side, default 256.
Prints one line per (N, tier) and a table at the end.
"""
import math
import os
import re
import subprocess
import sys


def sphere_obj(path, n):
    """A UV sphere of exactly n triangles: m longitude segments, k latitude bands (fans at the
    poles, two triangles per quad between), n = m·(2k − 2)."""
    for m in (8, 16, 32, 64):
        if n % m == 0 and (n // m) % 2 == 0 and n // m >= 2:
            k = n // m // 2 + 1
            if k <= m:
                break
    else:
        raise SystemExit(f"no (m, k) for {n} triangles")
    c, r = (170.0, 330.0, 300.0), 100.0
    verts = [(c[0], c[1] + r, c[2])]
    for i in range(1, k):
        th = math.pi * i / k
        for j in range(m):
            ph = 2 * math.pi * j / m
            verts.append((c[0] + r * math.sin(th) * math.cos(ph), c[1] + r * math.cos(th),
                          c[2] + r * math.sin(th) * math.sin(ph)))
    verts.append((c[0], c[1] - r, c[2]))
    ring = lambda i, j: 2 + (i - 1) * m + j % m  # 1-based OBJ index of ring i (1..k-1)
    faces = [(1, ring(1, j + 1), ring(1, j)) for j in range(m)]
    for i in range(1, k - 1):
        for j in range(m):
            a, b, cc, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            faces += [(a, b, cc), (a, cc, d)]
    last = len(verts)
    faces += [(last, ring(k - 1, j), ring(k - 1, j + 1)) for j in range(m)]
    assert len(faces) == n, (len(faces), n)
    with open(path, "w") as f:
        for v in verts:
            f.write("v %.6f %.6f %.6f\n" % v)
        for t in faces:
            f.write("f %d %d %d\n" % t)


def scene(path, cbox, obj):
    extra = ""
    if obj:
        extra = (f'<shape type="obj"><string name="filename" value="{obj}"/>'
                 '<ref id="white"/></shape>')
    with open(path, "w") as f:
        f.write(f"""<scene version="3.0.0">
    <path value="{cbox}"/>
    <include filename="fragments/base.xml"/>
    <include filename="fragments/bsdfs-rgb.xml"/>
    <include filename="fragments/shapes.xml"/>
    {extra}
    <emitter type="area" id="area-emitter">
        <rgb name="radiance" value="18.387, 10.9873, 2.75357"/>
    </emitter>
</scene>
""")


def main():
    binary, cbox, out = sys.argv[1], os.path.abspath(sys.argv[2]), sys.argv[3]
    ns = [int(a) for a in sys.argv[4:]] or [0, 64, 128, 256, 512]
    spp, res = os.environ.get("SPP", "2"), os.environ.get("RES", "256")
    here = os.path.dirname(os.path.abspath(__file__))
    os.makedirs(out, exist_ok=True)
    rows = []
    for n in ns:
        obj = os.path.join(os.path.abspath(out), f"sphere{n}.obj") if n else None
        if obj:
            sphere_obj(obj, n)
        xml = os.path.join(out, f"cbox_sphere{n}.xml")
        scene(xml, cbox, obj)
        per = {}
        for tier in ("brute", "embree"):
            env = dict(os.environ, GROOVE=binary, RENDERER="stream", GROOVE_TIER=tier,
                       GROOVE_ARGS=f"-D res={res}")
            line = subprocess.run([os.path.join(here, "callgrind.sh"), xml, "classic", spp],
                                  env=env, capture_output=True, text=True, check=True).stdout
            print(f"N={n} {tier}: {line.strip()}", flush=True)
            per[tier] = int(re.search(r"(\d+) per sample", line).group(1))
        rows.append((n, per["brute"], per["embree"]))
    print("\n| sphere triangles | scene triangles | tier A | Embree | tier A / Embree |")
    print("|---|---|---|---|---|")
    for n, b, e in rows:
        print(f"| {n} | {n + 38} | {b:,} | {e:,} | {b / e:.2f} |")


if __name__ == "__main__":
    main()
