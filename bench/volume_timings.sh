#!/bin/bash
# Timings of `itgfx volume` for docs/VOLUME.md: wall, user and system CPU
# time and peak memory (GNU time), plus the load average around each run
# (the machine is shared: CPU time is the figure to compare).
# Usage: bench/volume_timings.sh [OUT_DIR]   (builds the release binary first)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-/tmp/itgfx-volume-bench}
mkdir -p "$OUT"
nice -n 10 cargo build --release -p itgfx-cli
B=./target/release/itgfx
run() {
    local name=$1
    shift
    uptime > "$OUT/$name.load"
    /usr/bin/time -f "%e s wall, %U s user, %S s sys, %M KiB max RSS" nice -n 10 "$B" volume "$@" --json \
        > "$OUT/$name.json" 2> "$OUT/$name.time"
    echo "$name: $(tail -1 "$OUT/$name.time")  [$(sed 's/.*load/load/' "$OUT/$name.load")]"
}
run hydrogen64-162 hydrogen:3,2,0,64 --viewpoints 162 --out "$OUT/hydrogen64-162"
run hydrogen64-162-t1 hydrogen:3,2,0,64 --viewpoints 162 --threads 1
run hydrogen64-42 hydrogen:3,2,0,64 --viewpoints 42
run phantom64-162 phantom:64 --viewpoints 162 --focus left --out "$OUT/phantom64-162"
run cube32-162 cube:32 --tf step --viewpoints 162
for n in 16 32 64; do run "resolution-$n" "hydrogen:3,2,0,$n" --viewpoints 42; done
run undersampled-64 hydrogen:3,2,0,64 --viewpoints 42 --size 64
run hydrogen128-162 hydrogen:3,2,0,128 --viewpoints 162
run hydrogen256-162 hydrogen:3,2,0,256 --viewpoints 162
