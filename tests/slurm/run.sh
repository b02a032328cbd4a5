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
# target/debug/itgfx, the newer; built with cargo if neither exists). TIMEOUT (seconds,
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

# shellcheck source=tests/slurm/cluster.sh
source "$repo/tests/slurm/cluster.sh"
start=$SECONDS

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
say "PASS in $((SECONDS - start)) s of jobs"
