#!/usr/bin/env bash
# Global-line tracing: itgfx's CPU backend against Embree and Mitsuba 3 on the
# same lines through the same scenes, in one run. Needs: pip install embreex
# trimesh mitsuba. Usage: bench/trace_vs_peers.sh [LINES] [SCENE...]
# (default 2e6 lines; cube-enclosure:30, cubes-room:512 and the bunny at
# --subdivide 4). Set NO_MITSUBA=1 to skip Mitsuba. For built-in scenes the
# whole `itgfx complexity SCENE --lines LINES` (default jackknife blocks) is
# timed too, wall and CPU seconds, in the same run as the peers.
set -euo pipefail
cd "$(dirname "$0")/.."
lines=${1:-2e6}
shift || true
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(cube-enclosure:30 cubes-room:512 "$PWD/../shared/data/meshes/stanford-bunny.obj@4")
out=${TMPDIR:-/tmp}/itgfx-trace-bench
mkdir -p "$out"
cargo build -q --release -p itgfx-backends --benches
cargo build -q --release -p itgfx-cli
for scene in "${scenes[@]}"; do
    tag=$(basename "${scene%%@*}" .obj | tr ':' '-')
    cargo bench -q -p itgfx-backends --bench trace -- "$scene" "$lines" --export "$out/$tag" | tail -1
    python3 bench/trace_peers.py "$out/$tag" ${NO_MITSUBA:+--no-mitsuba} | tail -2
    if [[ "$scene" != */* ]]; then
        /usr/bin/time -f "{\"impl\":\"itgfx complexity\",\"scene\":\"$scene\",\"lines\":$lines,\"wall_s\":%e,\"cpu_s\":\"%U+%S\"}" \
            target/release/itgfx complexity "$scene" --lines "$lines" --json > /dev/null
    fi
done
