#!/usr/bin/env bash
# Tests the Slurm scripts on a real Slurm: installs slurm-wlm's daemons and munge from
# Debian's packages (as root, where missing), starts munged, slurmctld and slurmd on this
# machine with a generated slurm.conf in a scratch directory, then
#   1. shards a small `tmo sweep` grid with submit-sweep.sh and checks the merged CSV has
#      the cells of a single run (all but the timing column), and
#   2. runs a two-replicate smoke-preset `tmo reproduce` with submit-reproduce.sh in two stages
#      (the sweeps in three parts, the steps in two shards) and checks the merged findings
#      equal a single run's (all but the time to classify a frame, which
#      is measured anew in every run).
# Every daemon it started is stopped when it ends, however it ends.
#
#   scripts/slurm/test-local-cluster.sh [TMO]      # TMO: the binary (target/release/tmo)
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
here="$repo/scripts/slurm"
TMO="$(realpath "${1:-${TMO:-$repo/target/release/tmo}}")"
[ -x "$TMO" ] || { echo "no tmo binary at $TMO: build it first (cargo build --release)" >&2; exit 2; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
    || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
    if [ "$(id -u)" != 0 ]; then
        echo "slurmctld, slurmd, sbatch and munged are missing and only root can install them (apt-get install slurmctld slurmd slurm-client munge)" >&2
        exit 2
    fi
    echo "installing slurmctld, slurmd, slurm-client and munge from Debian's packages"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
fi

work="$(mktemp -d /tmp/tmo-slurm.XXXXXX)"
pids=()
stop_daemons() {
    local status=$?
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null || true
    done
    if [ "$status" != 0 ]; then
        echo "--- the daemons' logs and the jobs' output (in $work)" >&2
        tail -n 20 "$work"/*.log "$work"/*.out "$work"/run/*.log 2>/dev/null >&2 || true
    else
        rm -rf "$work"
    fi
    exit "$status"
}
trap stop_daemons EXIT INT TERM

# munge: its own key and socket in the scratch directory, so nothing of the machine's is used
mkdir -p "$work/munge" "$work/state" "$work/spool" "$work/run"
chmod 700 "$work/munge"
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
munged --foreground --force --key-file="$work/munge/munge.key" \
    --socket="$work/munge/munge.socket" --pid-file="$work/munge/munged.pid" \
    --seed-file="$work/munge/munged.seed" --log-file="$work/munged.log" >/dev/null 2>&1 &
pids+=($!)
for _ in $(seq 100); do [ -S "$work/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$work/munge/munge.socket" ] || { echo "munged did not start" >&2; exit 1; }

host="$(hostname -s)"
cores="$(nproc)"
memory_mb="$(awk '/MemTotal/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)"
export SLURM_CONF="$work/slurm.conf"
cat > "$SLURM_CONF" <<CONF
ClusterName=tmo-test
SlurmctldHost=$host
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=$(id -un)
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge/munge.socket
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
MinJobAge=7200
NodeName=$host CPUs=$cores RealMemory=$memory_mb State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -i -f "$SLURM_CONF" >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$work/slurmd.out" 2>&1 &
pids+=($!)
ready=""
for _ in $(seq 300); do
    if sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed)'; then ready=1; break; fi
    sleep 0.2
done
[ -n "$ready" ] || { echo "the Slurm node never came up" >&2; sinfo >&2 || true; exit 1; }
echo "slurm is up on $host ($cores cores); scratch in $work"

# Waits for a job to leave the queue and fails unless it completed.
wait_for() {
    local id="$1" state=""
    for _ in $(seq 3000); do
        # a job slurmctld no longer knows makes scontrol fail: not a reason for set -e to
        # end the test without a word (it did, when the single runs outlasted MinJobAge)
        state="$( (scontrol show job "$id" 2>/dev/null || true) | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -1)"
        case "$state" in
            COMPLETED) return 0 ;;
            FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY | BOOT_FAIL | DEADLINE)
                echo "job $id ended $state" >&2; return 1 ;;
        esac
        sleep 0.2
    done
    echo "job $id did not finish in 10 minutes (last state $state)" >&2
    return 1
}

cd "$work/run"
# The sweep: trials from the simulator, a small grid in three shards.
"$TMO" sim collect --rig rail --trials 4 --seed 5 --out train >/dev/null
"$TMO" sim collect --rig rail --trials 4 --seed 6 --out test >/dev/null
sweep_args="--downsample 0.5,1 --n-slip 1,5,9"
ids="$(SHARDS=3 TMO="$TMO" TRIALS=train TEST=test OUT=sweep/sweep.csv SWEEP_ARGS="$sweep_args" \
    bash "$here/submit-sweep.sh" | tail -1)"
sweep_merge="${ids##* }"
# The reproduction: two replicates of the smoke preset (every step on the fewest trials: the
# scripts, not the findings, are under test), their sweeps in three parts, then their steps
# in two shards and the merge, submitted at once.
ids="$(SHARDS=2 SWEEP_SHARDS=3 TMO="$TMO" OUT=reproduce \
    REPRODUCE_ARGS="--preset smoke --replicates 2" bash "$here/submit-reproduce.sh" | tail -1)"
reproduce_merge="${ids##* }"
# the single runs to compare with, meanwhile
# shellcheck disable=SC2086
"$TMO" sweep train --test test $sweep_args --out single/sweep.csv >/dev/null
"$TMO" reproduce --preset smoke --replicates 2 --out single/reproduce >/dev/null

wait_for "$sweep_merge"
strip_timing() { cut -d, -f1-"$(($(head -1 "$1" | tr ',' '\n' | wc -l) - 1))" "$1"; }
if ! diff <(strip_timing sweep/sweep.csv) <(strip_timing single/sweep.csv) >/dev/null; then
    echo "the sweep merged from Slurm shards differs from a single run" >&2
    diff <(strip_timing sweep/sweep.csv) <(strip_timing single/sweep.csv) >&2 || true
    exit 1
fi
echo "sweep: 3 Slurm shards merged give the cells of a single run ($(($(wc -l < sweep/sweep.csv) - 1)) cells)"

wait_for "$reproduce_merge"
python3 - reproduce/findings.json single/reproduce/findings.json <<'PY'
import json, sys
def load(path):
    j = json.load(open(path))
    j["findings"] = [f for f in j["findings"] if f["id"] != "sf-classify-time"]
    j["measures"] = {k: v for k, v in j["measures"].items() if "classify" not in k}
    # the counts include that row's verdict, which a busy machine can flip
    for count in ("all", "values", "evidence", "standings", "headline"):
        j.pop(count, None)
    return j
merged, single = (load(p) for p in sys.argv[1:3])
if merged != single:
    differ = [k for k in merged if merged[k] != single.get(k)]
    sys.exit(f"the reproduction merged from Slurm shards differs from a single run in {differ}")
print("reproduce: 3 Slurm sweep parts and 2 shards merged give a single run's findings")
PY
echo "the Slurm scripts pass on a real single-node Slurm"
