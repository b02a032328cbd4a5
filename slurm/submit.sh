#!/bin/bash
# Submits an itgfx run as a Slurm job array of SHARDS tasks and a merge job
# that starts when every task has succeeded (afterok). Prints the job ids:
# the array's, the final merge's, then those of the merge tree's levels.
#   SHARDS=16 OUT=/shared/run1 SCENE=cube-enclosure:30 LINES=1e9 slurm/submit.sh complexity
#   SHARDS=16 OUT=/shared/run2 MESH=bunny.obj VIEWPOINTS=2562 slurm/submit.sh viewpoints
#   SHARDS=16 OUT=/shared/run3 VOLUME=head.nrrd VIEWPOINTS=642 slurm/submit.sh volume
#   SHARDS=16 OUT=/shared/run4 RSCENE=mirror-room RENDER_ARGS="--size 512x512 --spp 1024" slurm/submit.sh render
# complexity only: FANIN=k (2 or more) merges in a tree, k files per task
# (slurm/complexity-tree.sbatch), each level a job array after the one below;
# the final merge reads at most k files.
#   SHARDS=16 FANIN=2 OUT=/shared/run1 SCENE=cube-enclosure:30 LINES=1e9 slurm/submit.sh complexity
# Extra arguments go to every sbatch call (e.g. --partition=short --time=1:00:00).
# Every job is submitted with --requeue (in the scripts): a task whose node
# fails is requeued and run again on another node.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
what=${1:-}
case $what in
complexity | viewpoints | volume | render) shift ;;
*)
    echo "usage: slurm/submit.sh complexity|viewpoints|volume|render [sbatch options]" >&2
    exit 2
    ;;
esac
export SHARDS=${SHARDS:-16} OUT=${OUT:-itgfx-run}
if ! [[ $SHARDS =~ ^[1-9][0-9]*$ ]]; then
    echo "submit.sh: SHARDS must be a positive integer, got '$SHARDS'" >&2
    exit 2
fi
if [[ -n ${FANIN:-} ]]; then
    if [[ $what != complexity ]]; then
        echo "submit.sh: FANIN (a merge tree) is for complexity only: the other merges concatenate rows" >&2
        exit 2
    fi
    if ! [[ $FANIN =~ ^[1-9][0-9]*$ ]] || ((FANIN < 2)); then
        echo "submit.sh: FANIN must be an integer of at least 2, got '$FANIN'" >&2
        exit 2
    fi
fi
mkdir -p "$OUT"
array=$(sbatch --parsable --array=0-$((SHARDS - 1)) --output="$OUT/%x-%A_%a.out" "$@" "$here/$what.sbatch")
array=${array%%;*}
# The merge tree: level L merges FANIN files of level L-1 per task until at most FANIN are left.
after=$array level=0 inputs=$SHARDS tree=()
while [[ -n ${FANIN:-} ]] && ((inputs > FANIN)); do
    level=$((level + 1))
    tasks=$(((inputs + FANIN - 1) / FANIN))
    after=$(LEVEL=$level INPUTS=$inputs sbatch --parsable --array=0-$((tasks - 1)) --dependency=afterok:"$after" \
        --kill-on-invalid-dep=yes --output="$OUT/%x-%A_%a.out" "$@" "$here/complexity-tree.sbatch")
    after=${after%%;*}
    tree+=("$after")
    inputs=$tasks
done
merge=$(LEVEL=$level INPUTS=$inputs sbatch --parsable --dependency=afterok:"$after" --kill-on-invalid-dep=yes \
    --output="$OUT/%x-%j.out" "$@" "$here/$what-merge.sbatch")
merge=${merge%%;*}
echo "$array $merge ${tree[*]}"
