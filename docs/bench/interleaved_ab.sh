#!/bin/bash
# groove classic vs Mitsuba 3 scalar_rgb, rendered in alternating pairs so that slow drifts of the
# host's speed hit both sides alike (`groove bench` times all of groove's modes first, then Mitsuba).
#
#   docs/bench/interleaved_ab.sh MITSUBA_PYTHON [ROUNDS=7] [SCENE ...]
#
# Run from the repository root after `cargo build --release`, with ../shared/tools beside it.
# Each round: one groove render (its summary line's render time) and one Mitsuba process that
# renders twice (the second render's time is kept: the first one warms up). 16 spp, 2 threads.
set -euo pipefail
PY=${1:?usage: $0 MITSUBA_PYTHON [ROUNDS] [SCENE ...]}
ROUNDS=${2:-7}
shift $(( $# >= 2 ? 2 : 1 ))
SCENES=("$@")
[ ${#SCENES[@]} -eq 0 ] && SCENES=(metal_plastic glass strong)
TOOLS=../shared/tools
for sc in "${SCENES[@]}"; do
    g=()
    m=()
    for _ in $(seq "$ROUNDS"); do
        g+=("$(./target/release/groove render "scenes/bench/$sc.xml" -t 2 --normal-mapping classic \
            -o /tmp/groove-ab.exr 2>&1 | grep -o 'render [0-9.]* s' | awk '{print $2}')")
        m+=("$("$PY" "$TOOLS/mitsuba_render.py" "scenes/bench/$sc.xml" --spp 16 --threads 2 \
            --no-write --repeat 2 --json 2>&1 | sed -n 's/^RESULT //p' |
            "$PY" -c 'import json,sys; print(json.load(sys.stdin)["render_all_s"][1])')")
    done
    "$PY" - "$sc" "${g[*]}" "${m[*]}" <<'EOF'
import statistics as st
import sys

scene = sys.argv[1]
g = [float(x) for x in sys.argv[2].split()]
m = [float(x) for x in sys.argv[3].split()]
r = [a / b for a, b in zip(g, m)]
print(f"{scene}: groove median {st.median(g):.3f} s, Mitsuba scalar_rgb median {st.median(m):.3f} s; "
      f"per-pair ratio median {st.median(r):.2f} (range {min(r):.2f}-{max(r):.2f})")
EOF
done
