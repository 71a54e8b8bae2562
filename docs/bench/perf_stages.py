#!/usr/bin/env python3
"""Where a render's *time* goes, by stage: `perf record -e cpu-clock -g` samples of groove's
render threads, attributed like `cg_stages.py` attributes callgrind's instructions (each sample's
innermost groove address through its inline chain, `addr2line -i`), and Embree's samples by the
API call they run under (`rtcIntersect8`, `rtcIntersect1M`, `rtcOccluded1M`, ... : the first
`rtc*` frame of the sample's call chain). Put next to `cg_stages.py`'s instruction shares, a
stage whose share of time exceeds its share of instructions is one that waits (cache misses).

Usage: perf_stages.py PERF_DATA BINARY [DEPTH] [TOP]
  The render threads are the threads other than the process's first (the scene load runs there)
  with a sample in BINARY; TID=n,m (environment) picks them instead. DEPTH (default 1) groove
  functions from the outside in; TOP (default 30) rows.
Record, e.g.:
  perf record -e cpu-clock -F 2000 -g -o /tmp/p.data target/release/groove render \
    scenes/bench/million/million.xml -D spp=64 --spp 64 -t 1 -q --renderer stream -o /tmp/x.exr
  docs/bench/perf_stages.py /tmp/p.data target/release/groove 1 30
"""
import collections
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cg_stages import inline_chains  # noqa: E402  (the scripts' shared addr2line reader)


def samples(data):
    """(pid, tid, command, [(address, symbol, dso), ...] innermost first) per sample of `perf script`."""
    out = subprocess.run(["perf", "script", "-i", data, "-F", "comm,pid,tid,ip,sym,dso"],
                         capture_output=True, text=True).stdout
    for block in out.split("\n\n"):
        lines = [l for l in block.split("\n") if l.strip()]
        if not lines:
            continue
        m = re.match(r"\s*(.*?)\s+(\d+)/(\d+)", lines[0])
        if not m:
            continue
        frames = []
        for l in lines[1:]:
            f = re.match(r"\s*([0-9a-f]+)\s+(.*?)\s+\((.*)\)\s*$", l)
            if f:
                frames.append((int(f.group(1), 16), f.group(2), f.group(3)))
        if frames:
            yield int(m.group(2)), int(m.group(3)), m.group(1), frames


def segments(binary):
    """(file offset, size, virtual address) of BINARY's loadable segments: perf prints an
    address in the binary as its file offset, addr2line wants the virtual address."""
    out = subprocess.run(["readelf", "-lW", binary], capture_output=True, text=True).stdout
    segs = []
    for l in out.splitlines():
        f = l.split()
        if f and f[0] == "LOAD":
            segs.append((int(f[1], 16), int(f[4], 16), int(f[2], 16)))
    return segs


def vaddr(segs, off):
    return next((off - o + v for o, n, v in segs if o <= off < o + n), off)


def main():
    data, binary = sys.argv[1], sys.argv[2]
    depth = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    top = int(sys.argv[4]) if len(sys.argv) > 4 else 30
    name = os.path.basename(binary)
    all_samples = list(samples(data))
    segs = segments(binary)
    if os.environ.get("TID"):
        tids = {int(t) for t in os.environ["TID"].split(",")}
    else:
        tids = {t for p, t, c, fr in all_samples
                if t != p and c == name and os.path.basename(fr[0][2]) == name}
    kinds, own = collections.Counter(), collections.Counter()
    for _, t, _, fr in all_samples:
        if t not in tids:
            continue
        dso = os.path.basename(fr[0][2])
        if dso == name:
            own[vaddr(segs, fr[0][0])] += 1
            kinds["groove"] += 1
        elif "embree" in dso:
            api = next((s.split("+")[0] for _, s, d in fr if "embree" in d and s.startswith("rtc")), "?")
            kinds["embree " + api] += 1
        else:
            kinds[dso] += 1
    total = sum(kinds.values())
    print(f"threads {sorted(tids)}: {total} samples")
    for k, v in kinds.most_common():
        print(f"{v:>8} {100 * v / total:5.1f}%  {k}")
    chains = inline_chains(binary, own)
    agg = collections.Counter()
    for a, v in own.items():
        names = [re.sub(r"<.*?>", "", f) for f, _ in reversed(chains.get(a, []))]
        names = [n for n in names if "run_avx2" not in n and "{{closure}}" not in n]
        agg[" > ".join(names[:depth]) or "(run_avx2 itself)"] += v
    print(f"groove's own samples by stage (% of all {total}):")
    for k, v in agg.most_common(top):
        print(f"{v:>8} {100 * v / total:5.1f}%  {k}")


if __name__ == "__main__":
    main()
