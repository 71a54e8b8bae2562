#!/usr/bin/env python3
"""path vs ptracer on one scene, per 8x8 tile, in groove or in Mitsuba 3.

Renders the scene K times with its `path` integrator and K times with a `ptracer` of the same
settings (the first `<integrator type="path"` of the file made `ptracer`), each render with its
own seed, and compares the tile means by Welch's t (K - 1 degrees of freedom a side: light
tracing's pixels are correlated, so only whole independent renders give a tile's variance).
Prints the whole-image ratio ptracer / path and the tiles with the largest |t|, and optionally
the per-pixel means and differences of a window. Used for docs/consistency.md, "Open curve ends".

    python3 path_vs_ptracer_tiles.py SCENE.xml --groove target/release/groove [-D k=v ...]
    python3 path_vs_ptracer_tiles.py SCENE.xml --mitsuba llvm_ad_rgb [-D k=v ...]

Needs numpy and Mitsuba 3 (also to read groove's EXRs). Mitsuba 3.9.1's scalar_rgb `ptracer`
crashed (segfault in ptracer.so) on tests/data/scenes/shape_curves.xml; llvm_ad_rgb does not.
"""

import argparse
import os
import re
import subprocess
import tempfile

import numpy as np
import mitsuba as mi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--groove", help="the groove binary")
    g.add_argument("--mitsuba", help="a Mitsuba 3 variant, e.g. llvm_ad_rgb")
    ap.add_argument("-D", action="append", default=[], help="scene parameter key=value")
    ap.add_argument("--spp-path", type=int, default=256)
    ap.add_argument("--spp-pt", type=int, default=256)
    ap.add_argument("-k", type=int, default=8, help="renders per side")
    ap.add_argument("--block", type=int, default=8)
    ap.add_argument("--show", help="y0,y1,x0,x1: print this window's pixels (channel mean)")
    a = ap.parse_args()

    mi.set_variant(a.mitsuba or "scalar_rgb")
    text = open(a.scene).read()
    pt_text = re.sub(r'<integrator type="path"', '<integrator type="ptracer"', text, count=1)
    assert pt_text != text, "no <integrator type=\"path\" in the scene"
    folder = os.path.dirname(os.path.abspath(a.scene))
    defines = dict(d.split("=", 1) for d in a.D)
    with tempfile.TemporaryDirectory() as tmp:
        # The ptracer copy lives next to the scene, so that its relative paths resolve.
        fd, pt_scene = tempfile.mkstemp(suffix=".xml", prefix=".ptracer_", dir=folder)
        with os.fdopen(fd, "w") as f:
            f.write(pt_text)
        try:
            def render(scene, spp, seed):
                if a.groove:
                    out = os.path.join(tmp, "img.exr")
                    cmd = [a.groove, "render", scene, "-o", out, "--spp", str(spp),
                           "--seed", str(seed), "-q"]
                    for d in a.D:
                        cmd += ["-D", d]
                    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
                    return np.array(mi.Bitmap(out), dtype=np.float64)[..., :3]
                s = mi.load_file(scene, **defines)
                return np.array(mi.render(s, spp=spp, seed=seed), dtype=np.float64)[..., :3]

            P = np.stack([render(a.scene, a.spp_path, 1 + i) for i in range(a.k)])
            T = np.stack([render(pt_scene, a.spp_pt, 1000 + i) for i in range(a.k)])
        finally:
            os.remove(pt_scene)

    b = a.block
    h, w = P.shape[1] // b * b, P.shape[2] // b * b

    def tiles(img):
        return img[:h, :w].reshape(h // b, b, w // b, b, 3).mean(axis=(1, 3))

    tp = np.stack([tiles(x) for x in P])
    tt = np.stack([tiles(x) for x in T])
    mp, mt = tp.mean(0), tt.mean(0)
    se = np.sqrt(tp.var(0, ddof=1) / a.k + tt.var(0, ddof=1) / a.k)
    t = np.where(se > 0, (mt - mp) / np.where(se > 0, se, 1), 0)
    print("ratio ptracer / path (R, G, B):",
          ", ".join(f"{r:.4f}" for r in T.mean(axis=(0, 1, 2)) / P.mean(axis=(0, 1, 2))))
    print(f"{t.size} tile x channel t-tests, {a.k - 1} dof a side; largest |t|:")
    order = np.argsort(-np.abs(t).ravel())[:6]
    for ty, tx, c in zip(*np.unravel_index(order, t.shape)):
        print(f"  tile ({tx},{ty}) {'RGB'[c]}: path {mp[ty, tx, c]:.4f} ptracer "
              f"{mt[ty, tx, c]:.4f} t {t[ty, tx, c]:.2f}")
    if a.show:
        y0, y1, x0, x1 = map(int, a.show.split(","))
        np.set_printoptions(linewidth=200, precision=3, suppress=True)
        print(f"path, pixels y {y0}..{y1}, x {x0}..{x1} (channel mean):")
        print(P.mean(0)[y0:y1, x0:x1].mean(-1))
        print("ptracer - path:")
        print((T.mean(0) - P.mean(0))[y0:y1, x0:x1].mean(-1))


if __name__ == "__main__":
    main()
