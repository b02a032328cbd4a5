# shellcheck shell=bash
# Sourced by tests/slurm/run.sh and bench/slurm_complexity.sh (which set
# `repo`, the repository root, `install`, 1 to apt-get install Slurm, and
# `nodes`, 1 or more): skips (exit 0) where Slurm cannot run; otherwise
# starts a cluster in a temporary directory $T: munged, slurmctld and
# `nodes` slurmd (proctrack/linuxproc, task/none, select/cons_tres, no
# accounting), exports SLURM_CONF and ITGFX, and defines wait_job, strip,
# kill_node and the arrays `pids` (daemons) and `netns` (namespaces).
#
# One node: the three daemons on this machine's loopback, free ports.
# Several nodes: each slurmd in its own network and UTS namespace (hostname
# nodeK, address 10.251.0.(10+K)), slurmctld in a namespace of its own
# (10.251.0.1) that holds the bridge the nodes' veth pairs join; the
# addresses exist only inside these namespaces (no route leaves them) and
# the Slurm commands run in the controller's namespace (wrappers first on
# PATH). munged is shared through its socket file, OUT through the file
# system, as a cluster shares them over NFS. Each node has its own spool,
# log and PID files under $T/nodeK.
#
# The EXIT trap stops exactly the daemons it started, by PID, then any
# process left in its namespaces (job steps of a killed node), deletes the
# namespaces (and with them the bridge and veths), and removes $T (KEEP=1
# keeps it). TIMEOUT (seconds from the cluster's start, default 150 per
# node count 1, 300 otherwise) bounds every wait.

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
    for f in "$T"/*.log "$T"/node*/*.log "$T"/run/out/*.out; do
        [[ -s $f ]] && {
            echo "--- $f (last lines)" >&2
            tail -n 15 "$f" >&2
        }
    done
    exit 1
}
nodes=${nodes:-1}
netns=()
cleanup() {
    local rc=$?
    if [[ -n ${SLURM_CONF:-} && ${#pids[@]} -gt 1 ]]; then
        timeout 10 scancel --quiet --user="$(id -un)" > /dev/null 2>&1 || true
    fi
    # Exactly the daemons started here, newest first, by PID: TERM, then KILL after 10 s.
    local i p n
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
    # Then whatever still runs in the namespaces made here (job steps the
    # daemons left), and the namespaces themselves: deleting one deletes
    # its veth ends and, for the controller's, the bridge.
    for n in "${netns[@]}"; do
        for p in $(ip netns pids "$n" 2> /dev/null); do kill -KILL "$p" 2> /dev/null || true; done
    done
    for n in "${netns[@]}"; do
        for _ in $(seq 50); do
            [[ -z $(ip netns pids "$n" 2> /dev/null) ]] && break
            sleep 0.1
        done
        ip netns delete "$n" 2> /dev/null || say "could not delete network namespace $n"
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

# What every configuration shares: munge, root daemons, no cgroups, no
# accounting, jobs kept 600 s after they end (scontrol shows their state).
common_conf() {
    cat << EOF
ClusterName=itgfxtest
AuthType=auth/munge
AuthInfo=socket=$socket${cred_expire:+,cred_expire=$cred_expire}
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
SlurmctldPidFile=$T/slurmctld.pid
SlurmctldLogFile=$T/slurmctld.log
EOF
}
export SLURM_CONF=$T/slurm.conf
node_names=()
node_pid=()
if ((nodes == 1)); then
    host=$(hostname -s)
    ctld_port=$(free_port)
    slurmd_port=$(free_port)
    [[ $ctld_port != "$slurmd_port" ]] || slurmd_port=$((ctld_port + 1))
    cpus=$(nproc)
    {
        common_conf
        cat << EOF
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmdSpoolDir=$T/spool
SlurmdPidFile=$T/slurmd.pid
SlurmdLogFile=$T/slurmd.log
NodeName=itgfxnode NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus State=UNKNOWN
PartitionName=itgfx Nodes=itgfxnode Default=YES MaxTime=INFINITE State=UP
EOF
    } > "$SLURM_CONF"
    slurmctld -D -c -f "$SLURM_CONF" > "$T/slurmctld.out.log" 2>&1 &
    pids+=($!)
    slurmd -D -f "$SLURM_CONF" -N itgfxnode > "$T/slurmd.out.log" 2>&1 &
    pids+=($!)
    node_names=(itgfxnode)
    node_pid=($!)
    up="slurmctld :$ctld_port, slurmd :$slurmd_port, $cpus CPUs"
else
    command -v ip > /dev/null && command -v unshare > /dev/null && command -v nsenter > /dev/null ||
        fail "--nodes $nodes needs ip (iproute2), unshare and nsenter (util-linux)"
    # A requeued job waits cred_expire seconds (default 120) before it may start again.
    cred_expire=30
    # The private network: 10.251.0.0/24, only inside the namespaces below.
    net=10.251.0
    tag=itgfx-${T##*.}
    ctl_ns=$tag-ctl
    ip netns add "$ctl_ns" || fail "cannot create the network namespace $ctl_ns"
    netns+=("$ctl_ns")
    ip -n "$ctl_ns" link set lo up
    ip -n "$ctl_ns" link add br0 type bridge
    ip -n "$ctl_ns" addr add "$net.1/24" dev br0
    ip -n "$ctl_ns" link set br0 up
    for ((k = 1; k <= nodes; k++)); do
        ns=$tag-node$k
        ip netns add "$ns" || fail "cannot create the network namespace $ns"
        netns+=("$ns")
        ip -n "$ns" link set lo up
        ip -n "$ctl_ns" link add "veth$k" type veth peer name eth0 netns "$ns"
        ip -n "$ctl_ns" link set "veth$k" master br0 up
        ip -n "$ns" addr add "$net.$((10 + k))/24" dev eth0
        ip -n "$ns" link set eth0 up
        node_names+=("node$k")
        mkdir -p "$T/node$k/spool"
    done
    {
        common_conf
        cat << EOF
SlurmctldHost=ctl($net.1)
SlurmctldPort=6817
SlurmdPort=6818
SlurmdSpoolDir=$T/%n/spool
SlurmdPidFile=$T/%n/slurmd.pid
SlurmdLogFile=$T/%n/slurmd.log
SlurmdTimeout=10
EOF
        for ((k = 1; k <= nodes; k++)); do
            echo "NodeName=node$k NodeAddr=$net.$((10 + k)) NodeHostname=node$k CPUs=1 State=UNKNOWN"
        done
        echo "PartitionName=itgfx Nodes=node[1-$nodes] Default=YES MaxTime=INFINITE State=UP"
    } > "$SLURM_CONF"
    # The Slurm commands talk to slurmctld from its namespace.
    mkdir -p "$T/bin"
    for c in sbatch squeue scontrol sinfo scancel sacct; do
        real=$(command -v "$c") || continue
        printf '#!/bin/sh\nexec nsenter --net=/run/netns/%q %q "$@"\n' "$ctl_ns" "$real" > "$T/bin/$c"
        chmod +x "$T/bin/$c"
    done
    export PATH=$T/bin:$PATH
    # nsenter (not `ip netns exec`, which mounts a sysfs without the cgroup
    # file systems slurmd reads), unshare and sh each exec the next: $! is the daemon.
    # shellcheck disable=SC2016 # expanded by that sh
    nsenter --net="/run/netns/$ctl_ns" unshare --uts sh -c 'hostname ctl && exec "$@"' sh \
        slurmctld -D -c -f "$SLURM_CONF" > "$T/slurmctld.out.log" 2>&1 &
    pids+=($!)
    for ((k = 1; k <= nodes; k++)); do
        # shellcheck disable=SC2016
        nsenter --net="/run/netns/$tag-node$k" unshare --uts sh -c 'hostname "$0" && exec slurmd -D -f "$1" -N "$0"' \
            "node$k" "$SLURM_CONF" > "$T/node$k/slurmd.out.log" 2>&1 &
        pids+=($!)
        node_pid+=($!)
    done
    up="$nodes nodes node1..node$nodes at $net.11..$net.$((10 + nodes)) (namespaces $tag-*), slurmctld $net.1:6817"
fi
state=
for _ in $(seq 120); do
    for p in "${pids[@]}"; do kill -0 "$p" 2> /dev/null || fail "a daemon exited (PID $p)"; done
    state=$(timeout 5 sinfo -h -o %T 2> /dev/null | sort -u | tr '\n' ' ' || true)
    [[ $state == "idle " && $(timeout 5 sinfo -h -t idle -o %D 2> /dev/null) == "$nodes" ]] && break
    sleep 0.5
done
[[ $state == "idle " ]] || fail "the nodes are not idle after 60 s (states '$state')"
say "cluster up: $up; nodes $state"

# Node k (1-based) dies: its slurmd and everything running in its namespace
# (the job steps and tasks it started) are killed, as a power cut would.
kill_node() {
    local k=$1 p
    kill -KILL "${node_pid[k - 1]}" 2> /dev/null || true
    wait "${node_pid[k - 1]}" 2> /dev/null || true
    if ((nodes > 1)); then
        for p in $(ip netns pids "$tag-node$k"); do kill -KILL "$p" 2> /dev/null || true; done
    fi
}

deadline=$((SECONDS + ${TIMEOUT:-$((nodes == 1 ? 150 : 300))}))
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
# The JSON without its wall-clock times and a merge's memory estimate.
strip() { sed -E 's/,?"((channel_|measures_)?seconds|merge_memory_estimate_MiB)":[^,}]*//g' "$1"; }

