#!/usr/bin/env bash
# Viewpoint-driven simplification (VMI, VE, VKL; placed vertex or half-edge) against QEM (meshoptimizer
# and fast-simplification) on the shared meshes: builds itgfx (release), installs
# the peers into a virtual environment outside the workspace, runs
# bench/simplify_table.py.
# Usage: bench/simplify_table.sh [OUTDIR] [MESH.obj ...]   (never run by CI)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-/tmp/itgfx-simplify-bench}"
shift || true
meshes=("$@")
if [ ${#meshes[@]} -eq 0 ]; then
  data="$here/../shared/data/meshes"
  [ -d "$data" ] || data=/work/shared/data/meshes
  meshes=("$data/suzanne.obj" "$data/spot.obj" "$data/teapot.obj" "$data/fandisk.obj")
fi
venv="${ITGFX_BENCH_VENV:-/tmp/itgfx-simplify-venv}"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -c "import meshoptimizer, fast_simplification, numpy" 2>/dev/null ||
  "$venv/bin/pip" install -q meshoptimizer fast-simplification numpy
(cd "$here" && nice -n 10 cargo build --release -p itgfx-cli)
nice -n 10 "$venv/bin/python" "$here/bench/simplify_table.py" "$here/target/release/itgfx" "$out" "${meshes[@]}" \
  --targets "${TARGETS:-10%,2%}" --viewpoints "${VIEWPOINTS:-42}"
