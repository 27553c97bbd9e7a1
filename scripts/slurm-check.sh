#!/usr/bin/env bash
# Slurm check: a policy evaluation run as a Slurm job array gives, once its
# shards are merged, the same files byte for byte as the same evaluation
# run on one machine.
#
# What it does:
#   1. installs Slurm and MUNGE from the Debian packages if they are
#      missing (slurm-wlm, munge; needs root and apt-get);
#   2. starts a one-node cluster in a temporary folder: munged, slurmctld
#      and slurmd as root, no systemd (ProctrackType=proctrack/pgid,
#      TaskPlugin=task/none work in a container), on free ports;
#   3. submits `tdeploy evaluate --shard k/n` as a job array of n tasks,
#      waits, merges the shards with `tdeploy merge`;
#   4. runs the same evaluation in one piece and compares the files;
#   5. stops the daemons it started, by their process ids, and removes the
#      temporary folder (also on failure).
#
#   scripts/slurm-check.sh            # 6 scenarios, 3 shards (~1 minute)
#   SLURM_CHECK_SCENARIOS=30 SLURM_CHECK_SHARDS=5 scripts/slurm-check.sh
#
# On a real cluster the job array is the same (see docs/user-guide.md
# "Policy evaluation"): one `tdeploy evaluate --shard $SLURM_ARRAY_TASK_ID/n` per
# task into its own folder, then `tdeploy merge` of the folders.
set -euo pipefail
cd "$(dirname "$0")/.."

scenarios=${SLURM_CHECK_SCENARIOS:-6}
shards=${SLURM_CHECK_SHARDS:-3}
say() { echo "slurm-check: $*"; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
    || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
    say "installing slurm-wlm and munge from the Debian packages"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q >/dev/null
    apt-get install -y -q slurm-wlm munge >/dev/null
fi

cargo build --release --quiet
tdeploy="$PWD/target/release/tdeploy"
evaluate_args=(evaluate --scenarios "$scenarios" --seed 11
    --policy "$PWD/policies/qp.toml" --policy "$PWD/policies/nominal.toml")

work=$(mktemp -d /tmp/tdeploy-slurm-check.XXXXXX)
chmod 755 "$work"
pids=()
cleanup() {
    local status=$?
    for pid in "${pids[@]}"; do
        kill "$pid" 2>/dev/null || true
    done
    for pid in "${pids[@]}"; do
        wait "$pid" 2>/dev/null || true
    done
    if [ "$status" -ne 0 ]; then
        for log in "$work"/*.log "$work"/*.out; do
            [ -f "$log" ] && { echo "--- $log"; tail -20 "$log"; }
        done
    fi
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT

# A TCP port nothing listens on, for each daemon (bash alone: a connect
# to it is refused).
free_port() {
    local port
    for _ in $(seq 100); do
        port=$((20000 + RANDOM % 40000))
        if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
            echo "$port"
            return
        fi
    done
    say "no free port found"
    exit 1
}

# MUNGE: its own key, socket and files in the folder.
mkdir -m 700 "$work/munge"
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
munged --force --foreground --key-file="$work/munge/munge.key" \
    --socket="$work/munge/munge.socket" --pid-file="$work/munge/munged.pid" \
    --log-file="$work/munged.log" --seed-file="$work/munge/munged.seed" \
    >"$work/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$work/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$work/munge/munge.socket" ] || { say "munged did not start"; exit 1; }

host=$(hostname -s)
ctld_port=$(free_port)
slurmd_port=$(free_port)
while [ "$slurmd_port" = "$ctld_port" ]; do slurmd_port=$(free_port); done
mkdir -p "$work/state" "$work/spool"
cat > "$work/slurm.conf" <<EOF
ClusterName=tdeploy-check
SlurmctldHost=$host
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/pgid
TaskPlugin=task/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=check Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$work/slurm.conf"

slurmctld -D -i -f "$SLURM_CONF" >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$work/slurmd.out" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
    sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && break
    sleep 0.2
done
sinfo -h -o '%T' | grep -qE '^(idle|mixed|allocated)' || { say "the node did not come up"; exit 1; }
say "one-node cluster up on $host ($(nproc) CPUs)"

# The evaluation as a job array: task k runs shard k/n into its own folder.
job=$(sbatch --parsable --array="1-$shards" --cpus-per-task=1 \
    --output="$work/job-%a.out" \
    --wrap="'$tdeploy' ${evaluate_args[*]} --threads 1 --shard \${SLURM_ARRAY_TASK_ID}/$shards -o '$work/shard-'\${SLURM_ARRAY_TASK_ID}")
say "submitted job array $job ($shards tasks, $scenarios scenarios)"
for _ in $(seq 600); do
    [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] && break
    sleep 1
done
[ -z "$(squeue -h -j "$job")" ] || { say "job array $job did not finish in 10 minutes"; exit 1; }

shard_dirs=()
for k in $(seq "$shards"); do
    [ -f "$work/shard-$k/runs.csv" ] || { say "shard $k wrote no results"; exit 1; }
    shard_dirs+=("$work/shard-$k")
done
# exit 1 means a run broke a truth limit (the nominal policy does): the
# files are written all the same; 2 is an error.
"$tdeploy" merge "${shard_dirs[@]}" -o "$work/merged" >/dev/null 2>&1 || [ $? -eq 1 ]
"$tdeploy" "${evaluate_args[@]}" -o "$work/single" >/dev/null 2>&1 || [ $? -eq 1 ]

for f in evaluation.toml runs.csv summary.csv paired.csv by_fold.csv evaluation.svg; do
    cmp "$work/single/$f" "$work/merged/$f" || { say "$f differs"; exit 1; }
done
say "ok: $shards Slurm array tasks merged equal the single run byte for byte ($(($(wc -l < "$work/single/runs.csv") - 1)) runs)"
