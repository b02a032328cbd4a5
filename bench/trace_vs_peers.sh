#!/usr/bin/env bash
# Global-line tracing: itgfx's CPU backend against Embree and Mitsuba 3 on the
# same lines through the same scenes, in one run. Needs: pip install embreex
# trimesh mitsuba. Usage: bench/trace_vs_peers.sh [LINES]   (default 2e6)
set -euo pipefail
cd "$(dirname "$0")/.."
lines=${1:-2e6}
out=${TMPDIR:-/tmp}/itgfx-trace-bench
mkdir -p "$out"
cargo build -q --release -p itgfx-backends --benches
for scene in cube-enclosure:30 cubes-room:512 "$PWD/../shared/data/meshes/stanford-bunny.obj@4"; do
    tag=$(basename "${scene%%@*}" .obj | tr ':' '-')
    cargo bench -q -p itgfx-backends --bench trace -- "$scene" "$lines" --export "$out/$tag" | tail -1
    python3 bench/trace_peers.py "$out/$tag" | tail -2
done
