#!/bin/bash
# The Slurm recipes (slurm/*.sbatch, slurm/submit.sh) on a real cluster:
# starts munged, slurmctld and slurmd with a configuration written to a
# temporary directory (proctrack/linuxproc, task/none, select/cons_tres, no
# accounting; tests/slurm/cluster.sh), submits each recipe as a job array and
# its dependent merge job (complexity also through a merge tree), waits (with
# a timeout), and compares each merged result with the single-process run bit
# for bit. Stops exactly the daemons it started, by PID.
#
#   tests/slurm/run.sh              one node, if Slurm and munge are installed, else skip (exit 0)
#   tests/slurm/run.sh --nodes 4    four slurmd, each in its own network and UTS namespace
#                                   (hostnames node1..node4 on a private bridge); checks that the
#                                   tasks ran on at least 3 nodes, then kills one node during an
#                                   array and checks that its tasks are requeued and the merge is exact
#   tests/slurm/run.sh --install    apt-get install slurm-wlm munge first (root, Debian/Ubuntu)
#
# ITGFX=path/to/itgfx picks the binary (default: target/release/itgfx or
# target/debug/itgfx, the newer; built with cargo if neither exists). TIMEOUT (seconds,
# default 150 for one node, 300 for several) bounds the whole wait for jobs. Exit 0:
# passed or skipped; 1: failed.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
install=0 nodes=1
while (($#)); do
    case $1 in
    --install) install=1 ;;
    --nodes)
        nodes=${2:-}
        if ! [[ $nodes =~ ^[1-9]$ ]]; then
            echo "tests/slurm/run.sh: --nodes takes a node count from 1 to 9, got '$nodes'" >&2
            exit 2
        fi
        shift
        ;;
    -h | --help)
        sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    *)
        echo "tests/slurm/run.sh: unknown argument '$1' (use --install, --nodes N or nothing)" >&2
        exit 2
        ;;
    esac
    shift
done

# shellcheck source=tests/slurm/cluster.sh
source "$repo/tests/slurm/cluster.sh"
start=$SECONDS

# The nodes the tasks of every array ran on (scontrol's BatchHost), one a line.
hosts=$T/hosts
: > "$hosts"
# A field of `scontrol show job` for job $1.
job_field() { scontrol show job "$1" 2> /dev/null | tr ' ' '\n' | sed -n "s/^$2=//p" | head -n 1; }
submit() {
    local what=$1
    local ids
    ids=$(cd "$T/run" && "$repo/slurm/submit.sh" "$what") || fail "submit.sh $what"
    read -r array merge tree <<< "$ids"
    say "$what: job array $array ($SHARDS tasks), merge job $merge${tree:+, merge tree levels $tree}"
    wait_job "$merge" "$what merge"
    for ((i = 0; i < SHARDS; i++)); do
        st=$(job_field "${array}_$i" JobState)
        [[ $st == COMPLETED ]] || fail "$what task $i ended '$st'"
        job_field "${array}_$i" BatchHost >> "$hosts"
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
# The same run as 8 shards merged in a tree of 2-file merges: 8 -> 4 -> 2 -> the final merge.
rm -f "$OUT"/complexity*
SHARDS=8 FANIN=2 submit complexity
cmp -s <(strip "$OUT/complexity.json") <(strip "$T/complexity-single.json") ||
    fail "complexity: the tree merge of 8 shards differs from the single run"
[[ -s $OUT/complexity-t2-1.counts && ! -e $OUT/complexity-t3-0.counts ]] ||
    fail "complexity: the tree merge did not take the 2 levels expected ($(ls "$OUT"))"
say "complexity: 8 shards merged in a tree (8 -> 4 -> 2 -> 1) == single run, bit for bit"

# viewpoints, both estimators: 4 shards of a 42-viewpoint run.
export MESH=table-chairs:1 VIEWPOINTS=42
for case in "|" "|--shard-levels 16" "--estimator grid --resolution 64|"; do
    export VP_ARGS=${case%|*} SHARD_ARGS=${case#*|}
    rm -f "$OUT"/viewpoints*
    submit viewpoints
    # shellcheck disable=SC2086
    "$ITGFX" viewpoints "$MESH" --viewpoints "$VIEWPOINTS" $VP_ARGS --json > "$T/viewpoints-single.json"
    cmp -s <(strip "$OUT/viewpoints.json") <(strip "$T/viewpoints-single.json") ||
        fail "viewpoints ${VP_ARGS:-solid-angle} $SHARD_ARGS: merged shards differ from the single run"
    say "viewpoints ${VP_ARGS:-(solid angle)} $SHARD_ARGS: merged == single run, bit for bit ($(grep -o '"I_VO":[^,]*' "$OUT/viewpoints.json"))"
done

# volume: 4 shards of a 42-viewpoint run over a labelled phantom.
export VOLUME=phantom:32 VIEWPOINTS=42 VOL_ARGS="--size 48" MERGE_ARGS="--focus left"
rm -f "$OUT"/volume*
submit volume
# shellcheck disable=SC2086
"$ITGFX" volume "$VOLUME" --viewpoints "$VIEWPOINTS" $VOL_ARGS $MERGE_ARGS --json > "$T/volume-single.json"
cmp -s <(strip "$OUT/volume.json") <(strip "$T/volume-single.json") ||
    fail "volume: merged shards differ from the single run"
say "volume: merged == single run, bit for bit ($(grep -o '"I_VZ":[^,]*' "$OUT/volume.json"))"

# render: 4 shards (pixel rows) of a tuned adaptive run and of the supersampler; the merged EXR is the single run's.
for sampler in hl-sqrt es; do
    export RSCENE=mirror-room:1 RENDER_ARGS="--size 24x20 --spp 24 --sampler $sampler" MERGE_ARGS=
    rm -rf "$OUT"/render*
    submit render
    # shellcheck disable=SC2086
    "$ITGFX" render "$RSCENE" $RENDER_ARGS --out "$T/render-single" --json > /dev/null
    cmp -s "$OUT/render/image.exr" "$T/render-single/image.exr" ||
        fail "render $sampler: the merged EXR differs from the single run's"
    rm -rf "$T/render-single"
    say "render $sampler: merged EXR == single run, byte for byte ($(grep -o '"spp_mean":[^,]*' "$OUT/render.json"))"
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

if ((nodes > 1)); then
    used=$(sort -u "$hosts" | tr '\n' ' ')
    want=$((nodes < 3 ? nodes : 3))
    (($(sort -u "$hosts" | wc -l) >= want)) || fail "the tasks ran on fewer than $want nodes: $used"
    say "the tasks ran on the nodes $used($(wc -l < "$hosts") tasks)"

    # A node dies during an array: the last node's slurmd and the task it runs are
    # killed; slurmctld marks the node DOWN after SlurmdTimeout (10 s) and
    # requeues the task (sbatch --requeue), which runs again on another
    # node; the merge still equals the single run. Without the requeue the
    # task would end NODE_FAIL and the afterok merge would be cancelled.
    export SCENE=cube-enclosure:10 LINES=2000000 SHARDS=$((2 * nodes))
    rm -f "$OUT"/complexity*
    # Each task first sleeps 5 s, so that the node dies while its task runs
    # (a shard of 250,000 lines alone may end before the kill).
    printf '#!/bin/sh\nsleep 5\nexec %q "$@"\n' "$ITGFX" > "$T/slow-itgfx"
    chmod +x "$T/slow-itgfx"
    ids=$(cd "$T/run" && ITGFX=$T/slow-itgfx "$repo/slurm/submit.sh" complexity) || fail "submit.sh complexity"
    read -r array merge _ <<< "$ids"
    victim=
    while [[ -z $victim ]]; do
        ((SECONDS < deadline)) || fail "no task of array $array ran on node$nodes before the timeout"
        victim=$(squeue -h -r -j "$array" -t RUNNING -w "node$nodes" -o %i 2> /dev/null | head -n 1)
        [[ -n $victim ]] || sleep 0.2
    done
    kill_node "$nodes"
    say "node failure: killed node$nodes (slurmd and its tasks) while it ran task $victim"
    wait_job "$merge" "complexity merge after the node failure"
    st=$(timeout 5 sinfo -h -n "node$nodes" -o %T 2> /dev/null)
    [[ $st == down* ]] || fail "node$nodes is '$st' after its slurmd was killed, expected down"
    [[ $(job_field "$victim" Restarts) -ge 1 && $(job_field "$victim" BatchHost) != "node$nodes" ]] ||
        fail "task $victim was not requeued to another node (Restarts=$(job_field "$victim" Restarts), BatchHost=$(job_field "$victim" BatchHost))"
    "$ITGFX" complexity "$SCENE" --lines "$LINES" --seed "$SEED" --blocks "$BLOCKS" --json > "$T/complexity-single.json"
    cmp -s <(strip "$OUT/complexity.json") <(strip "$T/complexity-single.json") ||
        fail "complexity after the node failure: merged shards differ from the single run"
    say "node failure: task $victim requeued to $(job_field "$victim" BatchHost), merge == single run, bit for bit"
    # And were a shard's file lost, the merge names the missing lines.
    files=$OUT/complexity-0.counts
    for ((i = 2; i < SHARDS; i++)); do files+=",$OUT/complexity-$i.counts"; done
    if err=$("$ITGFX" complexity "$SCENE" --lines "$LINES" --merge "$files" --json 2>&1 > /dev/null); then
        fail "a merge without shard 1 succeeded"
    fi
    [[ $err == *"lines $((LINES / SHARDS))..$((2 * LINES / SHARDS)) of --lines $LINES are missing"* && $(wc -l <<< "$err") == 1 ]] ||
        fail "a merge without shard 1 said: $err"
    say "a merge without shard 1 is refused: $err"
fi
say "PASS in $((SECONDS - start)) s of jobs"
