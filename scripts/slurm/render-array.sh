#!/usr/bin/env bash
# One part of a split groove render per Slurm array task. Submit with submit.sh, or:
#   sbatch --array=0-$((N-1)) --export=ALL,SCENE=scene.xml,SPLIT=tile,N=$N,OUT=parts render-array.sh
# Environment:
#   SCENE   scene file (SPLIT=tile|samples), or a file listing one scene per line (SPLIT=scenes)
#   SPLIT   tile    : task I renders tile I/N (strips of rows)
#           samples : task I renders sample indices [I*SPP/N, (I+1)*SPP/N) of the full frame
#           scenes  : task I renders line I+1 of the list in SCENE, whole
#   N       number of tasks (tile, samples)
#   SPP     samples per pixel (samples: required; tile: optional, default the scene's)
#   OUT     folder of the parts (default parts); task I writes OUT/part-I.exr (scenes: OUT/<stem>.exr)
#   GROOVE  the groove binary (default groove on PATH); GROOVE_ARGS more render options (-D k=v ...)
# The part is written atomically (temporary file + rename): a task that fails or is killed
# leaves no part, so the merge job names it as missing.
#SBATCH --job-name=groove-part
#SBATCH --requeue
#SBATCH --cpus-per-task=4
#SBATCH --output=groove-part-%A_%a.log
set -euo pipefail
: "${SCENE:?SCENE is required}" "${SLURM_ARRAY_TASK_ID:?run as a Slurm array task}"
SPLIT=${SPLIT:-tile}
OUT=${OUT:-parts}
GROOVE=${GROOVE:-groove}
I=$SLURM_ARRAY_TASK_ID
THREADS=${SLURM_CPUS_PER_TASK:-0}
mkdir -p "$OUT"
# shellcheck disable=SC2086 # GROOVE_ARGS is a list of options
case $SPLIT in
  tile)
    : "${N:?N is required}"
    exec "$GROOVE" render "$SCENE" -q -t "$THREADS" ${SPP:+--spp "$SPP"} --tile "$I/$N" \
      -o "$OUT/part-$I.exr" ${GROOVE_ARGS:-} ;;
  samples)
    : "${N:?N is required}" "${SPP:?SPP is required}"
    A=$(( I * SPP / N )); B=$(( (I + 1) * SPP / N ))
    exec "$GROOVE" render "$SCENE" -q -t "$THREADS" --spp "$SPP" --samples "$A..$B" \
      -o "$OUT/part-$I.exr" ${GROOVE_ARGS:-} ;;
  scenes)
    S=$(sed -n "$(( I + 1 ))p" "$SCENE")
    [ -n "$S" ] || { echo "no line $(( I + 1 )) in $SCENE" >&2; exit 2; }
    STEM=$(basename "${S%.*}")
    exec "$GROOVE" render "$S" -q -t "$THREADS" ${SPP:+--spp "$SPP"} \
      -o "$OUT/$STEM.exr" --json "$OUT/$STEM.json" ${GROOVE_ARGS:-} ;;
  *) echo "SPLIT must be tile, samples or scenes, not '$SPLIT'" >&2; exit 2 ;;
esac
