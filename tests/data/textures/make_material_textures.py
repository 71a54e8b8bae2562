#!/usr/bin/env python3
"""Write the small procedural textures of the mask / bumpmap / textured-roughness / textured-light
reference scenes (tests/data/scenes/{bump_plane,mat_roughconductor_tex,light_area_tex}.xml).

    python3 tests/data/textures/make_material_textures.py   (needs numpy and Pillow, or Mitsuba's venv)

* bump_height.png  32x32 8-bit grey, height h = 0.5 + 0.4 sin(2 pi 2u) cos(2 pi 3v) (read raw)
* alpha_stripes.png 16x16 8-bit grey, roughness ramp 0.05 .. 0.6 along u with a finer v ripple (raw)
* emit_tiles.png   8x8 8-bit sRGB colour tiles (an area light's radiance texture)
"""
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def save(name, arr):
    arr = np.clip(np.rint(arr * 255.0), 0, 255).astype(np.uint8)
    try:
        from PIL import Image

        Image.fromarray(arr).save(os.path.join(HERE, name))
    except ImportError:  # Mitsuba's own writer
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
        pf = mi.Bitmap.PixelFormat.Y if arr.ndim == 2 else mi.Bitmap.PixelFormat.RGB
        mi.Bitmap(arr, pf).write(os.path.join(HERE, name))


def centres(n):
    return (np.arange(n) + 0.5) / n


def main():
    u, v = np.meshgrid(centres(32), centres(32))
    save("bump_height.png", 0.5 + 0.4 * np.sin(2 * np.pi * 2 * u) * np.cos(2 * np.pi * 3 * v))

    u, v = np.meshgrid(centres(16), centres(16))
    save("alpha_stripes.png", 0.05 + 0.55 * u + 0.04 * np.sin(2 * np.pi * 2 * v))

    rng = np.random.default_rng(7)
    tiles = rng.uniform(0.15, 1.0, size=(8, 8, 3))
    tiles[::2, ::2] = 1.0
    save("emit_tiles.png", tiles)


if __name__ == "__main__":
    main()
