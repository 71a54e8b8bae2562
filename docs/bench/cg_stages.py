#!/usr/bin/env python3
"""Where a callgrind profile's instructions go inside inlined code: each instruction's exclusive
cost (callgrind --dump-instr=yes) is attributed through its inline chain (addr2line -i), since the
stream renderer's stages are all inlined into `groove::lane::avx2::run_avx2`.

Usage: cg_stages.py CALLGRIND_OUT BINARY MODE [DEPTH] [TOP]
  MODE stage: per chain of groove functions from the outside in (DEPTH of them, default 2);
       line:  per innermost groove source line (not library code);
       at=FILE:LINE (or a substring of a path): the callers (DEPTH source lines) of that code.
       mnemonic: per x86 mnemonic (objdump -d), e.g. to count gathers, divisions, square roots;
       footprint: the code the profile executed: distinct instructions and 64-byte lines, and the
                  lines whose instructions ran at least 10^3, 10^4, 10^5 times (the hot code
                  against the L1 instruction cache's 32 KB).
  STAGE=NAME (environment) keeps only instructions whose chain has a function containing NAME.
  EVENT=NAME (environment) attributes that event of the profile (e.g. I1mr, D1mr, Bcm with
       callgrind's --cache-sim=yes or --branch-sim=yes) instead of the first (Ir).
  STAGE and DEPTH with ONCE=1 (environment) count each executed instruction once (code size by
       stage) instead of its cost.
Collect the render loop only with --toggle-collect='*StackJob*execute*' (rayon's block jobs, what
callgrind.sh counts; builds since the twenty-eighth session inline `stream::render_block` into them,
so '*stream::render_block*' collects nothing there), e.g.
  GROOVE_LANES=8 valgrind --tool=callgrind --dump-instr=yes --toggle-collect='*StackJob*execute*' \
    --callgrind-out-file=/tmp/cg.out target/release/groove render scenes/bench/metal_plastic.xml \
    -D spp=2 --spp 2 -t 1 -q --renderer stream -o /tmp/x.exr
  docs/bench/cg_stages.py /tmp/cg.out target/release/groove stage 1
"""
import collections
import os
import re
import subprocess
import sys


def main():
    cg, binary, mode = sys.argv[1], sys.argv[2], sys.argv[3]
    depth = int(sys.argv[4]) if len(sys.argv) > 4 else 2
    top = int(sys.argv[5]) if len(sys.argv) > 5 else 40
    cost, other = read_costs(cg, binary, os.environ.get("EVENT"))
    if mode == "mnemonic":
        return by_mnemonic(cost, binary, top)
    if mode == "footprint":
        return footprint(cost)
    if os.environ.get("ONCE") == "1":
        cost = collections.Counter({a: 1 for a in cost})
    chains = inline_chains(binary, cost)
    own = lambda loc: "/src/" in loc and "/rustc/" not in loc and ".cargo" not in loc
    short = lambda loc: re.sub(r"^.*?/src/", "src/", loc)
    flt = os.environ.get("STAGE")
    agg, total = collections.Counter(), sum(cost.values())
    for a, v in cost.items():
        ch = chains.get(a, [])
        if flt and not any(flt in f for f, _ in ch):
            continue
        if mode == "line":
            key = next((short(loc) for _, loc in ch if own(loc)), "?")
        elif mode.startswith("at="):
            j = next((j for j, (_, loc) in enumerate(ch) if mode[3:] in loc), None)
            if j is None:
                continue
            key = " < ".join([short(loc) for _, loc in ch[j + 1:] if own(loc)][:depth])
        else:
            names = [re.sub(r"<.*?>", "", f) for f, _ in reversed(ch)]
            names = [n for n in names if "run_avx2" not in n and "{{closure}}" not in n]
            key = " > ".join(names[:depth])
        agg[key] += v
    for k, v in agg.most_common(top):
        print(f"{v:>12,} {100 * v / total:5.1f}%  {k}")
    print(f"{total:>12,} in {os.path.basename(binary)}; other objects:")
    for k, v in other.most_common(5):
        print(f"{v:>12,}  {k}")


def inline_chains(binary, addrs):
    """Each address's inline chain, innermost first, as (function, file:line) pairs
    (`addr2line -i`); `perf_stages.py` uses it too."""
    out = subprocess.run(["addr2line", "-i", "-f", "-C", "-a", "-e", binary],
                         input="\n".join(hex(a) for a in sorted(addrs)), capture_output=True,
                         text=True).stdout
    chains, cur, fn = {}, None, None
    for l in out.split("\n"):
        if l.startswith("0x"):
            cur, fn = int(l, 16), None
            chains[cur] = []
        elif cur is not None:
            if fn is None:
                fn = l
            else:
                chains[cur].append((fn, l.split(" ")[0]))
                fn = None
    return chains


def read_costs(cg, binary, event=None):
    """Each instruction's exclusive cost in `binary` (by address) for one event of a callgrind
    --dump-instr=yes profile, and the other objects' costs by function."""
    obs, fns, cur_ob, cur_fn = {}, {}, None, None
    cost, other = collections.Counter(), collections.Counter()
    addr, skip_next, col = 0, False, 2
    for line in open(cg):
        line = line.rstrip("\n")
        if not line:
            continue
        if line.startswith("events:"):
            names = line.split()[1:]
            col = 2 + (names.index(event) if event else 0)
            continue
        c = line[0]
        if c.isdigit() or c in "+-*":
            parts = line.split()
            t = parts[0]
            if t != "*":
                addr = addr + int(t[1:], 0) if t[0] == "+" else addr - int(t[1:], 0) if t[0] == "-" else int(t, 0)
            if skip_next:  # the inclusive cost of a call
                skip_next = False
                continue
            if len(parts) >= 3:
                v = int(parts[col]) if len(parts) > col else 0
                if cur_ob and os.path.basename(binary) in cur_ob:
                    cost[addr] += v
                else:
                    other[cur_fn] += v
            continue
        m = re.match(r"(ob|fn|cob|cfn|cfi|cfl|fl|fi|fe)=\((\d+)\)(?: (.*))?", line)
        if m:
            kind, ident, name = m.groups()
            table = obs if kind in ("ob", "cob") else fns if kind in ("fn", "cfn") else None
            if table is not None and name:
                table[ident] = name
            if kind == "ob":
                cur_ob = obs[ident]
            elif kind == "fn":
                cur_fn = fns[ident]
        elif line.startswith("calls="):
            skip_next = True
    return cost, other


def by_mnemonic(cost, binary, top):
    """The cost per x86 mnemonic, from objdump's disassembly of the profiled addresses."""
    addrs = sorted(a for a in cost if cost[a])
    out = subprocess.run(["objdump", "-d", "--no-show-raw-insn", f"--start-address={addrs[0]}",
                          f"--stop-address={addrs[-1] + 16}", binary], capture_output=True, text=True).stdout
    op = {}
    for l in out.splitlines():
        m = re.match(r"\s+([0-9a-f]+):\s+(\S+)", l)
        if m:
            op[int(m.group(1), 16)] = m.group(2)
    agg, total = collections.Counter(), sum(cost.values())
    for a, v in cost.items():
        agg[op.get(a, "?")] += v
    for k, v in agg.most_common(top):
        print(f"{v:>12,} {100 * v / total:5.1f}%  {k}")
    print(f"{total:>12,} in {os.path.basename(binary)}")


def footprint(cost):
    """How much code the profile ran: distinct instructions and 64-byte lines, and the hot lines."""
    lines = collections.Counter()
    for a, v in cost.items():
        lines[a // 64] += v
    print(f"{len(cost):,} instructions executed in {len(lines):,} lines of 64 bytes ({len(lines) * 64 // 1024} KB)")
    for t in (10**3, 10**4, 10**5):
        hot = sum(1 for v in lines.values() if v >= t)
        print(f"lines of >= {t:,}: {hot:,} ({hot * 64 // 1024} KB)")


if __name__ == "__main__":
    main()
