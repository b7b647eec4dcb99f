#!/usr/bin/env bash
# Runs scripts/slurm/eval_array.sbatch on a real Slurm: starts a one-node cluster on this
# machine (munged, slurmctld and slurmd run by this script, no systemd), generates 8 parts
# with `s2g gen`, submits a 4-task array of `s2g eval --shard K/4` over them, waits,
# merges the per-part results with `s2g eval --merge` and compares the tables byte for
# byte with one `s2g eval` process over the same parts. Prints PASS or FAIL (exit 0 or 1)
# and stops the daemons it started, whatever happens.
#
#   cargo build --release -p shape2gcode-cli
#   sudo scripts/slurm/test_local_cluster.sh
#
# Needs root (the daemons run as root, and apt-get installs slurm-wlm and munge on
# Debian or Ubuntu when they are missing). The evaluation is small (16^3, 256 points, the
# fixed-fine and fixed-coarse policies, whose rows differ there) so the run takes a few
# minutes. Environment: S2G (default
# target/release/s2g), S2G_SLURM_PORT (slurmctld's port, default 6817; slurmd gets the
# next), S2G_SLURM_TIMEOUT (seconds to wait for the array, default 1800), S2G_SLURM_KEEP=1
# (keep the temporary folder, which a FAIL always keeps).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
repo=$PWD
s2g=${S2G:-$repo/target/release/s2g}
ctld_port=${S2G_SLURM_PORT:-6817}
slurmd_port=$((ctld_port + 1))
timeout_s=${S2G_SLURM_TIMEOUT:-1800}
shards=4
parts=8
eval_args=(--res 16 --points 256 --policies "fine,coarse" --tables "policies,orientation")

say() { printf 'test_local_cluster: %s\n' "$*" >&2; }

if [[ ! -x $s2g ]]; then
    say "no $s2g: build it first (cargo build --release -p shape2gcode-cli) or set S2G"
    exit 2
fi
if [[ $(id -u) -ne 0 ]]; then
    say "run as root: the Slurm daemons run as root here, and apt-get may have to install them"
    exit 2
fi

# Install what is missing (Debian's slurm-wlm brings slurmctld, slurmd and the clients).
need=()
for cmd in munged slurmctld slurmd sbatch sinfo; do
    command -v "$cmd" >/dev/null 2>&1 || need=(slurm-wlm munge)
done
if [[ ${#need[@]} -gt 0 ]]; then
    say "installing ${need[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi

work=$(mktemp -d /tmp/s2g-slurm.XXXXXX)
chmod 711 "$work"
mkdir -p "$work"/{etc,munge,state,spool,log,parts,results}
started=()
job=""
status=FAIL

cleanup() {
    local pid
    if [[ -n $job ]]; then
        scancel "$job" >/dev/null 2>&1 || true
    fi
    # Stop the daemons this script started (slurmd and slurmctld first, munged last).
    for ((i = ${#started[@]} - 1; i >= 0; i--)); do
        pid=${started[i]}
        kill "$pid" 2>/dev/null || true
        wait "$pid" 2>/dev/null || true
    done
    if [[ $status == PASS && ${S2G_SLURM_KEEP:-0} != 1 ]]; then
        rm -rf "$work"
    else
        say "kept $work (logs in $work/log)"
    fi
}
trap cleanup EXIT

fail() {
    say "$*"
    local log
    for log in "$work"/log/*.log "$work"/log/*.out; do
        if [[ -f $log ]]; then
            say "--- tail of $log"
            tail -n 20 "$log" >&2
        fi
    done
    echo FAIL
    exit 1
}

# munge: a fresh key, and munged on a socket of our own (the system's, if any, is left be).
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
socket=$work/munge/munge.socket
munged --foreground --force --key-file="$work/munge/munge.key" --socket="$socket" \
    --pid-file="$work/munge/munged.pid" --seed-file="$work/munge/munged.seed" \
    --log-file="$work/log/munged.log" 2>"$work/log/munged.out" &
started+=("$!")
for _ in $(seq 50); do [[ -S $socket ]] && break; sleep 0.2; done
[[ -S $socket ]] || fail "munged did not start"

# A one-node slurm.conf: this host, its real CPU count and memory.
host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo)
conf=$work/etc/slurm.conf
cat >"$conf" <<EOF
ClusterName=s2gtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=s2g Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf

say "starting slurmctld and slurmd for node $host ($cpus CPUs, $mem_mb MB)"
slurmctld -D -c -f "$conf" >"$work/log/slurmctld.out" 2>&1 &
started+=("$!")
slurmd -D -f "$conf" >"$work/log/slurmd.out" 2>&1 &
started+=("$!")
state=""
for _ in $(seq 120); do
    state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.5
done
[[ $state == idle ]] || fail "node $host is not idle after 60 s (state '${state}')"

"$s2g" gen --count "$parts" --seed 37 --out "$work/parts" >&2

t0=$(date +%s)
say "submitting a $shards-task array over $parts parts"
cd "$work"
job=$(sbatch --parsable --array=0-$((shards - 1)) --output="$work/log/task-%a.log" \
    --export=ALL,S2G="$s2g" "$repo/scripts/slurm/eval_array.sbatch" \
    "$work/results" --corpus "$work/parts" "${eval_args[@]}")
say "job $job submitted; waiting"
while :; do
    left=$(squeue -h -j "$job" 2>/dev/null | wc -l)
    [[ $left -eq 0 ]] && break
    (($(date +%s) - t0 < timeout_s)) || fail "the array is not done after $timeout_s s"
    sleep 1
done
t1=$(date +%s)
job=""
say "array done in $((t1 - t0)) s"
for k in $(seq 0 $((shards - 1))); do
    [[ -f $work/log/task-$k.log ]] || fail "array task $k wrote no log"
    grep -q "shard $k/$shards:" "$work/log/task-$k.log" || fail "array task $k did not finish: $(tail -n 3 "$work/log/task-$k.log")"
done

"$s2g" eval --merge "$work/results" >"$work/merged.md"
t2=$(date +%s)
"$s2g" eval --corpus "$work/parts" "${eval_args[@]}" >"$work/single.md" 2>"$work/log/single.log"
t3=$(date +%s)
say "single process in $((t3 - t2)) s"
if ! cmp "$work/single.md" "$work/merged.md" >&2; then
    diff "$work/single.md" "$work/merged.md" >&2 || true
    fail "the merged tables differ from the single-process ones"
fi
cat "$work/merged.md"
status=PASS
echo PASS
