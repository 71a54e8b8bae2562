#!/usr/bin/env python3
"""Interleaved wall-clock pairs of two groove binaries on the stream renderer.

Usage: python3 docs/bench/ab_pairs.py OLD_BINARY NEW_BINARY ROUNDS SCENE.xml...

Per scene, ROUNDS pairs at 16 spp on 2 threads, the order alternating every round (old first on
even rounds), each time read from groove's own "render N s" line (the render, not the scene load).
Prints per scene the median times and the median of the per-round ratios new/old with the 2nd
lowest and 2nd highest ratio as a rough interval. On a shared machine, run it quiet.
GROOVE_ARGS (environment) adds render arguments to both binaries' renders, split at spaces
(e.g. GROOVE_ARGS="--normal-mapping compensated"). THREADS (environment) sets the renders'
thread count instead of 2 (1 leaves a core to another job on a 2-core host that is not quiet).
"""
import os
import re
import statistics
import subprocess
import sys


def render_seconds(binary, scene):
    out = subprocess.run(
        [binary, "render", scene, "--spp", "16", "-t", os.environ.get("THREADS", "2"),
         "-o", "/tmp/ab_pairs.exr", "--renderer", "stream"] + os.environ.get("GROOVE_ARGS", "").split(),
        capture_output=True, text=True, check=True)
    return float(re.search(r"render ([0-9.]+) s", out.stdout + out.stderr).group(1))


def main():
    old, new, rounds, scenes = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4:]
    for scene in scenes:
        t_old, t_new, ratios = [], [], []
        for i in range(rounds):
            if i % 2:
                b = render_seconds(new, scene)
                a = render_seconds(old, scene)
            else:
                a = render_seconds(old, scene)
                b = render_seconds(new, scene)
            t_old.append(a)
            t_new.append(b)
            ratios.append(b / a)
        s = sorted(ratios)
        print(f"{scene}: old {statistics.median(t_old):.3f} s, new {statistics.median(t_new):.3f} s, "
              f"new/old median {statistics.median(s):.3f} [{s[1]:.3f}, {s[-2]:.3f}]")


if __name__ == "__main__":
    main()
