#!/usr/bin/env python3
"""Writes sky_sun.exr: a 64x32 lat-long float32 RGB test environment for groove's emitter tests.

A dim gradient that varies along both axes (so orientation mistakes show), with a fixed random
texel-to-texel variation of ±40% (so the bilinear lookup matters, and directly seen background
pixels carry sampling noise well above float rounding), plus a bright Gaussian "sun" blob at texel
column 40, row 9. Run with the Mitsuba venv's python (uses mi.Bitmap to write):

    /work/.venv-mitsuba/bin/python tests/data/envmaps/make_envmap.py
"""
import os
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
W, H = 64, 32
x = (np.arange(W) + 0.5) / W
y = (np.arange(H) + 0.5) / H
X, Y = np.meshgrid(x, y)
img = np.zeros((H, W, 3))
img[..., 0] = 0.05 + 0.25 * (1 - Y) + 0.10 * X
img[..., 1] = 0.08 + 0.30 * (1 - Y) + 0.05 * np.sin(2 * np.pi * X) ** 2
img[..., 2] = 0.10 + 0.45 * (1 - Y)
rng = np.random.default_rng(12345)
img *= rng.uniform(0.6, 1.4, size=(H, W, 1))
# the sun: a Gaussian blob (sigma ~1.5 texels) centred on texel (40, 9)
cx, cy = 40.5, 9.5
d2 = ((np.arange(W) + 0.5 - cx)[None, :] ** 2 + (np.arange(H) + 0.5 - cy)[:, None] ** 2)
sun = 60.0 * np.exp(-d2 / (2 * 1.5 ** 2))
img[..., 0] += sun * 1.0
img[..., 1] += sun * 0.85
img[..., 2] += sun * 0.6
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "sky_sun.exr")
mi.Bitmap(np.ascontiguousarray(img, dtype=np.float32), mi.Bitmap.PixelFormat.RGB).write(out)
print(out, img.mean(axis=(0, 1)))
