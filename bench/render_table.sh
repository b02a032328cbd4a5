#!/usr/bin/env bash
# Equal-budget comparison of the pixel criteria (Part III-IV Table 3 and
# Part IV Table 2 protocol: every criterion spends the same average number of
# rays per pixel, scored against a high-spp stratified reference).
#
#   bench/render_table.sh            # mirror-room 128x128, 60 spp, 1024-spp reference, seeds 1 2
#   SIZE=64x64 SEEDS="1 2" bench/render_table.sh
#   SCENE=open-sphere CRITERIA="adaptive es hl-sqrt ec" BOUND=/tmp/bound.json bench/render_table.sh
#
# Every row traces the same average rays per pixel (--spp counts the
# decision samples too). Each criterion runs in its default, unbiased form
# (decisions on samples kept out of the image) and with --tutorial-form (the
# tutorial's shared samples, biased); its threshold is tuned once per form
# (seed 1, on its own pilot pixels of another seed, never on the reference)
# and reused for the other seeds. `adaptive` (the recommended sampler) has
# one form and no threshold. With BOUND (the JSON line of
# `cargo run --release -p itgfx-cli --example oracle_bound`), two more
# columns: RMSE_a over uniform's, and the share of the oracle bound's gain
# it captures, (1 - ratio) / (1 - bound). Writes $OUT/table.md, the JSON of
# every run and its CPU seconds ($OUT/NAME.time, user + system).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-target/release/itgfx}
OUT=${OUT:-/tmp/itgfx-render-table}
SCENE=${SCENE:-mirror-room}
SIZE=${SIZE:-128x128}
SPP=${SPP:-60}
REF_SPP=${REF_SPP:-1024}
SEEDS=${SEEDS:-"1 2"}
CRITERIA=${CRITERIA:-"adaptive cc ct kl cs hl kl-sqrt cs-sqrt hl-sqrt ec ic cc-tree ec-batch rel es"}
BOUND=${BOUND:-}
mkdir -p "$OUT"
# run NAME ARGS...: one render into $OUT/NAME, its JSON in $OUT/NAME.json, CPU seconds in $OUT/NAME.time.
run() {
    local name=$1
    shift
    /usr/bin/time -f "%U %S" -o "$OUT/$name.time" nice -n 10 "$BIN" render "$SCENE" --size "$SIZE" \
        --out "$OUT/$name" "$@" --json > "$OUT/$name.json"
}
# Runs whose JSON exists are kept (the script resumes).
have() { [ -s "$OUT/$1.json" ]; }
have ref || run ref --spp "$REF_SPP" --seed 1000
REF="$OUT/ref/image.exr"
for seed in $SEEDS; do
    have "uniform-$seed" || run "uniform-$seed" --spp "$SPP" --seed "$seed" --reference "$REF"
done
first=${SEEDS%% *}
for c in $CRITERIA; do
    for form in default tutorial; do
        # adaptive has one (unbiased) form.
        [ "$form" = tutorial ] && [ "$c" = adaptive ] && continue
        key=$c
        extra=()
        [ "$form" = tutorial ] && key=$c-tutorial && extra=(--tutorial-form)
        have "$key-$first" || run "$key-$first" --sampler "$c" --spp "$SPP" "${extra[@]}" --seed "$first" --reference "$REF"
        # es (supersampling) has no threshold: it spends exactly --spp.
        t=$(python3 -c "import json,sys; t=json.load(open(sys.argv[1])).get('threshold'); print('' if t is None else repr(t))" "$OUT/$key-$first.json")
        thr=()
        [ -n "$t" ] && thr=(--threshold "$t")
        for seed in $SEEDS; do
            [ "$seed" = "$first" ] || have "$key-$seed" ||
                run "$key-$seed" --sampler "$c" --spp "$SPP" "${extra[@]}" "${thr[@]}" --seed "$seed" --reference "$REF"
        done
    done
done
python3 - "$OUT" "$SEEDS" "$CRITERIA" "$BOUND" <<'PY'
import json, statistics, sys, os
out, seeds, crit, bound_file = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), sys.argv[4]
bound = json.load(open(bound_file))["bound"] if bound_file else None
ref = json.load(open(f"{out}/ref.json"))
rows = [("uniform", "uniform")]
for c in crit:
    rows += [(c, c)] + ([] if c == "adaptive" else [(f"{c}-tutorial", f"{c} --tutorial-form")])
def ms(v):
    return f"{statistics.mean(v):.3f} ± {statistics.stdev(v):.3f}" if len(v) > 1 else f"{v[0]:.3f}"
def cpu(key, s):
    return sum(float(x) for x in open(f"{out}/{key}-{s}.time").read().split()[-2:])
uniform = {s: json.load(open(f"{out}/uniform-{s}.json"))["mean_luminance"] for s in seeds}
lines = [f"reference: {ref['scene']} {ref['width']}x{ref['height']}, {ref['spp_mean']:.0f} spp uniform, seed 1000, "
         f"mean Y {ref['mean_luminance']:.5f}; cells: mean ± sd over seeds {' '.join(seeds)}"
         + (f"; oracle bound (cross-validated) {bound:.3f} x uniform's RMSE_a" if bound else ""),
         "", "| sampler | spp (image) | spp (traced) | RMSE_a | RMSE_p | PSNR_a | PSNR_p | relMSE | mean Y / ref "
         "| mean Y / uniform | CPU-s |" + (" RMSE_a / uniform | share of the bound's gain |" if bound else ""),
         "|---|---|---|---|---|---|---|---|---|---|---|" + ("---|---|" if bound else "")]
def share(r):
    # Undefined where the bound promises (almost) nothing: 1 - bound below 0.05.
    return ms([(1 - x) / (1 - bound) for x in r]) if bound and 1 - bound >= 0.05 else "—"
uniform_rmse = {s: json.load(open(f"{out}/uniform-{s}.json"))["RMSE_a"] for s in seeds}
for key, name in rows:
    have = [s for s in seeds if os.path.exists(f"{out}/{key}-{s}.json")]
    js = [json.load(open(f"{out}/{key}-{s}.json")) for s in have]
    if not js:
        continue
    g = lambda k: [j[k] for j in js]
    ratio = [j["mean_luminance"] / ref["mean_luminance"] for j in js]
    to_u = [j["mean_luminance"] / uniform[s] for j, s in zip(js, have)]
    lines.append(f"| {name} | {ms(g('spp_mean'))} | {ms(g('spp_traced_mean'))} | {ms(g('RMSE_a'))} | {ms(g('RMSE_p'))} "
                 f"| {ms(g('PSNR_a'))} | {ms(g('PSNR_p'))} | {ms(g('relMSE'))} | {ms(ratio)} | {ms(to_u)} "
                 f"| {ms([cpu(key, s) for s in have])} |"
                 + (f" {ms([j['RMSE_a'] / uniform_rmse[s] for j, s in zip(js, have)])} "
                    f"| {share([j['RMSE_a'] / uniform_rmse[s] for j, s in zip(js, have)])} |"
                    if bound else ""))
open(f"{out}/table.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
