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
sessions before the sixteenth; on metal_plastic it reads ~25 % slower than a warm render).

`MITSUBA_EMBREE_ISA=avx2` caps the ISA of Mitsuba's own Embree (3.13.4, bundled in the wheel,
which picks AVX-512 on an AVX-512 host whatever Dr.Jit's target), as groove caps Debian's Embree:
with `DRJIT_LLVM_TARGET` pinned to AVX2 too, both renderers then run the kernels of an AVX2
machine. A list (`avx2,native`) times Mitsuba once per entry in each round, interleaved, and
prints one line per entry; `native` leaves Embree's choice alone. Embree 3.13 reads no
configuration file (no `.embree3` is opened, under strace) and Mitsuba passes only its thread
counts to `rtcNewDevice`, so the script compiles (with `cc`, in a temporary directory) a small
`LD_PRELOAD` shim of Mitsuba's `rtcNewDevice` that appends `max_isa=ISA,verbose=1` to that
configuration string, for the Mitsuba processes only; Embree's verbose header reports the ISA it
enabled, and each line names it (e.g. `embree AVX2`); with two or more entries a line gives
the first entry's Mitsuba time over each other's, per round. `RATIOS_ROUNDS=1` prints every
round's times."""
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
# The LD_PRELOAD shim of `MITSUBA_EMBREE_ISA` (module doc): Mitsuba's Embree lives in namespace
# `mitsuba` inside the wheel's libembree3.so, which Python opens RTLD_LOCAL, so the real function
# is found through that library's handle rather than RTLD_NEXT.
SHIM_C = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
typedef void *(*newdev_t)(const char *);
void *_ZN7mitsuba12rtcNewDeviceEPKc(const char *cfg) {
    static newdev_t real;
    if (!real) {
        void *h = dlopen("libembree3.so", RTLD_LAZY | RTLD_NOLOAD);
        real = (newdev_t)dlsym(h ? h : RTLD_NEXT, "_ZN7mitsuba12rtcNewDeviceEPKc");
        if (!real || real == _ZN7mitsuba12rtcNewDeviceEPKc) { fputs("shim: no rtcNewDevice\n", stderr); abort(); }
    }
    const char *extra = getenv("GROOVE_EMBREE_EXTRA");
    char buf[1024];
    snprintf(buf, sizeof buf, "%s%s%s", cfg ? cfg : "", cfg && *cfg && extra ? "," : "", extra ? extra : "");
    return real(buf);
}
"""
SHIM_DIR = tempfile.TemporaryDirectory()
def shim_env(isa):
    """Mitsuba's environment for one entry of MITSUBA_EMBREE_ISA (None: untouched)."""
    if isa is None:
        return None
    so = os.path.join(SHIM_DIR.name, "shim.so")
    if not os.path.exists(so):
        with open(os.path.join(SHIM_DIR.name, "shim.c"), "w") as f:
            f.write(SHIM_C)
        subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", so, os.path.join(SHIM_DIR.name, "shim.c"), "-ldl"],
                       check=True)
    env = dict(os.environ, LD_PRELOAD=so)
    env["GROOVE_EMBREE_EXTRA"] = "verbose=1" + ("" if isa == "native" else f",max_isa={isa}")
    return env
def embree_isa(out):
    """The widest ISA of the Config section of Embree's verbose header, or None."""
    m = re.search(r"Config\n.*?\n\s+ISA\s*:([^\n]*)", out)
    if not m:
        return None
    feats = m.group(1).split()
    return next((f for f in ("AVX512F", "AVX2", "AVX", "SSE4.2") if f in feats), "?")
def mitsuba(scene, spp, variant, isa=None):
    out = subprocess.run([PY, MR, scene, "--variant", variant, "--spp", str(spp), "--threads", "2",
                          "--repeat", "3", "--no-write", "--json", "--quiet"], capture_output=True, text=True,
                         env=shim_env(isa)).stdout
    line = [l for l in out.splitlines() if l.startswith("RESULT")][-1]
    d = json.loads(line[7:])
    TARGET[variant] = d.get("llvm_target")
    if isa is not None:
        EMBREE[isa] = embree_isa(out)
    return min(d["render_all_s"][1:])  # after the first (JIT for llvm)
TARGET, EMBREE = {}, {}
ISAS = os.environ["MITSUBA_EMBREE_ISA"].split(",") if os.environ.get("MITSUBA_EMBREE_ISA") else [None]
for sc in scenes:
    spp = 16
    rl, rs, tg, tl, ts = {i: [] for i in ISAS}, [], [], {i: [] for i in ISAS}, []
    for r in range(rounds):
        a = groove(sc, spp)
        for i in ISAS:
            b = mitsuba(sc, spp, "llvm_ad_rgb", i)
            tl[i].append(b); rl[i].append(a / b)
        c = mitsuba(sc, spp, "scalar_rgb") if os.environ.get("MITSUBA_SCALAR") != "0" else float("nan")
        tg.append(a); ts.append(c); rs.append(a / c)
    def summ(x):
        s = sorted(x); return f"{statistics.median(s):.2f} [{s[1]:.2f}, {s[-2]:.2f}]"
    if os.environ.get("RATIOS_ROUNDS") == "1":
        print(f"{sc.split('/')[-1]} rounds: groove {[round(x, 3) for x in tg]}, "
              + ", ".join(f"llvm ({i}) {[round(x, 3) for x in tl[i]]}" for i in ISAS), flush=True)
    for i in ISAS[1:]:
        q = [a / b for a, b in zip(tl[ISAS[0]], tl[i])]
        print(f"{sc.split('/')[-1]}: llvm ({ISAS[0]}) / llvm ({i}) {summ(q)}", flush=True)
    for i in ISAS:
        print(f"{sc.split('/')[-1]}: groove {statistics.median(tg):.3f} s, llvm {statistics.median(tl[i]):.3f} s, "
              f"scalar {statistics.median(ts):.3f} s; groove/llvm {summ(rl[i])}; groove/scalar {summ(rs)}"
              f" (llvm target {TARGET.get('llvm_ad_rgb')}"
              + ("" if i is None else f", embree {EMBREE.get(i)} ({i})") + ")", flush=True)
