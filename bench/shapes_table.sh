#!/usr/bin/env bash
# Shape retrieval: the information descriptor (it) against D2 and A3 on the
# held-out part of the retrieval set (docs/SHAPES.md). Builds itgfx and the
# set generator (release), writes the set (10 classes x PER_CLASS shapes;
# odd members held out), runs `itgfx shapes` once on the held-out shapes with
# every descriptor, under /usr/bin/time -v, and prints a Markdown table.
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
/usr/bin/time -v -o "$out/time.txt" "$here/target/release/itgfx" shapes "${files[@]}" \
  --labels "$out/set/labels-$split.csv" --out "$out/result" --json ${EXTRA:-} > "$out/shapes.json"
cpu=$(awk -F': ' '/User time/{u=$2} /System time/{s=$2} END{printf "%.1f", u+s}' "$out/time.txt")
wall=$(awk -F': ' '/Elapsed \(wall/{print $2}' "$out/time.txt")
rss=$(awk -F': ' '/Maximum resident/{printf "%.0f", $2/1024}' "$out/time.txt")
echo "# ${#files[@]} $split shapes; whole run: $cpu s CPU (user+sys), $wall wall, $rss MiB max RSS"
python3 - "$out/shapes.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print("| descriptor | NN accuracy | mAP | seconds (wall, all shapes) |")
print("|---|---|---|---|")
for d in j["descriptors"]:
    print(f"| {d['descriptor']} | {d['nearest_neighbour_accuracy']:.3f} | {d['mean_average_precision']:.3f} | {d['seconds']:.1f} |")
PY
