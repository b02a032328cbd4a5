#!/bin/bash
# Submits an itgfx run as a Slurm job array of SHARDS tasks and a merge job
# that starts when every task has succeeded (afterok). Prints the two job ids.
#   SHARDS=16 OUT=/shared/run1 SCENE=cube-enclosure:30 LINES=1e9 slurm/submit.sh complexity
#   SHARDS=16 OUT=/shared/run2 MESH=bunny.obj VIEWPOINTS=2562 slurm/submit.sh viewpoints
#   SHARDS=16 OUT=/shared/run3 VOLUME=head.nrrd VIEWPOINTS=642 slurm/submit.sh volume
#   SHARDS=16 OUT=/shared/run4 RSCENE=mirror-room RENDER_ARGS="--size 512x512 --spp 1024" slurm/submit.sh render
# Extra arguments go to both sbatch calls (e.g. --partition=short --time=1:00:00).
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
mkdir -p "$OUT"
array=$(sbatch --parsable --array=0-$((SHARDS - 1)) --output="$OUT/%x-%A_%a.out" "$@" "$here/$what.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" --kill-on-invalid-dep=yes --output="$OUT/%x-%j.out" "$@" \
    "$here/$what-merge.sbatch")
merge=${merge%%;*}
echo "$array $merge"
