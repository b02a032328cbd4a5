#!/usr/bin/env bash
# The equal-element-count table of docs/RADIOSITY.md (Part III-IV Table 2
# in spirit): every oracle at ~N elements on $SCENE (default cornell-box), scored
# against a path-traced reference, over several seeds.
#
#   bench/radiosity_table.sh [ITGFX] [OUTDIR]
#
# Makes the reference first when OUTDIR/ref/reference.pfm is missing
# (WALKS walks per pixel, SIZE x SIZE pixels, seed 1000: not a solver seed).
set -euo pipefail
ITGFX=${1:-target/debug/itgfx}
OUT=${2:-bench-out/radiosity}
SIZE=${SIZE:-128}
WALKS=${WALKS:-2048}
COUNTS=${COUNTS:-"1000 5000"}
SEEDS=${SEEDS:-"1 2 3"}
ORACLES=${ORACLES:-"power ks ks-avg mi kl cs hl variance"}
SCENE=${SCENE:-cornell-box}
mkdir -p "$OUT"
if [ ! -f "$OUT/ref/reference.pfm" ]; then
  nice -n 10 "$ITGFX" radiosity "$SCENE" --path-trace "$WALKS" --size "$SIZE" --seed 1000 --out "$OUT/ref" --json > "$OUT/ref.json"
fi
for n in $COUNTS; do
  for o in $ORACLES; do
    for s in $SEEDS; do
      f="$OUT/$o-$n-$s.json"
      [ -f "$f" ] && continue
      nice -n 10 "$ITGFX" radiosity "$SCENE" --oracle "$o" --elements "$n" --seed "$s" --size "$SIZE" \
        --reference "$OUT/ref/reference.pfm" --out "$OUT/$o-$n-$s" --json > "$f.tmp" && mv "$f.tmp" "$f"
    done
  done
done
python3 "$(dirname "$0")/radiosity_table.py" "$OUT"
