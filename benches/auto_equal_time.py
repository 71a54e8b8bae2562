#!/usr/bin/env python3
"""The equal-time test of issue 17 (item 5 and targets): at classic normal mapping's time budget,
the RMSE against the **walk's** high-spp reference (bias and noise both counted) of
`--normal-mapping auto` and of `--normal-mapping walk-mirror` (the walk on auto's microsurface:
sawtooth, mirror wall), on the whole image of every scenes/bench scene and on every showcase
sphere.

Per-sample cost: interleaved timings (classic, walk-mirror, auto, repeated `--repeats` times at
`--time-spp`, the render seconds groove prints, median per mode), so that the machine's load
drifts alike for all modes. Where `auto` is the walk (a scene whose every normal-mapped material
has no remainder table, e.g. glass.xml's transmitting one), its timing renders equal walk-mirror's
bit for bit at the same seed: the same computation (the same instruction count per sample,
`docs/mnm.md`), so the two modes' timings are pooled into one median and they get the same spp;
otherwise a timing difference there is the machine's noise (run 3 on glass). The equal-time spp
of a mode is round(S · t_classic / t_mode) with S = `--budget-spp` (classic's spp). The reference is walk-mirror at `--ref-spp` with another
seed. Sphere masks: the showcase's spheres projected with its camera (discs of 0.85 × the
projected radius).

Usage (from the repository root, with Mitsuba's Python for reading EXRs):
  /work/.venv-mitsuba/bin/python benches/auto_equal_time.py target/release/groove OUT_DIR
Results: a Markdown table on stdout, and OUT_DIR/results.json.
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")

SCENES = [
    ("metal_plastic", "scenes/bench/metal_plastic.xml", []),
    ("strong", "scenes/bench/strong.xml", []),
    ("glass", "scenes/bench/glass.xml", []),
    ("showcase", "scenes/showcase/showcase.xml", ["-D", "spp=1", "-D", "res=480"]),
]
MODES = ["classic", "walk-mirror", "auto"]
# showcase.xml: spheres (name, centre, radius); camera lookat, fov (x axis), film size.
SPHERES = [
    ("conductor", (-3.15, 0.9, 0.0), 0.9),
    ("plastic", (-1.05, 0.9, 0.0), 0.9),
    ("dielectric", (1.05, 0.9, 0.0), 0.9),
    ("diffuse", (3.15, 0.9, 0.0), 0.9),
]
CAM = ((0.0, 3.0, 11.0), (0.0, 0.9, 0.0), (0.0, 1.0, 0.0), 42.0)


def render(groove, scene, defines, mode, spp, seed, out, threads):
    cmd = [groove, "render", scene, "--spp", str(spp), "-t", str(threads), "--seed", str(seed),
           "--normal-mapping", mode, "-o", out] + defines
    r = subprocess.run(cmd, capture_output=True, text=True, check=True)
    m = re.search(r"render ([0-9.]+) s", r.stdout + r.stderr)
    return float(m.group(1))


def load(path):
    return np.array(mi.Bitmap(path), copy=False)[:, :, :3].astype(np.float64)


def rmse(a, b, mask=None):
    d = (a - b) ** 2
    if mask is not None:
        d = d[mask]
    return float(math.sqrt(d.mean()))


def sphere_masks(h, w):
    o, t, up = (np.array(v, dtype=np.float64) for v in CAM[:3])
    fov = CAM[3]
    f = (t - o) / np.linalg.norm(t - o)
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    up2 = np.cross(right, f)
    scale = (w / 2) / math.tan(math.radians(fov) / 2)
    yy, xx = np.mgrid[0:h, 0:w]
    out = {}
    for name, c, r in SPHERES:
        d = np.array(c) - o
        z = d @ f
        px = w / 2 + (d @ right) / z * scale
        py = h / 2 - (d @ up2) / z * scale
        rp = r / np.linalg.norm(d) * scale
        out[name] = (xx + 0.5 - px) ** 2 + (yy + 0.5 - py) ** 2 <= (0.85 * rp) ** 2
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("groove")
    ap.add_argument("out")
    ap.add_argument("--budget-spp", type=int, default=16)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--time-spp", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--scenes", default=",".join(s[0] for s in SCENES))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    results = {}
    for name, scene, defines in SCENES:
        if name not in a.scenes.split(","):
            continue
        times = {m: [] for m in MODES}
        for k in range(a.repeats + 1):
            for m in MODES:
                t = render(a.groove, scene, defines, m, a.time_spp, 100 + k,
                           f"{a.out}/{name}.time.{m}.exr", a.threads)
                if k > 0:  # the first round builds the tables (disk cache) and warms up
                    times[m].append(t / a.time_spp)
        per_spp = {m: statistics.median(v) for m, v in times.items()}
        # The last round rendered every mode with the same seed: auto identical to the walk
        # bit for bit is the walk, at the walk's cost (pooled timings, one spp for both).
        same = np.array_equal(load(f"{a.out}/{name}.time.auto.exr"),
                              load(f"{a.out}/{name}.time.walk-mirror.exr"))
        if same:
            pooled = statistics.median(times["auto"] + times["walk-mirror"])
            per_spp["auto"] = per_spp["walk-mirror"] = pooled
        ref = f"{a.out}/{name}.ref.walk-mirror.{a.ref_spp}.exr"
        if not os.path.exists(ref):
            render(a.groove, scene, defines, "walk-mirror", a.ref_spp, 1, ref, a.threads)
        refimg = load(ref)
        masks = sphere_masks(*refimg.shape[:2]) if name == "showcase" else {}
        budget = a.budget_spp * per_spp["classic"]
        row = {"per_spp_seconds": per_spp, "budget_seconds": budget, "auto_is_walk": same}
        for m in ["walk-mirror", "auto"]:
            spp = max(1, round(budget / per_spp[m]))
            img_path = f"{a.out}/{name}.{m}.{spp}.exr"
            render(a.groove, scene, defines, m, spp, 7, img_path, a.threads)
            img = load(img_path)
            row[m] = {"spp": spp, "rmse": rmse(img, refimg),
                      "spheres": {s: rmse(img, refimg, mk) for s, mk in masks.items()}}
        results[name] = row
        with open(f"{a.out}/results.json", "w") as fh:
            json.dump(results, fh, indent=1)
    print("| scene / region | classic s/spp | walk-mirror s/spp | auto s/spp | spp walk / auto "
          "| RMSE walk | RMSE auto | auto/walk |")
    print("|---|---|---|---|---|---|---|---|")
    for name, r in results.items():
        w, au = r["walk-mirror"], r["auto"]
        p = r["per_spp_seconds"]
        label = f"{name} (image{', auto = walk' if r['auto_is_walk'] else ''})"
        print(f"| {label} | {p['classic']:.3f} | {p['walk-mirror']:.3f} | {p['auto']:.3f} "
              f"| {w['spp']} / {au['spp']} | {w['rmse']:.5f} | {au['rmse']:.5f} "
              f"| {au['rmse'] / w['rmse']:.3f} |")
        for s in w["spheres"]:
            print(f"| {name} {s} sphere | | | | | {w['spheres'][s]:.5f} | {au['spheres'][s]:.5f} "
                  f"| {au['spheres'][s] / w['spheres'][s]:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
