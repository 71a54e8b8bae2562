#!/usr/bin/env bash
# The merge job of a split render: runs after the array (sbatch --dependency=afterany:JOBID,
# so it runs even when tasks failed), checks that every part OUT/part-0..N-1.exr exists, names
# the missing ones with the command that renders only them again, and merges with groove merge
# (which checks that the parts belong to one render and cover every sample of every pixel).
# Environment: N, OUT (default parts), RESULT (default result.exr), GROOVE (default groove),
# SCENE, SPLIT, SPP, SCRIPTS (this folder; sbatch runs a copy of the script) only to print the
# resubmit command; ALLOW_MISSING=1 to merge anyway.
#SBATCH --job-name=groove-merge
#SBATCH --output=groove-merge-%j.log
set -euo pipefail
: "${N:?N is required}"
OUT=${OUT:-parts}
RESULT=${RESULT:-result.exr}
GROOVE=${GROOVE:-groove}
missing=()
parts=()
for (( i = 0; i < N; i++ )); do
  if [ -f "$OUT/part-$i.exr" ]; then parts+=("$OUT/part-$i.exr"); else missing+=("$i"); fi
done
if [ ${#missing[@]} -gt 0 ]; then
  list=$(IFS=,; echo "${missing[*]}")
  echo "missing parts: $list" >&2
  echo "render only them again, then merge again:" >&2
  echo "  jid=\$(sbatch --parsable --array=$list --export=ALL,SCENE=${SCENE:-scene.xml},SPLIT=${SPLIT:-tile},N=$N,OUT=$OUT${SPP:+,SPP=$SPP} ${SCRIPTS:-$(dirname "$0")}/render-array.sh)" >&2
  echo "  sbatch --dependency=afterany:\$jid --export=ALL,N=$N,OUT=$OUT,RESULT=$RESULT ${SCRIPTS:-$(dirname "$0")}/merge.sh" >&2
  if [ "${ALLOW_MISSING:-0}" != 1 ] || [ ${#parts[@]} -eq 0 ]; then exit 1; fi
  exec "$GROOVE" merge --allow-missing "$RESULT" "${parts[@]}"
fi
exec "$GROOVE" merge "$RESULT" "${parts[@]}"
