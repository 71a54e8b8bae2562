#!/usr/bin/env python3
"""Writes chart.png, the normal map of the light-direction chart (chart.xml): 4 x 4 texels,
8-bit RGB, n = 2*rgb - 1 in the shading frame (x = dp/du, the light's side; row 0 = v = 0 as
Mitsuba reads textures). Pure Python, deterministic: the PNG in the repository is exactly what
this script writes.

    python3 scenes/diffuse_normalmap/make_chart.py

Columns (u): the normal tilts toward the light (+x), away from it (-x), sideways (+y), or not at
all (flat). Rows (v): tilt 20, 40, 60, 75 degrees. chart.xml lights the plane from +x and looks
straight down, so every texel is seen along the macro normal.
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "showcase"))
from make_normalmap import png  # noqa: E402

TILTS = (20.0, 40.0, 60.0, 75.0)
# azimuth of the tilt per column, degrees; None = flat
AZIMUTHS = (0.0, 180.0, 90.0, None)


def texel(tilt_deg, azimuth_deg):
    if azimuth_deg is None:
        n = (0.0, 0.0, 1.0)
    else:
        t, a = math.radians(tilt_deg), math.radians(azimuth_deg)
        n = (math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t))
    return [max(0, min(255, int(round((0.5 * c + 0.5) * 255)))) for c in n]


def main():
    rows = [sum((texel(t, a) for a in AZIMUTHS), []) for t in TILTS]
    here = os.path.dirname(os.path.abspath(__file__))
    png(os.path.join(here, "chart.png"), len(AZIMUTHS), len(TILTS), rows)


if __name__ == "__main__":
    main()
