#!/usr/bin/env python3
"""The figure of docs/consistency.md: tests/data/scenes/ptracer_nmap.xml (flip and shadowing off)
rendered by groove with `path` and with `ptracer`, classic and microfacet (walk-mirror) normal
mapping, and the difference ptracer − path (red: light tracing brighter, blue: darker; scale ±0.1).

    python3 docs/consistency/make_figure.py target/release/groove  (a python with mitsuba 3.9.1, numpy)

Writes docs/consistency/nmap_path_vs_ptracer.png (rows: classic, walk-mirror; columns: path,
ptracer, difference) and prints the per-row image means.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
SCENE = os.path.join(REPO, "tests", "data", "scenes", "ptracer_nmap.xml")


def render(groove, mode, integrator, spp, out):
    subprocess.run([groove, "render", "-q", SCENE, "-D", f"integrator={integrator}", "-D",
                    "flip=false", "-D", "shadow=false", "-D", "res=96", "--normal-mapping", mode,
                    "--spp", str(spp), "--seed", "1", "-t", "2", "-o", out], check=True)
    return np.array(mi.Bitmap(out), dtype=np.float64)[:, :, :3]


def srgb(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def main():
    groove = sys.argv[1]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for mode in ["classic", "walk-mirror"]:
            a = render(groove, mode, "path", 1024, os.path.join(tmp, "a.exr"))
            b = render(groove, mode, "ptracer", 2048, os.path.join(tmp, "b.exr"))
            d = (b - a).mean(axis=2) / 0.1
            diff = np.stack([np.clip(d, 0, 1), np.zeros_like(d), np.clip(-d, 0, 1)], axis=2)
            print(f"{mode}: path mean {a.mean(axis=(0, 1))}, ptracer mean {b.mean(axis=(0, 1))}")
            rows.append(np.concatenate([srgb(a), srgb(b), diff], axis=1))
    img = np.concatenate(rows, axis=0).astype(np.float32)
    bmp = mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB)
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=False)
    bmp.write(os.path.join(HERE, "nmap_path_vs_ptracer.png"))


if __name__ == "__main__":
    main()
