#!/bin/bash
# groove classic vs Mitsuba 3 scalar_rgb, rendered in alternating pairs so that slow drifts of the
# host's speed hit both sides alike (`groove bench` times all of groove's modes first, then Mitsuba).
#
#   docs/bench/interleaved_ab.sh MITSUBA_PYTHON [ROUNDS=7] [SCENE ...]
#
# Run from the repository root after `cargo build --release` (Mitsuba's helper: docs/tools).
# Each round: one groove process that renders twice (`groove bench --modes classic --repeat 1`:
# a warm-up, then the timed render) and one Mitsuba process that renders twice (the second
# render's time is kept). Both sides are timed warm, in-process, at 16 spp on 2 threads.
set -euo pipefail
PY=${1:?usage: $0 MITSUBA_PYTHON [ROUNDS] [SCENE ...]}
ROUNDS=${2:-7}
shift $(( $# >= 2 ? 2 : 1 ))
SCENES=("$@")
[ ${#SCENES[@]} -eq 0 ] && SCENES=(metal_plastic glass strong)
TOOLS=docs/tools
for sc in "${SCENES[@]}"; do
    g=()
    m=()
    for _ in $(seq "$ROUNDS"); do
        ./target/release/groove bench "scenes/bench/$sc.xml" --modes classic --repeat 1 --spp 16 \
            -t 2 --no-ceiling --ref-spp 0 --peer off -q --json /tmp/groove-ab.json \
            --md /tmp/groove-ab.md --plot /tmp/groove-ab.png >/dev/null
        g+=("$("$PY" -c 'import json; print(json.load(open("/tmp/groove-ab.json"))["records"][0]["seconds"])')")
        m+=("$("$PY" "$TOOLS/mitsuba_render.py" "scenes/bench/$sc.xml" --spp 16 --threads 2 \
            --no-write --repeat 2 --json 2>&1 | sed -n 's/^RESULT //p' |
            "$PY" -c 'import json,sys; print(json.load(sys.stdin)["render_all_s"][1])')")
    done
    "$PY" - "$sc" "${g[*]}" "${m[*]}" <<'EOF'
import math
import statistics as st
import sys

scene = sys.argv[1]
g = [float(x) for x in sys.argv[2].split()]
m = [float(x) for x in sys.argv[3].split()]
r = [a / b for a, b in zip(g, m)]
# Geometric mean of the per-pair ratios with a 95 % t-interval on their logarithms (two-sided
# Student t quantiles for n - 1 degrees of freedom).
T975 = {1: 12.71, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262,
        10: 2.228, 11: 2.201, 12: 2.179, 13: 2.160, 14: 2.145, 15: 2.131, 16: 2.120, 17: 2.110,
        18: 2.101, 19: 2.093, 20: 2.086, 25: 2.060, 30: 2.042}
lr = [math.log(x) for x in r]
n = len(lr)
ci = ""
if n > 1:
    df = n - 1
    t = T975.get(df) or T975[max(k for k in T975 if k <= df)] if df <= 30 else 1.96
    h = t * st.stdev(lr) / math.sqrt(n)
    ci = f", geometric mean {math.exp(st.mean(lr)):.3f} (95 % CI {math.exp(st.mean(lr) - h):.3f}-{math.exp(st.mean(lr) + h):.3f})"
print(f"{scene}: groove median {st.median(g):.3f} s, Mitsuba scalar_rgb median {st.median(m):.3f} s; "
      f"per-pair ratio median {st.median(r):.2f} (range {min(r):.2f}-{max(r):.2f}){ci}")
EOF
done
