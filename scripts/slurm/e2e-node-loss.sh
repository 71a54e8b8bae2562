#!/usr/bin/env bash
# Node-loss test of the Slurm recipe on a private single-node Slurm (needs root; the slow tier):
#   scripts/slurm/e2e-node-loss.sh GROOVE_BINARY WORKDIR
# testbed.sh brings up munged, slurmctld and slurmd on 127.0.0.1 (state under a temporary
# folder, stopped by PID on exit), with SlurmdTimeout=10 so that a dead node is noticed quickly.
# An array of 2 tiles of a small scene is submitted with the recipe's `--requeue`, and a merge job
# after it (afterany). Task 0 renders; task 1, on its first run, records its PIDs and waits. The
# node then "dies": slurmd, the task's slurmstepd and the task itself are killed (SIGKILL, by
# the PIDs recorded). slurmctld marks the node down and requeues task 1; slurmd is started again,
# the node returns to service (ReturnToService=2), task 1 runs again from the start and renders,
# and the merge runs. WORKDIR receives result.exr (the merge) and single.exr (one plain render),
# which `cargo test --release --test cli -- --ignored node_loss` compares bit for bit. Every wait
# is bounded; the script exits non-zero on any failure.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: $0 GROOVE_BINARY WORKDIR" >&2; exit 2; }
GROOVE=$(readlink -f "$1")
WORK=$(mkdir -p "$2" && cd "$2" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
TESTBED_CONF="SlurmdTimeout=10"
. "$HERE/testbed.sh"

cd "$T/work"
write_scene scene.xml
# Task 1's first run: note the task's PID (this shell, which then becomes `sleep`) and its
# parent's (slurmstepd), then wait to be killed with the node. Later runs render.
cat >groove-node-loss <<EOF
#!/bin/sh
if [ "\$SLURM_ARRAY_TASK_ID" = 1 ] && [ ! -e "$T/work/ran-once" ]; then
  touch "$T/work/ran-once"
  echo \$PPID >"$T/work/stepd.pid"
  echo \$\$ >"$T/work/task.pid.tmp" && mv "$T/work/task.pid.tmp" "$T/work/task.pid"
  exec sleep 300
fi
exec "$GROOVE" "\$@"
EOF
chmod +x groove-node-loss
export SCENE=scene.xml SPLIT=tile N=2 OUT=parts RESULT=result.exr SCRIPTS=$HERE
export GROOVE=$T/work/groove-node-loss

t0=$(date +%s)
jid=$(sbatch --parsable --array=0-1 --cpus-per-task=1 --export=ALL "$HERE/render-array.sh")
mid=$(sbatch --parsable --dependency=afterany:"$jid" --export=ALL "$HERE/merge.sh")
wait_for 60 "part 0" test -e parts/part-0.exr
wait_for 60 "task 1's first run" test -e task.pid
# The node dies: its slurmd, the running task's slurmstepd and the task, all at once.
kill -9 "$slurmd_pid" "$(cat stepd.pid)" "$(cat task.pid)"
node_down() { sinfo -h -n "$NODE" -o %T | grep -Eq 'down|unk|fail'; }
wait_for 90 "slurmctld to mark $NODE down" node_down
t_down=$(date +%s)
start_slurmd 90
st=$(wait_job "$mid" 300)
[ "$st" = COMPLETED ] || { echo "the merge ended $st:" >&2; cat "groove-merge-$mid.log" >&2; exit 1; }
restarts=$(scontrol show job "${jid}_1" | sed -n 's/.*Restarts=\([0-9]*\).*/\1/p' | head -1)
[ "${restarts:-0}" -ge 1 ] || { echo "task 1 was not requeued (Restarts=${restarts:-?})" >&2; exit 1; }
"$GROOVE" render scene.xml -q -o single.exr >/dev/null
cp result.exr single.exr "$WORK/"
echo "slurm node loss: node down after $(( t_down - t0 )) s, task 1 requeued (Restarts=$restarts)," \
  "merged in $(( $(date +%s) - t0 )) s -> $WORK/result.exr"
