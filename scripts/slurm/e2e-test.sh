#!/usr/bin/env bash
# End-to-end test of the Slurm recipe on a private single-node Slurm (needs root):
#   scripts/slurm/e2e-test.sh GROOVE_BINARY WORKDIR
# Installs Debian's slurmctld, slurmd, munge and slurm-client when missing (apt-get, idempotent),
# writes a slurm.conf on 127.0.0.1 with private ports and every state file under a temporary
# folder, starts munged, slurmctld -D and slurmd -D itself (no systemd) and stops them by their
# PIDs on exit. Then: an array of 4 tiles of a small scene in which task 2 fails on its first
# run; the merge job (afterany) must fail and name part 2; index 2 alone is resubmitted with a
# new merge job, which must succeed. WORKDIR receives result.exr (the merge) and single.exr (one
# plain render of the same scene), which `cargo test --release --test cli -- --ignored slurm`
# compares bit for bit. Every wait is bounded; the script exits non-zero on any failure.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: $0 GROOVE_BINARY WORKDIR" >&2; exit 2; }
GROOVE=$(readlink -f "$1")
WORK=$(mkdir -p "$2" && cd "$2" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
[ "$(id -u)" = 0 ] || { echo "the Slurm test runs as root (slurmd must start jobs)" >&2; exit 2; }
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
   || ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q slurmctld slurmd munge slurm-client >/dev/null
fi

T=$(mktemp -d /tmp/groove-slurm.XXXXXX)
chmod 700 "$T"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$p" 2>/dev/null || true
  done
  rm -rf "$T"
}
trap cleanup EXIT

# Bounded wait: wait_for SECONDS WHAT COMMAND...
wait_for() {
  local s=$1 what=$2; shift 2
  for _ in $(seq $(( s * 4 ))); do "$@" >/dev/null 2>&1 && return 0; sleep 0.25; done
  echo "timed out after ${s}s waiting for $what" >&2
  for f in "$T"/*.log; do echo "== $f" >&2; tail -20 "$f" >&2; done
  return 1
}

mkdir -p "$T/munge" "$T/ctld" "$T/slurmd" "$T/work"
dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$T/munge/munge.key"
munged -F --force --key-file="$T/munge/munge.key" --socket="$T/munge/munge.socket" \
  --pid-file="$T/munge/munged.pid" --log-file="$T/munged.log" --seed-file="$T/munge/seed" \
  >"$T/munged.out" 2>&1 &
pids+=($!)
wait_for 20 "munged" test -S "$T/munge/munge.socket"

NODE=$(hostname -s)
PORT=$(( 20000 + RANDOM % 20000 ))
CPUS=$(nproc)
cat >"$T/slurm.conf" <<EOF
ClusterName=groovetest
SlurmctldHost=$NODE(127.0.0.1)
SlurmctldPort=$PORT
SlurmdPort=$(( PORT + 1 ))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$T/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$T/ctld
SlurmdSpoolDir=$T/slurmd
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/slurmctld.log
SlurmdLogFile=$T/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
MailProg=/bin/true
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$CPUS State=UNKNOWN
PartitionName=test Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$T/slurm.conf
slurmctld -D -f "$SLURM_CONF" >"$T/slurmctld.out" 2>&1 &
pids+=($!)
wait_for 30 "slurmctld" scontrol ping
slurmd -D -f "$SLURM_CONF" -N "$NODE" >"$T/slurmd.out" 2>&1 &
pids+=($!)
node_idle() { sinfo -h -n "$NODE" -o %T | grep -q idle; }
wait_for 60 "node $NODE idle" node_idle

# The scene, and a groove wrapper that makes task 2 fail until FIXED exists.
cd "$T/work"
cat >scene.xml <<'EOF'
<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,1,4" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
        <film type="hdrfilm"><integer name="width" value="41"/><integer name="height" value="27"/></film>
    </sensor>
    <shape type="sphere"><float name="radius" value="0.7"/><bsdf type="roughconductor"/></shape>
    <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
</scene>
EOF
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

job_state() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -1; }
# Bounded wait for job $1 to end; prints its final state.
wait_job() {
  for _ in $(seq 480); do
    local st; st=$(job_state "$1")
    case $st in COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY) echo "$st"; return 0 ;; esac
    sleep 0.25
  done
  echo "job $1 did not end within 120 s" >&2; scontrol show job "$1" >&2; return 1
}

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
