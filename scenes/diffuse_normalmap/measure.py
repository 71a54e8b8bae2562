#!/usr/bin/env python3
"""Measures the light-direction shading of each normal-mapping model on chart.xml (the table of
docs/mnm.md, "Normal maps on diffuse materials").

    python3 scenes/diffuse_normalmap/measure.py \
        [--groove target/release/groove] [--nested diffuse] [--spp 16] [--elevations 10,30,60]

For each model (`--normal-mapping` mode) and light elevation e it renders the chart with one
thread and prints, per tilt θp, the radiance of the texels tilted toward the light (T), away
from it (A) and sideways (S), each divided by the flat texel's (F), the contrast
C = (T − A)/(T + A) with its standard error, and the darkening (T + A + 2S)/(4F), the mean
over the four azimuths. The orthographic camera looks from -y at elevation --view (default
straight down), so every pixel of a texel sees it along one direction and a block's pixels are
independent estimates of one value: its standard error is the pixels' standard deviation over
√n. Needs numpy and mitsuba (for reading EXR).
"""
import argparse
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")

HERE = os.path.dirname(os.path.abspath(__file__))
MODES = ("classic", "explicit", "explicit4", "walk-mirror", "walk-same", "vgroove", "ugroove")
TILTS = (20, 40, 60, 75)  # rows of chart.png, v = 0 first (make_chart.py)
COLUMNS = ("T", "A", "S", "F")  # columns of chart.png, u = 0 first


def blocks(path, res, view):
    """Per texel (row = tilt index, col): the mean of the RGB mean over the central half (in
    each axis) of the texel's pixels, and its standard error. The film spans [-1, 1]² of the
    camera; the plane's y is foreshortened by sin(view) and its top (v = 1, texel row 3) is
    the image's top."""
    a = np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3].mean(axis=2)
    s = math.sin(math.radians(view))
    b = res // 4
    out = {}
    for r in range(4):
        # texel row r spans y in [-1 + r/2, -0.5 + r/2]; its central half, in image rows
        y_top, y_bottom = -1 + 0.5 * r + 0.375, -1 + 0.5 * r + 0.125
        i0, i1 = (int(round((1 - s * y) / 2 * res)) for y in (y_top, y_bottom))
        for c in range(4):
            px = a[i0:i1, c * b + b // 4 : c * b + 3 * b // 4].ravel()
            out[r, c] = (px.mean(), px.std(ddof=1) / math.sqrt(px.size))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--groove", default="target/release/groove")
    ap.add_argument("--nested", default="diffuse")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--elevations", default="10,30,60")
    ap.add_argument("--modes", default=",".join(MODES))
    ap.add_argument("--view", type=float, default=90.0,
                    help="camera elevation, degrees (90: straight down; it looks from -y)")
    a = ap.parse_args()
    scene = os.path.join(HERE, "chart.xml")
    v = math.radians(a.view)
    print(f"nested = {a.nested}, view elevation {a.view:g}°, {a.res}x{a.res} px, {a.spp} spp")
    print("| model | e | θp | T/F | A/F | S/F | C = (T−A)/(T+A) | darkening |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for mode in a.modes.split(","):
            for e in (float(x) for x in a.elevations.split(",")):
                out = os.path.join(tmp, "chart.exr")
                cmd = [a.groove, "render", scene, "-q", "-t", "1", "--normal-mapping", mode,
                       "-o", out, "-D", f"rot={-(90 + e)}", "-D", f"nested={a.nested}",
                       "-D", f"spp={a.spp}", "-D", f"res={a.res}",
                       "-D", f"cy={-5 * math.cos(v):.6f}", "-D", f"cz={5 * math.sin(v):.6f}"]
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
                bl = blocks(out, a.res, a.view)
                for r, tilt in enumerate(TILTS):
                    (t, st), (aw, sa), (s, _), (f, _) = (bl[r, c] for c in range(4))
                    den = t + aw
                    c = (t - aw) / den if den > 0 else float("nan")
                    # error propagation of C for independent T and A
                    sc = 2 * math.hypot(aw * st, t * sa) / den**2 if den > 0 else float("nan")
                    print(f"| {mode} | {e:g}° | {tilt}° | {t / f:.3f} | {aw / f:.3f} | {s / f:.3f} "
                          f"| {c:+.3f} ± {sc:.3f} | {(t + aw + 2 * s) / (4 * f):.3f} |")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
