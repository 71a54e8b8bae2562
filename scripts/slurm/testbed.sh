# The private single-node Slurm of the e2e tests, sourced by e2e-test.sh and e2e-node-loss.sh
# (which set GROOVE, WORK and HERE first; TESTBED_CONF adds slurm.conf lines). Installs Debian's
# slurmctld, slurmd, munge and slurm-client when missing (apt-get, idempotent), writes a
# slurm.conf on 127.0.0.1 with private ports and every state file under a temporary folder $T,
# starts munged, slurmctld -D and slurmd -D itself (no systemd) and, on exit, stops every
# process it started by PID ($pids) and removes $T. Defines wait_for (bounded waits),
# start_slurmd, job_state and wait_job.
# shellcheck shell=bash
[ "$(id -u)" = 0 ] || { echo "the Slurm test runs as root (slurmd must start jobs)" >&2; exit 2; }
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
   || ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
  pkgs=(slurmctld slurmd munge slurm-client)
  # A machine whose package lists are stale or empty needs one update first.
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${pkgs[@]}" >/dev/null 2>&1 || {
    apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${pkgs[@]}" >/dev/null
  }
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
${TESTBED_CONF:-}
EOF
export SLURM_CONF=$T/slurm.conf
slurmctld -D -f "$SLURM_CONF" >"$T/slurmctld.out" 2>&1 &
pids+=($!)
wait_for 30 "slurmctld" scontrol ping
node_idle() { sinfo -h -n "$NODE" -o %T | grep -q idle; }
# Starts slurmd (again, after a simulated node loss) and waits for the node to be idle; its
# PID is in $slurmd_pid.
start_slurmd() {
  slurmd -D -f "$SLURM_CONF" -N "$NODE" >>"$T/slurmd.out" 2>&1 &
  slurmd_pid=$!
  pids+=("$slurmd_pid")
  wait_for "${1:-60}" "node $NODE idle" node_idle
}
start_slurmd

job_state() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -1; }
# Bounded wait for job $1 to end (at most $2 seconds, default 120); prints its final state.
wait_job() {
  local s=${2:-120}
  for _ in $(seq $(( s * 4 ))); do
    local st; st=$(job_state "$1")
    case $st in COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY) echo "$st"; return 0 ;; esac
    sleep 0.25
  done
  echo "job $1 did not end within $s s" >&2; scontrol show job "$1" >&2; return 1
}

# The small test scene (41×27, 8 spp), written to $1.
write_scene() {
cat >"$1" <<'EOF'
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
}
