#!/usr/bin/env python3
"""Writes the procedural tangent-space normal maps of the benchmark scenes (8-bit RGB PNG,
n = 2·rgb − 1, green = +v, row 0 = v = 0 as Mitsuba reads textures). Pure Python (zlib +
struct), deterministic: the PNGs in the repository are exactly what this script writes.

    python3 scenes/bench/make_normalmaps.py [--size 256]   # writes next to this script

ripples.png   moderate: concentric ripples and a sine weave, tilt up to ~40°
grooves70.png strong: asymmetric sawtooth grooves whose steep flanks tilt 70°, crossed by a
              gentler weave; every normal is clamped to a tilt of at most 70°
"""
import argparse
import math
import os
import sys

# The PNG writer of the showcase's normal-map script (pure Python, zlib + struct).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "showcase"))
from make_normalmap import png  # noqa: E402


def ripples(u, v):
    """Height-field gradient (dh/du, dh/dv) of ripples around four centres plus a sine weave."""
    gx = gy = 0.0
    for cx, cy in ((0.25, 0.25), (0.75, 0.3), (0.3, 0.75), (0.7, 0.7)):
        dx, dy = u - cx, v - cy
        r = math.hypot(dx, dy) + 1e-9
        k = 2 * math.pi * 10
        a = 0.012 * k * math.cos(k * r) * math.exp(-3 * r)
        gx += a * dx / r
        gy += a * dy / r
    k = 2 * math.pi * 6
    gx += 0.02 * k * math.cos(k * u)
    gy += 0.02 * k * math.cos(k * v)
    return gx, gy


def grooves70(u, v):
    """Sawtooth grooves along u (steep flank 70°, gentle flank 20°) and a weave along v."""
    period = 1.0 / 16
    t = (u % period) / period
    # fraction of the period on the steep flank: tan20 / (tan20 + tan70) keeps the mean height flat
    f = math.tan(math.radians(20)) / (math.tan(math.radians(20)) + math.tan(math.radians(70)))
    gx = math.tan(math.radians(70)) if t < f else -math.tan(math.radians(20))
    k = 2 * math.pi * 10
    gy = 0.6 * math.sin(k * v)
    return gx, gy


def normal(gx, gy, max_tilt_deg):
    nx, ny, nz = -gx, -gy, 1.0
    l = math.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / l, ny / l, nz / l
    max_tilt = math.radians(max_tilt_deg)
    if math.acos(nz) > max_tilt:
        s = math.hypot(nx, ny)
        nx, ny, nz = nx / s * math.sin(max_tilt), ny / s * math.sin(max_tilt), math.cos(max_tilt)
    return nx, ny, nz


def write(path, n, gradient, max_tilt):
    rows = []
    for j in range(n):
        row = []
        for i in range(n):
            nx, ny, nz = normal(*gradient((i + 0.5) / n, (j + 0.5) / n), max_tilt)
            row += [max(0, min(255, int(round((0.5 * c + 0.5) * 255)))) for c in (nx, ny, nz)]
        rows.append(row)
    png(path, n, n, rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=256)
    a = ap.parse_args()
    here = os.path.dirname(os.path.abspath(__file__))
    write(os.path.join(here, "ripples.png"), a.size, ripples, 40.0)
    write(os.path.join(here, "grooves70.png"), a.size, grooves70, 70.0)


if __name__ == "__main__":
    main()
