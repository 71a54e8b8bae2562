#!/usr/bin/env python3
"""Renders the figure of docs/mnm.md, "Normal maps on diffuse materials": the benchmark's ripples
normal map (scenes/bench/ripples.png) on chart.xml's plane, lit from the right (+x) by a
directional light, seen straight down.

    python3 scenes/diffuse_normalmap/make_figure.py \
        [--groove target/release/groove] [-o docs/mnm-diffuse-normalmaps.png]

Rows: classic, explicit (the paper's Variant M), walk-mirror, walk-same, vgroove, ugroove.
Columns: diffuse (ρ = 0.8) with the light at elevation 10°, 30° and 60°, then rough plastic and
rough conductor at 30°. Each column has one exposure, 0.4 / (the mean of its classic image),
then sRGB; tiles are 96 × 96 px with a 2 px white gap. One thread per render. Needs numpy
and mitsuba (for reading EXR and writing the PNG).
"""
import argparse
import os
import subprocess
import tempfile

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")

HERE = os.path.dirname(os.path.abspath(__file__))
ROWS = ("classic", "explicit", "walk-mirror", "walk-same", "vgroove", "ugroove")
COLUMNS = (("diffuse", 10), ("diffuse", 30), ("diffuse", 60), ("plastic", 30), ("conductor", 30))
RES, GAP = 96, 2


def render(groove, tmp, mode, nested, elevation):
    out = os.path.join(tmp, f"{mode}.{nested}.{elevation}.exr")
    spp = 4 if nested == "diffuse" else 64
    subprocess.run([groove, "render", os.path.join(HERE, "chart.xml"), "-q", "-t", "1",
                    "--normal-mapping", mode, "-o", out,
                    "-D", "nm=../bench/ripples.png", "-D", "filter=bilinear",
                    "-D", f"nested={nested}", "-D", f"rot={-(90 + elevation)}",
                    "-D", f"spp={spp}", "-D", f"res={RES}"], check=True,
                   stdout=subprocess.DEVNULL)
    return np.array(mi.Bitmap(out), dtype=np.float64)[:, :, :3]


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--groove", default="target/release/groove")
    ap.add_argument("-o", "--output", default="docs/mnm-diffuse-normalmaps.png")
    a = ap.parse_args()
    h = len(ROWS) * RES + (len(ROWS) - 1) * GAP
    w = len(COLUMNS) * RES + (len(COLUMNS) - 1) * GAP
    fig = np.ones((h, w, 3))
    with tempfile.TemporaryDirectory() as tmp:
        for c, (nested, e) in enumerate(COLUMNS):
            tiles = [render(a.groove, tmp, mode, nested, e) for mode in ROWS]
            scale = 0.4 / tiles[0].mean()
            for r, t in enumerate(tiles):
                y, x = r * (RES + GAP), c * (RES + GAP)
                fig[y : y + RES, x : x + RES] = srgb(t * scale)
    img = mi.Bitmap((fig * 255 + 0.5).astype(np.uint8), mi.Bitmap.PixelFormat.RGB)
    img.write(a.output)
    print(f"wrote {a.output} ({w}x{h})")


if __name__ == "__main__":
    main()
