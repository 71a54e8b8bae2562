#!/usr/bin/env python3
"""Turn the stdout of `cargo bench --bench bsdf` into the Markdown table of docs/microgeometry.md.

Reads criterion's lines `GROUP/MODE/OP ... time: [low mid high]` from stdin (or from the files
given) and prints one row per nested BSDF and mode with criterion's middle estimate of the time per
call for eval, sample and pdf. With several files, each cell lists every run's estimate, separated
by " / ", so run-to-run spread on a loaded machine stays visible.
"""
import re
import sys

UNIT = {"ps": 1e-3, "ns": 1.0, "µs": 1e3, "us": 1e3, "ms": 1e6}
LINE = re.compile(r"^(\S+)/(\S+)/(eval|sample|pdf)\s*(?:\n\s*)?time:\s+\[\S+ \S+ (\S+) (\S+) \S+ \S+\]", re.M)


def parse(text):
    out = {}
    for group, mode, op, mid, unit in LINE.findall(text):
        out[(group, mode, op)] = float(mid) * UNIT[unit]
    return out


def main():
    texts = [open(p).read() for p in sys.argv[1:]] or [sys.stdin.read()]
    runs = [parse(t) for t in texts]
    keys = []
    for k in runs[0]:
        if (k[0], k[1]) not in keys:
            keys.append((k[0], k[1]))
    print("| nested | mode | eval ns | sample ns | pdf ns |")
    print("|---|---|---|---|---|")
    for group, mode in keys:
        cells = []
        for op in ("eval", "sample", "pdf"):
            vals = [r.get((group, mode, op)) for r in runs]
            cells.append(" / ".join("–" if v is None else f"{v:.0f}" if v >= 10 else f"{v:.1f}" for v in vals))
        print(f"| {group} | {mode} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
