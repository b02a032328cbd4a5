#!/usr/bin/env bash
# Equal-budget comparison of the pixel criteria (Part III-IV Table 3 and
# Part IV Table 2 protocol: every criterion spends the same average number of
# rays per pixel, scored against a high-spp stratified reference).
#
#   bench/render_table.sh            # mirror-room 128x128, 60 spp, 1024-spp reference, seeds 1 2
#   SIZE=64x64 SEEDS="1 2" bench/render_table.sh
#
# Each criterion's threshold is tuned once (seed 1, on its own pilot pixels,
# never on the reference) and reused for the other seeds and for --unbiased.
# Writes $OUT/table.md and the JSON of every run.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-target/release/itgfx}
OUT=${OUT:-/tmp/itgfx-render-table}
SCENE=${SCENE:-mirror-room}
SIZE=${SIZE:-128x128}
SPP=${SPP:-60}
REF_SPP=${REF_SPP:-1024}
SEEDS=${SEEDS:-"1 2"}
CRITERIA=${CRITERIA:-"cc ct kl cs hl kl-sqrt cs-sqrt hl-sqrt ec ic cc-tree ec-batch rel es"}
mkdir -p "$OUT"
run() { nice -n 10 "$BIN" render "$SCENE" --size "$SIZE" "$@" --json; }
# Runs whose JSON exists are kept (the script resumes).
have() { [ -s "$OUT/$1.json" ]; }
if [ ! -f "$OUT/ref/image.exr" ]; then
    run --out "$OUT/ref" --spp "$REF_SPP" --seed 1000 > "$OUT/ref.json"
fi
REF="$OUT/ref/image.exr"
for seed in $SEEDS; do
    have "uniform-$seed" || run --out "$OUT/uniform-$seed" --spp "$SPP" --seed "$seed" --reference "$REF" \
        > "$OUT/uniform-$seed.json"
    have "uniform2x-$seed" || run --out "$OUT/uniform2x-$seed" --spp $((2 * SPP)) --seed "$seed" --reference "$REF" \
        > "$OUT/uniform2x-$seed.json"
done
for c in $CRITERIA; do
    first=${SEEDS%% *}
    have "$c-$first" || run --out "$OUT/$c-$first" --sampler "$c" --spp "$SPP" --seed "$first" --reference "$REF" \
        > "$OUT/$c-$first.json"
    # es (supersampling) has no threshold: it spends exactly --spp, and decides once (no --unbiased).
    t=$(python3 -c "import json,sys; t=json.load(open(sys.argv[1])).get('threshold'); print('' if t is None else repr(t))" "$OUT/$c-$first.json")
    thr=()
    [ -n "$t" ] && thr=(--threshold "$t")
    for seed in $SEEDS; do
        if [ "$seed" != "$first" ] && ! have "$c-$seed"; then
            run --out "$OUT/$c-$seed" --sampler "$c" --spp "$SPP" "${thr[@]}" --seed "$seed" \
                --reference "$REF" > "$OUT/$c-$seed.json"
        fi
        [ -n "$t" ] || continue
        have "$c-unbiased-$seed" || run --out "$OUT/$c-unbiased-$seed" --sampler "$c" --spp "$SPP" "${thr[@]}" --unbiased --seed "$seed" \
            --reference "$REF" > "$OUT/$c-unbiased-$seed.json"
    done
done
python3 - "$OUT" "$SEEDS" "$CRITERIA" <<'PY'
import json, statistics, sys, os
out, seeds, crit = sys.argv[1], sys.argv[2].split(), sys.argv[3].split()
ref = json.load(open(f"{out}/ref.json"))
rows = [("uniform", "uniform"), ("uniform2x", "uniform, 2x spp")]
for c in crit:
    rows += [(c, c), (f"{c}-unbiased", f"{c} --unbiased")]
def ms(v):
    return f"{statistics.mean(v):.3f} ± {statistics.stdev(v):.3f}" if len(v) > 1 else f"{v[0]:.3f}"
lines = [f"reference: {ref['scene']} {ref['width']}x{ref['height']}, {ref['spp_mean']:.0f} spp uniform, seed 1000, "
         f"mean Y {ref['mean_luminance']:.5f}; cells: mean ± sd over seeds {' '.join(seeds)}",
         "", "| sampler | spp (image) | spp (traced) | RMSE_a | RMSE_p | PSNR_a | PSNR_p | relMSE | mean Y / ref |",
         "|---|---|---|---|---|---|---|---|---|"]
for key, name in rows:
    js = [json.load(open(f"{out}/{key}-{s}.json")) for s in seeds if os.path.exists(f"{out}/{key}-{s}.json")]
    if not js:
        continue
    g = lambda k: [j[k] for j in js]
    ratio = [j["mean_luminance"] / ref["mean_luminance"] for j in js]
    lines.append(f"| {name} | {ms(g('spp_mean'))} | {ms(g('spp_traced_mean'))} | {ms(g('RMSE_a'))} | {ms(g('RMSE_p'))} "
                 f"| {ms(g('PSNR_a'))} | {ms(g('PSNR_p'))} | {ms(g('relMSE'))} | {ms(ratio)} |")
open(f"{out}/table.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
