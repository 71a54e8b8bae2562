#!/usr/bin/env bash
# Tier A vs Embree replay throughput as the number of analytic primitives grows (issue 16 item 3):
# writes scenes of N random spheres or rectangles (N = 1..64) and runs `groove bench --rays` on
# each, one thread. Usage: docs/bench/tier_threshold.sh GROOVE_BINARY [OUTDIR]
set -eu
bin=$1; out=${2:-$(mktemp -d)}
mkdir -p "$out"
for kind in sphere rectangle; do
  for n in 1 2 4 8 12 16 24 32 48 64; do
    f=$out/$kind$n.xml
    python3 - "$kind" "$n" > "$f" <<'PY'
import random, sys
kind, n = sys.argv[1], int(sys.argv[2])
random.seed(n * 7 + len(kind))
print('<scene version="3.0.0">')
print('<sensor type="perspective"><float name="fov" value="45"/>'
      '<transform name="to_world"><lookat origin="0,0,10" target="0,0,0" up="0,1,0"/></transform>'
      '<sampler type="independent"/><film type="hdrfilm"><integer name="width" value="160"/>'
      '<integer name="height" value="120"/></film></sensor>')
print('<emitter type="constant"/>')
for i in range(n):
    x, y, z = (random.uniform(-3, 3) for _ in range(3))
    if kind == "sphere":
        print(f'<shape type="sphere"><point name="center" x="{x}" y="{y}" z="{z}"/>'
              f'<float name="radius" value="0.5"/></shape>')
    else:
        ax = [random.uniform(-1, 1) for _ in range(3)]
        print(f'<shape type="rectangle"><transform name="to_world"><scale value="0.6"/>'
              f'<rotate x="{ax[0]}" y="{ax[1]}" z="{ax[2] + 0.01}" angle="{random.uniform(0, 180)}"/>'
              f'<translate x="{x}" y="{y}" z="{z}"/></transform></shape>')
print('</scene>')
PY
    "$bin" bench --rays --spp 4 -t 1 --repeat 3 --peer off --json "$out/$kind$n.json" \
      --md "$out/$kind$n.md" --plot "$out/$kind$n.png" "$f" 2>&1 | grep "tier A" || echo "$kind$n: no tier A line"
  done
done
