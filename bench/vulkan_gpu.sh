#!/usr/bin/env bash
# bench/vulkan_gpu.sh: the Vulkan backend on a real GPU against the CPU backend of the same machine, one run.
#
#   BIN=target/release/itgfx VB=target/release/examples/vulkan_bench MESHES=../shared/data/meshes \
#     OUT=/tmp/vkgpu bench/vulkan_gpu.sh [small]
#
# Each step runs with `--backend cpu` (at 2 threads and at every core) and `--backend vulkan`, writes its
# stdout/stderr under $OUT and one line "name rc wall_s user_s sys_s" to $OUT/times.tsv.
# SKIP=REGEX leaves out the steps whose name matches (e.g. SKIP='^volume|bunny-sub.cpu').
# `small` shrinks every size (a quick check of the script itself, e.g. on lavapipe).
# Afterwards `bench/vulkan_gpu_compare.py $OUT` checks that each step's JSON is the same on every backend
# (timings, backend names and memory estimates aside) and prints the table for BENCHMARKS.md.
set -u
BIN=${BIN:-target/release/itgfx}
VB=${VB:-target/release/examples/vulkan_bench}
M=${MESHES:-../shared/data/meshes}
OUT=${OUT:-/tmp/vkgpu}
TMO=${TMO:-150}
mkdir -p "$OUT"
: >"$OUT/times.tsv"
NC=$(nproc)

if [ "${1:-}" = small ]; then
    LINES_VB=100000; ELEMS=1048576; VIEWS=12; SUBDIV=1; CLINES=1e6; RSIZE=64x64; RSPP=16; VOL=hydrogen:3,2,0,32
else
    LINES_VB=10000000; ELEMS=16777216; VIEWS=162; SUBDIV=4; CLINES=1e8; RSIZE=256x256; RSPP=64; VOL=hydrogen:3,2,0,128
fi

# step NAME CMD...: time one command (GNU time's -f would need /usr/bin/time, absent on bare machines).
step() {
    local name=$1
    shift
    if [ -n "${SKIP:-}" ] && [[ $name =~ $SKIP ]]; then
        return
    fi
    echo "== $name: $*" >>"$OUT/log"
    local s e
    s=$(date +%s.%N)
    timeout "$TMO" bash -c 'time -p "$@"' _ "$@" >"$OUT/$name.out" 2>"$OUT/$name.err"
    local rc=$?
    e=$(date +%s.%N)
    local user sys
    user=$(awk '/^user /{print $2}' "$OUT/$name.err" | tail -1)
    sys=$(awk '/^sys /{print $2}' "$OUT/$name.err" | tail -1)
    printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$rc" "$(awk -v s="$s" -v e="$e" 'BEGIN{printf "%.3f", e-s}')" "${user:-?}" "${sys:-?}" | tee -a "$OUT/times.tsv"
}

# the backends: cpu at 2 threads, cpu at every core, vulkan (RUNS="cpuN vulkan" skips the 2-thread runs)
RUNS=${RUNS:-cpu2 cpuN vulkan}
three() {
    local name=$1
    shift
    for r in $RUNS; do
        case $r in
            cpu2) step "$name.cpu2" "$@" --backend cpu --threads 2 ;;
            cpuN) step "$name.cpu$NC" "$@" --backend cpu --threads "$NC" ;;
            vulkan) step "$name.vulkan" "$@" --backend vulkan ;;
        esac
    done
}

{
    uname -a
    grep -m1 "model name" /proc/cpuinfo
    nproc
    nvidia-smi -L 2>&1 || true
    "$BIN" devices 2>&1
} >"$OUT/machine.txt"
cat "$OUT/machine.txt"
if ! "$BIN" devices 2>&1 | grep -qi -e nvidia -e llvmpipe -e amd -e intel; then
    echo "no Vulkan device: stop" | tee -a "$OUT/log"
    exit 3
fi

case $RUNS in *cpu2*) step vulkan_bench.2 env RAYON_NUM_THREADS=2 "$VB" "$LINES_VB" "$ELEMS" ;; esac
step vulkan_bench.all "$VB" "$LINES_VB" "$ELEMS"
three viewpoints.bunny "$BIN" viewpoints "$M/stanford-bunny.obj" --viewpoints "$VIEWS" --json
three viewpoints.bunny-sub "$BIN" viewpoints "$M/stanford-bunny.obj" --subdivide "$SUBDIV" --viewpoints "$VIEWS" --json
three complexity "$BIN" complexity cube-enclosure:30 --lines "$CLINES" --seed 1 --json
for r in $RUNS; do
    case $r in
        cpu2) b=cpu2 args=(--backend cpu --threads 2) ;;
        cpuN) b=cpu$NC args=(--backend cpu --threads "$NC") ;;
        vulkan) b=vulkan args=(--backend vulkan) ;;
    esac
    mkdir -p "$OUT/render.$b"
    step "render.$b" "$BIN" render cornell-box --size "$RSIZE" --spp "$RSPP" --seed 1 "${args[@]}" --out "$OUT/render.$b"
done
three volume "$BIN" volume "$VOL" --viewpoints "$VIEWS" --json
for b in "cpu$NC" vulkan; do
    [ -f "$OUT/render.cpu2/image.exr" ] && [ -f "$OUT/render.$b/image.exr" ] || continue
    cmp "$OUT/render.cpu2/image.exr" "$OUT/render.$b/image.exr" && echo "render image.exr cpu2 = $b" | tee -a "$OUT/log"
done
echo done | tee -a "$OUT/log"
