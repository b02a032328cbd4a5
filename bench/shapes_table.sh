#!/usr/bin/env bash
# Shape retrieval: the information descriptor (it) against D2 and A3 on the
# held-out part of the retrieval set (docs/SHAPES.md). Builds itgfx and the
# set generator (release), writes the set (10 classes x PER_CLASS shapes;
# odd members held out), runs `itgfx shapes` on the held-out shapes twice
# (--descriptor it, then d2,a3: CPU seconds of each), under /usr/bin/time -v,
# and prints a Markdown table.
# Usage: bench/shapes_table.sh [OUTDIR] [PER_CLASS] [SPLIT]   (SPLIT: heldout
# (default) or tuning; never run by CI)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-/tmp/itgfx-shapes-bench}"
per_class="${2:-10}"
split="${3:-heldout}"
data="$here/../shared/data/meshes"
[ -d "$data" ] || data=/work/shared/data/meshes
(cd "$here" && nice -n 10 cargo build --release -p itgfx-cli --bin itgfx --example shapes_set)
"$here/target/release/examples/shapes_set" "$out/set" "$data" "$per_class" 2026
uptime | sed 's/^/# /'
mapfile -t files < "$out/set/$split.txt"
# One run per descriptor group, each under /usr/bin/time -v, for CPU seconds
# of each (user + sys); the scores are the same as one run with every descriptor.
for d in it d2,a3; do
  /usr/bin/time -v -o "$out/time-$d.txt" "$here/target/release/itgfx" shapes "${files[@]}" \
    --labels "$out/set/labels-$split.csv" --descriptor "$d" --out "$out/result-$d" --json ${EXTRA:-} > "$out/shapes-$d.json"
done
uptime | sed 's/^/# /'
python3 - "$out" "${#files[@]}" "$split" <<'PY'
import json, sys, re
out, n, split = sys.argv[1:]
def cpu(d):
    t = open(f"{out}/time-{d}.txt").read()
    g = lambda k: float(re.search(k + r".*: ([0-9.]+)", t).group(1))
    return g("User time") + g("System time"), g("Maximum resident set size") / 1024
print(f"# {n} {split} shapes")
print("| descriptor | NN accuracy | mAP | CPU s (user+sys), all shapes | max RSS MiB |")
print("|---|---|---|---|---|")
for d in ["it", "d2,a3"]:
    c, rss = cpu(d)
    for x in json.load(open(f"{out}/shapes-{d}.json"))["descriptors"]:
        print(f"| {x['descriptor']} | {x['nearest_neighbour_accuracy']:.3f} | {x['mean_average_precision']:.3f} | {c:.1f} ({d}) | {rss:.0f} |")
PY
