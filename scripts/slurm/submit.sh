#!/usr/bin/env bash
# Submit a split render and its merge:  submit.sh SCENE N [tile|samples] [SPP]
# (OUT, RESULT, GROOVE, GROOVE_ARGS and sbatch's own SBATCH_* variables pass through.)
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 SCENE N [tile|samples] [SPP]" >&2; exit 2; }
SCENE=$1 N=$2 SPLIT=${3:-tile} SPP=${4:-}
here=$(cd "$(dirname "$0")" && pwd)
export SCRIPTS=$here SCENE N SPLIT SPP OUT=${OUT:-parts} RESULT=${RESULT:-result.exr}
jid=$(sbatch --parsable --array=0-$(( N - 1 )) --export=ALL "$here/render-array.sh")
jid=${jid%%;*}
mid=$(sbatch --parsable --dependency=afterany:"$jid" --export=ALL "$here/merge.sh")
echo "array job $jid ($N parts in $OUT), merge job ${mid%%;*} -> $RESULT"
