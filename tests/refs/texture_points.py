#!/usr/bin/env python3
"""Texture fixtures and Mitsuba 3.9.1 point evaluations for groove's texture tests.

    /work/.venv-mitsuba/bin/python tests/refs/texture_points.py

1. Writes the small fixture images under tests/data/textures/ (PNGs with a minimal writer of our
   own, so their exact bytes are known: 8/16-bit, grey, grey+alpha, RGB, RGBA; EXRs and a JPEG
   through mi.Bitmap).
2. Evaluates Mitsuba 3.9.1 (scalar_rgb) textures at a fixed set of uvs for each case below and
   writes tests/data/textures/points.json: for every case the <texture> XML (loaded as is by
   Mitsuba with mi.load_string and by groove inside a scene), the uvs, Mitsuba's tex.eval(si)
   RGB and tex.mean(). tests/scene/texture.rs compares groove against it.
"""
import json
import os
import struct
import sys
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(REPO, "tests", "data", "textures")


def write_png(path, pixels, bitdepth=8):
    """pixels: rows (first row = top of the image) of pixels (tuples of 1-4 channel values)."""
    h, w, c = len(pixels), len(pixels[0]), len(pixels[0][0])
    ctype = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    fmt = ">B" if bitdepth == 8 else ">H"
    raw = b"".join(b"\x00" + b"".join(struct.pack(fmt, v) for px in row for v in px)
                   for row in pixels)

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    data = (b"\x89PNG\r\n\x1a\n"
            + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bitdepth, ctype, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(data)


class Lcg:
    """Deterministic pseudo-random integers (fixtures must not change between runs)."""

    def __init__(self, seed):
        self.s = seed

    def next(self, n):
        self.s = (self.s * 6364136223846793005 + 1442695040888963407) % (1 << 64)
        return (self.s >> 33) % n


def image(w, h, c, maxv, seed, specials=()):
    r = Lcg(seed)
    px = [[tuple(r.next(maxv + 1) for _ in range(c)) for _ in range(w)] for _ in range(h)]
    for (x, y), v in specials:
        px[y][x] = v
    return px


def make_fixtures(mi):
    os.makedirs(OUT, exist_ok=True)
    # 8-bit RGB 5x4: black, white and the codes either side of the sRGB linear-segment threshold.
    write_png(os.path.join(OUT, "rgb8.png"),
              image(5, 4, 3, 255, 1, [((0, 0), (0, 10, 11)), ((4, 3), (255, 255, 255)),
                                      ((2, 1), (128, 1, 254))]))
    write_png(os.path.join(OUT, "rgba8.png"),
              image(4, 3, 4, 255, 2, [((0, 0), (200, 100, 50, 0)), ((1, 0), (20, 40, 60, 128))]))
    write_png(os.path.join(OUT, "grey8.png"), image(3, 4, 1, 255, 3))
    write_png(os.path.join(OUT, "greya8.png"), image(3, 2, 2, 255, 4))
    write_png(os.path.join(OUT, "rgb16.png"),
              image(4, 3, 3, 65535, 5, [((0, 0), (0, 1, 65535)), ((1, 0), (1000, 30000, 50000))]),
              bitdepth=16)
    write_png(os.path.join(OUT, "grey16.png"), image(3, 3, 1, 65535, 6), bitdepth=16)
    # 1 pixel wide: Mitsuba up-samples images narrower than 2 pixels to 2.
    write_png(os.path.join(OUT, "thin.png"), [[(255, 0, 0)], [(0, 255, 0)], [(0, 0, 255)]])
    # A colourful 8x6 image for the render test (orientation is visible: red top-left).
    r = Lcg(7)
    render = [[(255, 0, 0) if (x, y) == (0, 0) else
               (r.next(256), r.next(256), r.next(256)) for x in range(8)] for y in range(6)]
    write_png(os.path.join(OUT, "render8x6.png"), render)

    # EXRs: float32 with values outside [0, 1], a one-channel (Y) image, and float16.
    a = np.array([[[2.5, 0.5, -0.25], [0.1, 0.2, 0.3], [1.0, 1.0, 1.0], [0.0, 4.0, 0.0]],
                  [[0.7, 0.3, 0.1], [0.05, 0.9, 0.4], [0.33, 0.66, 0.99], [0.2, 0.2, 0.8]],
                  [[1.5, 0.0, 0.25], [0.6, 0.6, 0.1], [0.01, 0.02, 0.03], [0.9, 0.1, 0.5]]],
                 dtype=np.float32)
    mi.Bitmap(a, mi.Bitmap.PixelFormat.RGB).write(os.path.join(OUT, "rgb32.exr"))
    mi.Bitmap(np.ascontiguousarray(a[:2, :3, 1:2]), mi.Bitmap.PixelFormat.Y).write(
        os.path.join(OUT, "grey.exr"))
    mi.Bitmap(np.ascontiguousarray(a[:, :3, :]).astype(np.float16),
              mi.Bitmap.PixelFormat.RGB).write(os.path.join(OUT, "half.exr"))
    # A JPEG (decoders may differ by a code value or so: compared with a looser tolerance).
    jp = np.array(image(8, 8, 3, 255, 8), dtype=np.uint8)
    mi.Bitmap(jp).write(os.path.join(OUT, "rgb8.jpg"))


UVS = [(0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (0.999, 0.001), (0.1, 0.125), (0.3, 0.375),
       (0.9, 0.875), (0.05, 0.95), (0.73, 0.21), (0.62, 0.58), (-0.25, 0.3), (1.25, 0.3),
       (0.3, -0.25), (0.3, 1.25), (-0.25, -0.25), (1.25, 1.25), (2.6, -1.3), (-3.7, 0.45),
       (1.9, 0.55), (-1.1, 2.2), (-0.02, 0.51)]


def bitmap(filename, **kw):
    props = "".join(
        f'<boolean name="{k}" value="{str(v).lower()}"/>' if isinstance(v, bool)
        else f'<string name="{k}" value="{v}"/>' for k, v in kw.items() if k != "to_uv")
    if "to_uv" in kw:
        props += f'<transform name="to_uv">{kw["to_uv"]}</transform>'
    return f'<texture type="bitmap"><string name="filename" value="{filename}"/>{props}</texture>'


def cases():
    out = []
    for raw in (False, True):
        for ft in ("bilinear", "nearest"):
            for wm in ("repeat", "mirror", "clamp"):
                out.append((bitmap("rgb8.png", raw=raw, filter_type=ft, wrap_mode=wm), (5, 4), 1e-5))
    out += [
        (bitmap("rgba8.png"), (4, 3), 1e-5),
        (bitmap("rgba8.png", raw=True, filter_type="nearest"), (4, 3), 1e-5),
        (bitmap("grey8.png"), (3, 4), 1e-5),
        (bitmap("grey8.png", filter_type="nearest", wrap_mode="mirror"), (3, 4), 1e-5),
        (bitmap("greya8.png"), (3, 2), 1e-5),
        (bitmap("rgb16.png"), (4, 3), 1e-5),
        (bitmap("rgb16.png", raw=True, wrap_mode="clamp"), (4, 3), 1e-5),
        # Storage precision: 'auto' keeps 8-bit codes exact and stores 16-bit data as float16.
        (bitmap("rgb16.png", format="variant"), (4, 3), 1e-5),
        (bitmap("rgb8.png", format="fp16"), (5, 4), 1e-5),
        (bitmap("rgb32.exr", format="fp16"), (4, 3), 1e-5),
        (bitmap("grey16.png"), (3, 3), 1e-5),
        (bitmap("rgb32.exr"), (4, 3), 1e-5),
        (bitmap("rgb32.exr", wrap_mode="mirror"), (4, 3), 1e-5),
        (bitmap("rgb32.exr", filter_type="nearest", wrap_mode="clamp"), (4, 3), 1e-5),
        (bitmap("grey.exr"), (3, 2), 1e-5),
        (bitmap("half.exr"), (3, 3), 1e-5),
        (bitmap("half.exr", raw=True, wrap_mode="mirror"), (3, 3), 1e-5),
        (bitmap("thin.png"), (1, 3), 1e-5),
        (bitmap("thin.png", wrap_mode="clamp", filter_type="nearest"), (1, 3), 1e-5),
        (bitmap("rgb8.png", to_uv='<scale x="2" y="3"/>'), (5, 4), 1e-5),
        (bitmap("rgb8.png", to_uv='<translate x="0.25" y="0.1" z="0.3"/>'), (5, 4), 1e-5),
        (bitmap("rgb8.png", to_uv='<scale x="2" y="0.5"/><rotate z="1" angle="30"/>'
                '<translate x="-0.2" y="0.7"/>'), (5, 4), 1e-5),
        (bitmap("rgb8.png", wrap_mode="mirror",
                to_uv='<matrix value="1.5 0.25 0.5 0.125  -0.5 2 0.25 0.0625  0 0 1 0  0 0 0 1"/>'),
         (5, 4), 1e-5),
        (bitmap("render8x6.png"), (8, 6), 1e-5),
        ('<texture type="checkerboard"/>', (1, 1), 1e-6),
        ('<texture type="checkerboard"><rgb name="color0" value="0.9, 0.1, 0.2"/>'
         '<rgb name="color1" value="0.05, 0.6, 0.3"/>'
         '<transform name="to_uv"><scale x="3" y="2"/><translate x="0.1" y="0.05"/></transform>'
         '</texture>', (1, 1), 1e-6),
        # JPEG decoders (libjpeg vs the image crate) may round a few codes differently.
        (bitmap("rgb8.jpg"), (8, 8), 2e-2),
    ]
    return out


def main():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Error)
    make_fixtures(mi)
    old = os.getcwd()
    os.chdir(OUT)  # filenames in the XML are relative to the fixtures folder
    try:
        records = []
        for xml, (w, h), tol in cases():
            tex = mi.load_string(xml.replace("<texture ", '<texture version="3.0.0" ', 1))
            uvs = list(UVS)
            # Texel centres (exact values under bilinear filtering).
            uvs += [((x + 0.5) / w, (y + 0.5) / h) for x, y in [(0, 0), (w - 1, h - 1), (w // 2, h // 2)]]
            si = mi.SurfaceInteraction3f()
            pts = []
            for u, v in uvs:
                si.uv = mi.Point2f(u, v)
                c = tex.eval(si)
                pts.append([u, v] + [float(f"{float(c[i]):.9g}") for i in range(3)])
            records.append({"xml": xml, "tolerance": tol, "mean": float(f"{float(tex.mean()):.9g}"),
                            "points": pts})
    finally:
        os.chdir(old)
    path = os.path.join(OUT, "points.json")
    # One case header and one point per line: small diffs when something changes.
    lines = ['{"mitsuba": %s, "variant": "scalar_rgb", "generator": "tests/refs/texture_points.py",'
             % json.dumps(mi.__version__), '"cases": [']
    for i, r in enumerate(records):
        lines.append('{"xml": %s, "tolerance": %s, "mean": %s, "points": ['
                     % (json.dumps(r["xml"]), json.dumps(r["tolerance"]), json.dumps(r["mean"])))
        lines += [json.dumps(p) + ("," if j + 1 < len(r["points"]) else "")
                  for j, p in enumerate(r["points"])]
        lines.append("]}" + ("," if i + 1 < len(records) else ""))
    lines.append("]}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {len(records)} cases, {sum(len(r['points']) for r in records)} points to {path}")


if __name__ == "__main__":
    sys.exit(main())
