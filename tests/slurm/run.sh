#!/bin/bash
# The Slurm recipes (slurm/*.sbatch, slurm/submit.sh) on a real one-node
# cluster: starts munged, slurmctld and slurmd with a configuration written
# to a temporary directory (proctrack/linuxproc, task/none, select/cons_tres,
# no accounting), submits each recipe as a job array and its dependent merge
# job, waits (with a timeout), and compares each merged result with the
# single-process run bit for bit. Stops exactly the daemons it started, by PID.
#
#   tests/slurm/run.sh              run if Slurm and munge are installed, else skip (exit 0)
#   tests/slurm/run.sh --install    apt-get install slurm-wlm munge first (root, Debian/Ubuntu)
#
# ITGFX=path/to/itgfx picks the binary (default: target/release/itgfx or
# target/debug/itgfx, built with cargo if neither exists). TIMEOUT (seconds,
# default 150) bounds the whole wait for jobs. Exit 0: passed or skipped;
# 1: failed.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
install=0
for a in "$@"; do
    case $a in
    --install) install=1 ;;
    -h | --help)
        sed -n '2,17p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    *)
        echo "tests/slurm/run.sh: unknown argument '$a' (use --install or nothing)" >&2
        exit 2
        ;;
    esac
done

say() { echo "slurm-test: $*" >&2; }
need=(munged slurmctld slurmd sbatch squeue scontrol sinfo scancel)
export PATH=$PATH:/usr/sbin:/sbin
missing() {
    local c
    for c in "${need[@]}"; do command -v "$c" > /dev/null 2>&1 || return 0; done
    return 1
}
if missing; then
    if [[ $install == 1 ]]; then
        if [[ $(id -u) != 0 ]] || ! command -v apt-get > /dev/null; then
            say "SKIP: --install needs root and apt-get"
            exit 0
        fi
        say "installing slurm-wlm and munge with apt-get"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq > /dev/null && apt-get install -y -qq slurm-wlm munge > /dev/null
    else
        say "SKIP: Slurm is not installed (need ${need[*]}; run with --install as root on Debian/Ubuntu)"
        exit 0
    fi
fi
if [[ $(id -u) != 0 ]]; then
    say "SKIP: slurmd must run as root to launch jobs; run as root"
    exit 0
fi

# The binary under test.
if [[ -z ${ITGFX:-} ]]; then
    for b in "$repo/target/release/itgfx" "$repo/target/debug/itgfx"; do
        if [[ -x $b ]]; then
            ITGFX=$b
            break
        fi
    done
fi
if [[ -z ${ITGFX:-} ]]; then
    say "building itgfx (cargo build -p itgfx-cli)"
    (cd "$repo" && cargo build -q -p itgfx-cli)
    ITGFX=$repo/target/debug/itgfx
fi
ITGFX=$(cd "$(dirname "$ITGFX")" && pwd)/$(basename "$ITGFX")
export ITGFX
say "binary: $ITGFX"

T=$(mktemp -d /tmp/itgfx-slurm.XXXXXX)
chmod 700 "$T"
pids=()
fail() {
    say "FAIL: $*"
    for f in "$T"/*.log "$T"/run/out/*.out; do
        [[ -s $f ]] && {
            echo "--- $f (last lines)" >&2
            tail -n 15 "$f" >&2
        }
    done
    exit 1
}
cleanup() {
    local rc=$?
    if [[ -n ${SLURM_CONF:-} && ${#pids[@]} -gt 1 ]]; then
        timeout 10 scancel --quiet --user="$(id -un)" > /dev/null 2>&1 || true
    fi
    # Exactly the daemons started here, newest first, by PID: TERM, then KILL after 10 s.
    local i p
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
        p=${pids[i]}
        kill -TERM "$p" 2> /dev/null || continue
        for _ in $(seq 100); do
            kill -0 "$p" 2> /dev/null || break
            sleep 0.1
        done
        kill -KILL "$p" 2> /dev/null || true
        wait "$p" 2> /dev/null || true
    done
    if [[ $rc == 0 && -z ${KEEP:-} ]]; then rm -rf "$T"; else say "kept $T"; fi
}
trap cleanup EXIT
trap 'exit 1' INT TERM

# A free TCP port on this machine.
free_port() {
    local p
    for _ in $(seq 200); do
        p=$((20000 + RANDOM % 30000))
        if ! (exec 3<> "/dev/tcp/127.0.0.1/$p") 2> /dev/null; then
            echo "$p"
            return
        fi
    done
    fail "no free port"
}

# munged with its own key and socket.
mkdir -p "$T/munge" "$T/state" "$T/spool" "$T/run"
chmod 700 "$T/munge"
dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$T/munge/munge.key"
socket=$T/munge/munge.socket
munged -F --force --key-file="$T/munge/munge.key" --socket="$socket" --pid-file="$T/munge/munged.pid" \
    --seed-file="$T/munge/munged.seed" --log-file="$T/munged.log" > "$T/munged.out.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
    [[ -S $socket ]] && break
    kill -0 "${pids[0]}" 2> /dev/null || fail "munged exited"
    sleep 0.1
done
[[ -S $socket ]] || fail "munged did not open its socket"

host=$(hostname -s)
ctld_port=$(free_port)
slurmd_port=$(free_port)
[[ $ctld_port != "$slurmd_port" ]] || slurmd_port=$((ctld_port + 1))
cpus=$(nproc)
cat > "$T/slurm.conf" << EOF
ClusterName=itgfxtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=2
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
SlurmdParameters=config_overrides
ReturnToService=2
MinJobAge=600
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/slurmctld.log
SlurmdLogFile=$T/slurmd.log
NodeName=itgfxnode NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus State=UNKNOWN
PartitionName=itgfx Nodes=itgfxnode Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$T/slurm.conf
slurmctld -D -c -f "$SLURM_CONF" > "$T/slurmctld.out.log" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N itgfxnode > "$T/slurmd.out.log" 2>&1 &
pids+=($!)
state=
for _ in $(seq 120); do
    for p in "${pids[@]}"; do kill -0 "$p" 2> /dev/null || fail "a daemon exited (PID $p)"; done
    state=$(timeout 5 sinfo -h -n itgfxnode -o %T 2> /dev/null || true)
    [[ $state == idle* ]] && break
    sleep 0.5
done
[[ $state == idle* ]] || fail "the node is not idle after 60 s (state '$state')"
say "cluster up: slurmctld :$ctld_port, slurmd :$slurmd_port, $cpus CPUs, node $state"

start=$SECONDS
deadline=$((SECONDS + ${TIMEOUT:-150}))
# Waits for job $1 to leave the queue; fails past the deadline.
wait_job() {
    local id=$1 what=$2
    while [[ -n $(squeue -h -j "$id" -o %i 2> /dev/null) ]]; do
        ((SECONDS < deadline)) || fail "$what (job $id) still queued or running at the timeout"
        sleep 1
    done
    local st
    st=$(scontrol show job "$id" 2> /dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1)
    [[ $st == COMPLETED ]] || fail "$what (job $id) ended $st"
}
# The JSON without its wall-clock times.
strip() { sed -E 's/,?"(channel_)?seconds":[^,}]*//g' "$1"; }

submit() {
    local what=$1
    local ids
    ids=$(cd "$T/run" && "$repo/slurm/submit.sh" "$what") || fail "submit.sh $what"
    read -r array merge <<< "$ids"
    say "$what: job array $array ($SHARDS tasks), merge job $merge"
    wait_job "$merge" "$what merge"
    for ((i = 0; i < SHARDS; i++)); do
        st=$(scontrol show job "${array}_$i" 2> /dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1)
        [[ $st == COMPLETED ]] || fail "$what task $i ended '$st'"
    done
}

export SHARDS=4 OUT=$T/run/out
# complexity: 4 shards of a 10^6-line run.
export SCENE=cube-enclosure:10 LINES=1e6 SEED=7 BLOCKS=8
submit complexity
"$ITGFX" complexity "$SCENE" --lines "$LINES" --seed "$SEED" --blocks "$BLOCKS" --json > "$T/complexity-single.json"
cmp -s <(strip "$OUT/complexity.json") <(strip "$T/complexity-single.json") ||
    fail "complexity: merged shards differ from the single run: $(strip "$OUT/complexity.json") vs $(strip "$T/complexity-single.json")"
say "complexity: merged == single run, bit for bit ($(grep -o '"I_S":[^,]*' "$OUT/complexity.json"))"

# viewpoints, both estimators: 4 shards of a 42-viewpoint run.
export MESH=table-chairs:1 VIEWPOINTS=42
for VP_ARGS in "" "--estimator grid --resolution 64"; do
    export VP_ARGS
    rm -f "$OUT"/viewpoints*
    submit viewpoints
    # shellcheck disable=SC2086
    "$ITGFX" viewpoints "$MESH" --viewpoints "$VIEWPOINTS" $VP_ARGS --json > "$T/viewpoints-single.json"
    cmp -s <(strip "$OUT/viewpoints.json") <(strip "$T/viewpoints-single.json") ||
        fail "viewpoints ${VP_ARGS:-solid-angle}: merged shards differ from the single run"
    say "viewpoints ${VP_ARGS:-(solid angle)}: merged == single run, bit for bit ($(grep -o '"I_VO":[^,]*' "$OUT/viewpoints.json"))"
done

# A failed shard: the merge job never runs (afterok) and is cancelled.
export SCENE=cube-enclosure:10 LINES=1e6
ids=$(cd "$T/run" && SHARDS=2 ITGFX=/nonexistent/itgfx "$repo/slurm/submit.sh" complexity) || fail "submit.sh"
read -r array merge <<< "$ids"
while [[ -n $(squeue -h -j "$merge" -o %i 2> /dev/null) ]]; do
    ((SECONDS < deadline)) || fail "the merge job after a failed shard is still queued at the timeout"
    sleep 1
done
st=$(scontrol show job "$merge" 2> /dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1)
[[ $st == CANCELLED ]] || fail "the merge job after a failed shard ended '$st', expected CANCELLED"
say "a failed shard cancels the merge job"
say "PASS in $((SECONDS - start)) s of jobs"
