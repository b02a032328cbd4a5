# shellcheck shell=bash
# Sourced by tests/slurm/run.sh and bench/slurm_complexity.sh (which set
# `repo`, the repository root, and `install`, 1 to apt-get install Slurm):
# skips (exit 0) where Slurm cannot run; otherwise starts a one-node cluster
# in a temporary directory $T (munged, slurmctld, slurmd; proctrack/linuxproc,
# task/none, select/cons_tres, no accounting), exports SLURM_CONF and ITGFX,
# and defines wait_job and strip. The EXIT trap stops exactly the daemons it
# started, by PID, and removes $T (KEEP=1 keeps it). TIMEOUT (seconds from
# the cluster's start, default 150) bounds every wait.

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
    # The newer of the release and debug builds.
    for b in "$repo/target/release/itgfx" "$repo/target/debug/itgfx"; do
        if [[ -x $b && (-z ${ITGFX:-} || $b -nt ${ITGFX:-}) ]]; then
            ITGFX=$b
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
strip() { sed -E 's/,?"(channel_|measures_)?seconds":[^,}]*//g' "$1"; }

