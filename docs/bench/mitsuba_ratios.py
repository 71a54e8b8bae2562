#!/usr/bin/env python3
"""Interleaved rounds: groove classic vs Mitsuba llvm_ad_rgb and scalar_rgb, render time only,
same scene, spp and threads. Per round the ratio groove/peer; reports median and the 2nd-lowest /
2nd-highest of the rounds (an approximate 95 % interval for the median at 10 rounds is the
2nd..9th order statistics). `GROOVE_RENDERER=stream` (or `scalar`) picks groove's renderer;
`MITSUBA_SCALAR=0` skips `scalar_rgb`. `DRJIT_LLVM_TARGET=CPU:FEATURES:WIDTH` (see
`docs/tools/mitsuba_render.py`) pins `llvm_ad_rgb`'s target, e.g. 8-wide AVX2 on an AVX-512 host;
each line names the target that ran.

Both sides are timed warm and in one process: Mitsuba renders 3 times per round and the minimum of
the 2nd and 3rd counts (the first compiles its kernels); groove runs `groove bench` (a 1-spp warm-up
render, then 3 timed renders, no ceiling, no reference, no peer) and the minimum of the 3 counts.
`GROOVE_COLD=1` times groove instead by one `groove render` in a fresh process (the method of the
sessions before the sixteenth; on metal_plastic it reads ~25 % slower than a warm render)."""
import json, os, re, subprocess, sys, statistics, tempfile
G = sys.argv.pop(1) if len(sys.argv) > 1 and sys.argv[1].endswith("groove") else "target/release/groove"
PY = sys.executable
MR = "docs/tools/mitsuba_render.py"
scenes = sys.argv[2:]
rounds = int(sys.argv[1])
def groove(scene, spp):
    if os.environ.get("GROOVE_COLD") != "1":
        return groove_warm(scene, spp)
    p = subprocess.run([G, "render", scene, "--spp", str(spp), "-t", "2", "-o", "/tmp/r.exr"]
                       + (["--renderer", os.environ["GROOVE_RENDERER"]] if os.environ.get("GROOVE_RENDERER") else []),
                       capture_output=True, text=True)
    out = p.stdout + p.stderr
    m = re.search(r"render ([0-9.]+) s", out)
    if not m:
        raise SystemExit(out)
    return float(m.group(1))
def groove_warm(scene, spp):
    with tempfile.TemporaryDirectory() as d:
        p = subprocess.run([G, "bench", scene, "--spp", str(spp), "-t", "2", "--repeat", "3", "--modes", "classic",
                            "--ref-spp", "0", "--no-ceiling", "--peer", "off", "-q",
                            "--json", f"{d}/b.json", "--md", f"{d}/b.md", "--plot", f"{d}/b.png"]
                           + (["--renderer", os.environ["GROOVE_RENDERER"]] if os.environ.get("GROOVE_RENDERER") else []),
                           capture_output=True, text=True)
        if p.returncode != 0:
            raise SystemExit(p.stdout + p.stderr)
        recs = json.load(open(f"{d}/b.json"))["records"]
    return min(r["seconds"] for r in recs)
def mitsuba(scene, spp, variant):
    out = subprocess.run([PY, MR, scene, "--variant", variant, "--spp", str(spp), "--threads", "2",
                          "--repeat", "3", "--no-write", "--json", "--quiet"], capture_output=True, text=True).stdout
    line = [l for l in out.splitlines() if l.startswith("RESULT")][-1]
    d = json.loads(line[7:])
    TARGET[variant] = d.get("llvm_target")
    return min(d["render_all_s"][1:])  # after the first (JIT for llvm)
TARGET = {}
for sc in scenes:
    spp = 16
    rl, rs, tg, tl, ts = [], [], [], [], []
    for r in range(rounds):
        a = groove(sc, spp); b = mitsuba(sc, spp, "llvm_ad_rgb")
        c = mitsuba(sc, spp, "scalar_rgb") if os.environ.get("MITSUBA_SCALAR") != "0" else float("nan")
        tg.append(a); tl.append(b); ts.append(c); rl.append(a / b); rs.append(a / c)
    def summ(x):
        s = sorted(x); return f"{statistics.median(s):.2f} [{s[1]:.2f}, {s[-2]:.2f}]"
    print(f"{sc.split('/')[-1]}: groove {statistics.median(tg):.3f} s, llvm {statistics.median(tl):.3f} s, "
          f"scalar {statistics.median(ts):.3f} s; groove/llvm {summ(rl)}; groove/scalar {summ(rs)}"
          f" (llvm target {TARGET.get('llvm_ad_rgb')})", flush=True)
