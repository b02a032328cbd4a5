#!/usr/bin/env bash
# The viewpoint channel's `--json` reports, byte for byte (timing fields
# dropped), on the five test meshes and six built-in scenes: record them with
# one binary, check another against them (issue 27: every speed-up must leave
# every VMI, and every other output, unchanged). About 3 CPU-minutes.
#
#   bench/viewpoint_identity.sh record DIR [ITGFX]   # e.g. with main's binary
#   bench/viewpoint_identity.sh check  DIR [ITGFX]   # default target/release/itgfx
#
# Thread counts vary (1, default): the outputs must not depend on them.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:?record or check}
dir=${2:?directory}
bin=${3:-target/release/itgfx}
meshes=$(cd "${MESHES:-$PWD/../shared/data/meshes}" && pwd -P)
cases=(
    "bunny42|$meshes/stanford-bunny.obj"
    "bunny42t1|$meshes/stanford-bunny.obj --threads 1"
    "bunny162|$meshes/stanford-bunny.obj --viewpoints 162"
    "bunnypp|$meshes/stanford-bunny.obj --per-polygon --background"
    "spot|$meshes/spot.obj --viewpoints 162"
    "suzanne|$meshes/suzanne.obj --viewpoints 162"
    "teapot|$meshes/teapot.obj --viewpoints 162"
    "fandisk|$meshes/fandisk.obj --viewpoints 162"
    "chairs|table-chairs:2 --viewpoints 42 --per-polygon"
    "geosphere|geosphere:2 --viewpoints 42 --per-polygon"
    "cubes|cubes-room:16 --viewpoints 42 --per-polygon"
    "torus|torus --viewpoints 42 --per-polygon"
    "cornell|cornell-box --viewpoints 42 --per-polygon"
    "open-sphere|open-sphere --viewpoints 42 --per-polygon"
)
mkdir -p "$dir"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bad=0
for c in "${cases[@]}"; do
    name=${c%%|*}
    # shellcheck disable=SC2086
    "$bin" viewpoints ${c#*|} --json > "$tmp/raw.json" 2> /dev/null
    python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
for k in ("channel_seconds", "seconds"):
    d.pop(k, None)
json.dump(d, open(sys.argv[2], "w"), sort_keys=True)' "$tmp/raw.json" "$tmp/$name.json"
    if [ "$mode" = record ]; then
        cp "$tmp/$name.json" "$dir/$name.json"
    elif cmp -s "$tmp/$name.json" "$dir/$name.json"; then
        echo "same $name"
    else
        echo "DIFFERENT $name"
        bad=1
    fi
done
[ "$mode" = record ] && echo "recorded ${#cases[@]} reports in $dir"
exit $bad
