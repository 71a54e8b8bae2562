#!/usr/bin/env bash
# How far two groove binaries' images are apart, render by render: every scenes/bench scene in
# every normal-mapping mode (17 renders) and the rough Beckmann test scenes of tests/data/scenes,
# same seed, same spp. Per render: the fraction of bit-identical pixels, mean |Δ| / mean (all
# channels) and the ratio of the image means. Needs a Python with numpy and mitsuba (to read EXR).
#
# Usage: docs/bench/check.sh OLD_BINARY NEW_BINARY [SPP]   (SPP default 4; 2 threads: the image
# does not depend on the thread count). PYTHON picks the interpreter (default python3).
set -euo pipefail
old=$1; new=$2; spp=${3:-4}
py=${PYTHON:-python3}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
renders=()
for s in metal_plastic glass strong; do
    for m in classic explicit walk-mirror walk-same vgroove ugroove; do
        [ "$s/$m" = glass/explicit ] && continue   # explicit cannot apply over glass
        renders+=("scenes/bench/$s.xml|--normal-mapping $m|$s-$m")
    done
done
t=tests/data/scenes
renders+=("$t/mat_roughconductor.xml|-D distribution=beckmann|roughconductor-beckmann")
renders+=("$t/mat_metals.xml|-D distribution=beckmann|metals-beckmann")
renders+=("$t/mat_plastic.xml||plastic")
renders+=("$t/mat_roughglass.xml||roughglass")
renders+=("$t/mat_rough_tex.xml||rough_tex")
for r in "${renders[@]}"; do
    IFS='|' read -r scene args name <<<"$r"
    for b in old new; do
        bin=$old; [ $b = new ] && bin=$new
        # shellcheck disable=SC2086
        "$bin" render "$scene" $args --spp "$spp" -t 2 -q -o "$tmp/$name.$b.exr" >/dev/null
    done
    echo "$name $tmp/$name.old.exr $tmp/$name.new.exr"
done | "$py" -c '
import sys
import numpy as np
import mitsuba as mi
mi.set_variant("scalar_rgb")
print("%-28s %12s %13s %13s" % ("render", "identical px", "mean|d|/mean", "mean new/old"))
for line in sys.stdin:
    name, a, b = line.split()
    a = np.array(mi.Bitmap(a), dtype=np.float32)[:, :, :3]
    b = np.array(mi.Bitmap(b), dtype=np.float32)[:, :, :3]
    same = np.all(a.view(np.uint32) == b.view(np.uint32), axis=2).mean()
    d = np.abs(a - b).mean() / max(a.mean(), 1e-30)
    print(f"{name:<28} {100 * same:>11.2f}% {d:>13.2e} {b.mean() / max(a.mean(), 1e-30):>13.6f}")
'
