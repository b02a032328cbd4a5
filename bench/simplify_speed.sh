#!/usr/bin/env bash
# CPU seconds of `itgfx simplify` (default settings, 42 viewpoints) for the
# speed goals of issue 28: spot to 10 % and 2 % (5,856 triangles), the
# Stanford bunny (69,451) to 5 %. Each binary given runs every case in turn,
# alternating binaries ROUNDS times (A/B under the same load). Prints per
# run: the simplification's CPU seconds as itgfx reports them (its stage's
# `cpu_seconds`, from the start of simplify to the target, tracing
# included), and the whole process's user + system CPU seconds and wall
# seconds (/usr/bin/time: reading, welding and the evaluation renders too).
# Usage: bench/simplify_speed.sh OUTDIR ITGFX [ITGFX2 ...]   (ROUNDS=1 by default; never run by CI)
set -euo pipefail
out="$1"
shift
data=/work/shared/data/meshes
[ -d "$data" ] || data="$(cd "$(dirname "$0")/.." && pwd)/../shared/data/meshes"
exes=("$@")
mkdir -p "$out"
echo "load: $(uptime)"
for round in $(seq "${ROUNDS:-1}"); do
  for case in "spot.obj 10%" "spot.obj 2%" "stanford-bunny.obj 5%"; do
    read -r mesh target <<<"$case"
    for exe in "${exes[@]}"; do
      d="$out/$(basename "$exe")-${mesh%.obj}-${target%\%}-$round"
      /usr/bin/time -f "%U %S %e" -o "$d.time" "$exe" simplify "$data/$mesh" --target "$target" --out "$d" --json >"$d.json" 2>/dev/null
      python3 -c "import json,sys; j=json.load(open('$d.json')); r=j['results'][0]; u,s,e=open('$d.time').read().split()[-3:]; print(f\"{'$exe':40s} {'$mesh':20s} {'$target':4s} triangles {r['triangles']:6d} simplify CPU s {r['cpu_seconds']:7.2f}  process CPU s {float(u)+float(s):7.2f}  wall s {float(e):7.1f}  image RMSE {r['image_rmse']:.4f}\")"
    done
  done
done
echo "load: $(uptime)"
