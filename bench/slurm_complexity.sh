#!/bin/bash
# Sharding overhead of `itgfx complexity` on a real Slurm cluster
# (tests/slurm/cluster.sh): the single run against SHARDS job-array tasks
# (1 CPU each) and their afterok merge job, timed, and compared bit for bit.
#   bench/slurm_complexity.sh [--install]      SCENE (cube-enclosure:30), LINES (1e8), SHARDS (16)
#   NODES=4: the cluster of tests/slurm/run.sh --nodes 4 (namespaces), else one node
#   FANIN=k: merge in a tree of k-file merges (slurm/submit.sh), each step timed
#   SINGLE_DIR=D: no single run here; D/time-single (/usr/bin/time -f "%e %U %S %M") and D/single.json
#   of one timed separately are read when the cluster is done.
# Prints one line per measurement and a summary; needs root (slurmd launches jobs).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
install=0 nodes=${NODES:-1}
[[ ${1:-} == --install ]] && install=1
export TIMEOUT=${TIMEOUT:-3600}
# shellcheck source=tests/slurm/cluster.sh
source "$repo/tests/slurm/cluster.sh"
SCENE=${SCENE:-cube-enclosure:30} LINES=${LINES:-1e8} SEED=${SEED:-1}
export SCENE LINES SEED BLOCKS=8 SHARDS=${SHARDS:-16} OUT=$T/run/out
mkdir -p "$OUT"
real=$ITGFX
# Every task's wall, user and system seconds and peak memory (KiB), by job id.
cat > "$T/timed-itgfx" << EOS
#!/bin/bash
exec /usr/bin/time -f "%e %U %S %M" -o "$OUT/time-\${SLURM_JOB_NAME}-\${SLURM_ARRAY_TASK_ID:-merge}\${LEVEL:+-L\$LEVEL}" "$real" "\$@"
EOS
chmod +x "$T/timed-itgfx"
now() { date +%s.%N; }
say "machine: $(nproc) CPUs, load $(cut -d' ' -f1-3 /proc/loadavg); binary $real"
t0=$(now)
if [[ -z ${SINGLE_DIR:-} ]]; then
    /usr/bin/time -f "%e %U %S %M" -o "$T/time-single" "$real" complexity "$SCENE" --lines "$LINES" --seed "$SEED" \
        --blocks 8 --json > "$T/single.json"
    say "single: $(cat "$T/time-single") (wall user sys KiB), threads $(nproc)"
fi
t1=$(now)
ids=$(cd "$T/run" && ITGFX=$T/timed-itgfx "$repo/slurm/submit.sh" complexity) || fail "submit"
read -r array merge tree <<< "$ids"
while [[ -n $(squeue -h -j "$merge" -o %i 2> /dev/null) ]]; do
    ((SECONDS < deadline)) || fail "timeout"
    sleep 0.5
done
t2=$(now)
if [[ -n ${SINGLE_DIR:-} ]]; then
    # A single run timed separately (one 10^9 run is enough), read once the cluster is done.
    while [[ ! -s $SINGLE_DIR/time-single ]]; do sleep 5; done
    cp "$SINGLE_DIR/time-single" "$SINGLE_DIR/single.json" "$T/"
    say "single: $(cat "$T/time-single") (wall user sys KiB) from $SINGLE_DIR"
fi
st=$(scontrol show job "$merge" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1)
[[ $st == COMPLETED ]] || fail "merge job ended $st"
same=no
cmp -s <(strip "$OUT/complexity.json") <(strip "$T/single.json") && same=yes
tasks=$(cat "$OUT"/time-itgfx-complexity-[0-9]*)
sum() { awk -v c="$1" '{s += $c} END {printf "%.1f", s}'; }
max() { awk -v c="$1" '$c > m {m = $c} END {printf "%.1f", m}'; }
say "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "scene=$SCENE lines=$LINES shards=$SHARDS cpus=$(nproc)"
echo "single_wall=$(cut -d' ' -f1 "$T/time-single") single_cpu=$(awk '{printf "%.1f", $2 + $3}' "$T/time-single") single_rss_kib=$(cut -d' ' -f4 "$T/time-single")"
echo "cluster_wall=$(echo "$t2 - $t1" | bc) tasks_wall_sum=$(echo "$tasks" | sum 1) tasks_wall_max=$(echo "$tasks" | max 1) tasks_cpu_sum=$(echo "$tasks" | awk '{s += $2 + $3} END {printf "%.1f", s}')"
for f in "$OUT"/time-itgfx-complexity-tree-*; do
    [[ -e $f ]] || continue
    k=${f##*-tree-}
    est=$(grep -o '"merge_memory_estimate_MiB":[0-9.]*' "$OUT/complexity-t${k#*-L}-${k%-L*}.json" | cut -d: -f2)
    echo "tree level ${k#*-L} task ${k%-L*}: $(cat "$f") (wall user sys KiB), estimate_mib=$est"
done
if [[ -n ${tree:-} ]]; then
    steps=$(cat "$OUT"/time-itgfx-complexity-tree-*)
    echo "tree_tasks=$(echo "$steps" | wc -l) tree_cpu_sum=$(echo "$steps" | awk '{s += $2 + $3} END {printf "%.1f", s}') tree_rss_max_kib=$(echo "$steps" | max 4)"
fi
echo "merge: $(cat "$OUT"/time-itgfx-complexity-merge-merge*) (wall user sys KiB), estimate_mib=$(grep -o '"merge_memory_estimate_MiB":[0-9.]*' "$OUT/complexity.json" | cut -d: -f2)"
echo "hosts: $(for ((i = 0; i < SHARDS; i++)); do scontrol show job "${array}_$i" | tr ' ' '\n' | sed -n 's/^BatchHost=//p'; done | sort | uniq -c | tr -s ' \n' ' ')"
echo "counts_bytes=$(du -cb "$OUT"/complexity-[0-9]*.counts | tail -n 1 | cut -f1) bit_identical=$same single_phase_wall=$(echo "$t1 - $t0" | bc)"
