#!/usr/bin/env bash
# The patch-by-patch check of docs/RADIOSITY.md: KL solutions of $SCENE
# (default cornell-box) at a few fixed epsilons, each patch's mean radiosity
# against the renderer's path tracer from PATHS uniform points per patch
# (`itgfx radiosity --check-paths`), one row per epsilon and one CSV per run.
#
#   bench/radiosity_patches.sh [ITGFX] [OUTDIR]
set -euo pipefail
ITGFX=${1:-target/release/itgfx}
OUT=${2:-bench-out/radiosity-patches}
SCENE=${SCENE:-cornell-box}
EPSILONS=${EPSILONS:-"1e-3 1.5e-5 2e-6"}
PATHS=${PATHS:-65536}
SEED=${SEED:-1}
mkdir -p "$OUT"
printf '| epsilon | elements | links | absorbed/emitted | scene mean: solved/traced - 1 | mean abs patch diff | worst patch | strays |\n'
printf '|---:|---:|---:|---:|---:|---:|---:|---:|\n'
for e in $EPSILONS; do
  f="$OUT/kl-$e.json"
  nice -n 10 "$ITGFX" radiosity "$SCENE" --oracle kl --epsilon "$e" --seed "$SEED" --size 32 \
    --check-paths "$PATHS" --out "$OUT/kl-$e" --json > "$f.tmp" && mv "$f.tmp" "$f"
  python3 - "$f" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
worst = max(d["check_patches"], key=lambda p: abs(p["relative_difference"]))
print(f"| {d['epsilon']:g} | {d['elements']:,} | {d['links']:,} | {d['balance']:.4f} | "
      f"{100 * d['check_scene_relative']:+.2f} % ± {100 * d['check_scene_relative_stderr']:.2f} | "
      f"{100 * d['check_mean_abs_relative']:.2f} % | {worst['name']} {100 * worst['relative_difference']:+.2f} % "
      f"(z {worst['z']:.1f}) | {d['check_strays']} |")
PY
done
