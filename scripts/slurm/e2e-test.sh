#!/usr/bin/env bash
# End-to-end test of the Slurm recipe on a private single-node Slurm (needs root):
#   scripts/slurm/e2e-test.sh GROOVE_BINARY WORKDIR
# testbed.sh installs Debian's slurmctld, slurmd, munge and slurm-client when missing, writes a
# slurm.conf on 127.0.0.1 with private ports and every state file under a temporary folder,
# starts munged, slurmctld -D and slurmd -D itself (no systemd) and stops them by their PIDs on
# exit. Then: an array of 4 tiles of a small scene in which task 2 fails on its first
# run; the merge job (afterany) must fail and name part 2; index 2 alone is resubmitted with a
# new merge job, which must succeed. WORKDIR receives result.exr (the merge) and single.exr (one
# plain render of the same scene), which `cargo test --release` (as root)
# compares bit for bit. Every wait is bounded; the script exits non-zero on any failure.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: $0 GROOVE_BINARY WORKDIR" >&2; exit 2; }
GROOVE=$(readlink -f "$1")
WORK=$(mkdir -p "$2" && cd "$2" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
. "$HERE/testbed.sh"

# The scene, and a groove wrapper that makes task 2 fail until FIXED exists.
cd "$T/work"
write_scene scene.xml
cat >groove-flaky <<EOF
#!/bin/sh
if [ "\$SLURM_ARRAY_TASK_ID" = 2 ] && [ ! -e "$T/work/FIXED" ]; then
  echo "task 2 fails on purpose" >&2; exit 3
fi
exec "$GROOVE" "\$@"
EOF
chmod +x groove-flaky
export SCENE=scene.xml SPLIT=tile N=4 OUT=parts RESULT=result.exr SCRIPTS=$HERE
export GROOVE=$T/work/groove-flaky

t0=$(date +%s)
jid=$(sbatch --parsable --array=0-3 --cpus-per-task=1 --export=ALL "$HERE/render-array.sh")
mid=$(sbatch --parsable --dependency=afterany:"$jid" --export=ALL "$HERE/merge.sh")
st=$(wait_job "$mid")
[ "$st" = FAILED ] || { echo "the first merge should fail (part 2 missing), it ended $st" >&2; exit 1; }
grep -q "missing parts: 2" "groove-merge-$mid.log" \
  || { echo "the merge log does not name part 2:" >&2; cat "groove-merge-$mid.log" >&2; exit 1; }
[ ! -e result.exr ] || { echo "a failed merge wrote result.exr" >&2; exit 1; }
# Resubmit only the failed index, and merge again.
touch FIXED
jid2=$(sbatch --parsable --array=2 --cpus-per-task=1 --export=ALL "$HERE/render-array.sh")
mid2=$(sbatch --parsable --dependency=afterany:"$jid2" --export=ALL "$HERE/merge.sh")
st=$(wait_job "$mid2")
[ "$st" = COMPLETED ] || { echo "the second merge ended $st:" >&2; cat "groove-merge-$mid2.log" >&2; exit 1; }
"$GROOVE" render scene.xml -q -o single.exr >/dev/null
cp result.exr single.exr "$WORK/"
echo "slurm e2e: array, failed part named, resubmitted, merged in $(( $(date +%s) - t0 )) s -> $WORK/result.exr"
