#!/bin/bash
# The stream renderer at lane width 16 (AVX-512) against width 8 (`GROOVE_LANES=8`), rendered in
# alternating pairs (the order flips every round) so that the shared host's drifts hit both alike.
#
#   docs/bench/lanes_pairs.sh [ROUNDS=5] [SPP=16] SCENE.xml ...
#
# Each render is one `groove render --renderer stream -t 2` process; its render time (without the
# scene's load) comes from `--json`. Prints per scene the medians of both widths and the median,
# min and max of the per-round ratios t16/t8. Needs `python3`; GROOVE picks the binary.
set -euo pipefail
ROUNDS=${1:-5}
SPP=${2:-16}
shift 2
BIN=${GROOVE:-target/release/groove}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
one() { # lanes scene -> seconds
    GROOVE_LANES=$1 "$BIN" render "$2" --spp "$SPP" -t 2 -q --renderer stream \
        -o "$tmp/img.exr" --json "$tmp/r.json" >/dev/null
    python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); r=d["renders"][0] if "renders" in d else d["records"][0]; print(r.get("render_seconds", r.get("seconds")))' "$tmp/r.json"
}
for sc in "$@"; do
    a=()
    b=()
    for r in $(seq "$ROUNDS"); do
        if [ $((r % 2)) -eq 1 ]; then
            a+=("$(one 16 "$sc")")
            b+=("$(one 8 "$sc")")
        else
            b+=("$(one 8 "$sc")")
            a+=("$(one 16 "$sc")")
        fi
    done
    python3 - "$sc" "${a[*]}" "${b[*]}" <<'PY'
import statistics as st, sys
a = [float(x) for x in sys.argv[2].split()]
b = [float(x) for x in sys.argv[3].split()]
r = [x / y for x, y in zip(a, b)]
print(f"{sys.argv[1]}: width 16 {st.median(a):.3f} s, width 8 {st.median(b):.3f} s, "
      f"t16/t8 median {st.median(r):.3f} [{min(r):.3f}, {max(r):.3f}] over {len(r)} rounds")
PY
done
