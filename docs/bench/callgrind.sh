#!/usr/bin/env bash
# Instructions per sample of a groove render, counted by callgrind (deterministic, unlike times
# on a shared machine): the render loop's instructions (rayon's block job, inclusive: tracing,
# shading and film, not scene loading) divided by pixels × spp.
#
# Usage: docs/bench/callgrind.sh SCENE.xml [MODE] [SPP]   (MODE: a --normal-mapping mode,
# default classic; SPP default 2; one thread). Needs valgrind; runs ~100× slower than a render.
# RENDERER=stream counts the stream renderer (default scalar); GROOVE_STREAM_PACKETS picks its packets.
# GROOVE_ARGS adds render arguments (e.g. GROOVE_ARGS="-D distribution=beckmann").
# The stream renderer's lanes are capped at 8 (GROOVE_LANES, unless set): valgrind 3.19 cannot run
# AVX-512 instructions, so the 16-wide kernels of an AVX-512 host cannot be counted.
set -euo pipefail
export GROOVE_LANES=${GROOVE_LANES:-8}
scene=$1; mode=${2:-classic}; spp=${3:-2}
bin=${GROOVE:-target/release/groove}
renderer=${RENDERER:-scalar}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
# A 1-spp render first, outside valgrind: the `compensated` and `auto` modes' remainder tables
# are built once and kept in groove's disk cache (`~/.cache/groove`); on a machine whose cache is
# cold the counted render would otherwise include their build (~17 G instructions on
# metal_plastic, ~220,000 a sample at 2 spp).
"$bin" render "$scene" -D spp=1 --spp 1 -t 1 -q --normal-mapping "$mode" --renderer "$renderer" ${GROOVE_ARGS:-} -o "$tmp/warm.png" >/dev/null 2>&1 || true
valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$bin" render "$scene" \
    -D spp="$spp" --spp "$spp" -t 1 -q --normal-mapping "$mode" --renderer "$renderer" ${GROOVE_ARGS:-} -o "$tmp/img.png" >/dev/null 2>&1
loop=$(callgrind_annotate --inclusive=yes --threshold=100 "$tmp/cg.out" 2>/dev/null \
    | grep -E "StackJob<L,F,R> as rayon_core::job::Job>::execute \[" | head -1 | awk '{print $1}' | tr -d ,)
read -r w h < <(file "$tmp/img.png" | sed -E 's/.*PNG image data, ([0-9]+) x ([0-9]+).*/\1 \2/')
echo "$scene $mode $renderer spp=$spp ${w}x${h}: render loop $loop instructions, $((loop / (w * h * spp))) per sample"
