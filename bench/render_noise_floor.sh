#!/bin/sh
# The path tracer's per-sample noise floor, itgfx alone (issue 23): each
# scene rendered with seeds 2 and 1, and the relMSE of seed 1's image
# against seed 2's, mean over pixels and channels of (a - b)^2 / (b^2 + 0.01)
# (`render --reference`, the formula of bench/render_mitsuba.py). The floor
# scales as 1/spp. Also prints both images' mean luminance and the CPU
# seconds (user + system) of seed 1's render.
#
#   bench/render_noise_floor.sh [BIN]     (default target/release/itgfx)
#   SIZE=256x256 SPP=64 THREADS=2 SCENES="cornell-box mirror-room" OUT=/tmp/noise-floor
set -eu
BIN=${1:-target/release/itgfx}
SIZE=${SIZE:-256x256}
SPP=${SPP:-64}
THREADS=${THREADS:-2}
SCENES=${SCENES:-cornell-box mirror-room}
OUT=${OUT:-/tmp/noise-floor}
field() { sed -n "s/.*\"$1\":\([^,}]*\).*/\1/p"; }
echo "scene size spp relMSE(seed1,seed2) meanY(seed1) meanY(seed2) cpu_s(seed1)"
for s in $SCENES; do
    common="$s --size $SIZE --spp $SPP --threads $THREADS --json"
    "$BIN" render $common --seed 2 --out "$OUT/$s-2" >"$OUT.$s-2.json"
    /usr/bin/time -f "%U %S" -o "$OUT.$s.time" \
        "$BIN" render $common --seed 1 --out "$OUT/$s-1" --reference "$OUT/$s-2/image.exr" >"$OUT.$s-1.json"
    rel=$(field relMSE <"$OUT.$s-1.json")
    y1=$(field mean_luminance_a <"$OUT.$s-1.json")
    y2=$(field mean_luminance_b <"$OUT.$s-1.json")
    cpu=$(awk '{print $1 + $2}' "$OUT.$s.time")
    echo "$s $SIZE $SPP $rel $y1 $y2 $cpu"
done
