#!/bin/bash
# Work of a sharded `itgfx viewpoints` run against the single run, without a
# cluster: the single run, then SHARDS shard runs one after another (1 thread
# each, as job-array tasks with --cpus-per-task=1) and the merge, each timed
# with /usr/bin/time; the merge is compared with the single run bit for bit.
#   bench/slurm_viewpoints.sh      MESH (table-chairs:2), VIEWPOINTS (162), SHARDS (16), VP_ARGS (""),
#                                  SHARD_ARGS (shard-only options, e.g. "--shard-levels 1")
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
ITGFX=${ITGFX:-$repo/target/debug/itgfx}
MESH=${MESH:-table-chairs:2} VIEWPOINTS=${VIEWPOINTS:-162} SHARDS=${SHARDS:-16} VP_ARGS=${VP_ARGS:-} SHARD_ARGS=${SHARD_ARGS:-}
T=$(mktemp -d /tmp/itgfx-vpbench.XXXXXX)
trap 'rm -rf "$T"' EXIT
strip() { sed -E 's/,?"(channel_)?seconds":[^,}]*//g' "$1"; }
tm() { /usr/bin/time -f "%e %U %S %M" -a -o "$T/$1" "${@:2}"; }
# shellcheck disable=SC2086
tm single "$ITGFX" viewpoints "$MESH" --viewpoints "$VIEWPOINTS" $VP_ARGS --json > "$T/single.json"
# shellcheck disable=SC2086
tm single1 "$ITGFX" viewpoints "$MESH" --viewpoints "$VIEWPOINTS" $VP_ARGS --threads 1 --json > /dev/null
files=
for ((i = 0; i < SHARDS; i++)); do
    # shellcheck disable=SC2086
    tm shards "$ITGFX" viewpoints "$MESH" --viewpoints "$VIEWPOINTS" $VP_ARGS --threads 1 $SHARD_ARGS --shard "$i/$SHARDS" \
        --save-shard "$T/s$i.shard" --json > /dev/null
    files+=${files:+,}$T/s$i.shard
done
# shellcheck disable=SC2086
tm merge "$ITGFX" viewpoints "$MESH" --viewpoints "$VIEWPOINTS" $VP_ARGS --merge "$files" --json > "$T/merged.json"
same=no
cmp -s <(strip "$T/merged.json") <(strip "$T/single.json") && same=yes
cpu() { awk '{s += $2 + $3} END {printf "%.2f", s}' "$T/$1"; }
wmax() { awk '$1 > m {m = $1} END {printf "%.2f", m}' "$T/$1"; }
echo "mesh=$MESH viewpoints=$VIEWPOINTS shards=$SHARDS args='$VP_ARGS' shard_args='$SHARD_ARGS' load=$(cut -d' ' -f1 /proc/loadavg)"
echo "single_cpu=$(cpu single) single_1thread_cpu=$(cpu single1) shards_cpu_sum=$(cpu shards) shard_wall_max=$(wmax shards) merge_cpu=$(cpu merge) shard_bytes=$(du -cb "$T"/*.shard | tail -n 1 | cut -f1) bit_identical=$same"
grep -o '"max_subdivision_used":[0-9]*\|"views_meeting_tolerance":[0-9]*\|"visibility_rays":[0-9]*' "$T/single.json" | tr '\n' ' '
echo
