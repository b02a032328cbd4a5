#!/usr/bin/env bash
# The scene channel's outputs, byte for byte, on nine scenes: record them with
# one binary, check another against them (issue 27: every speed-up must leave
# the JSON and the counts files unchanged). Each case writes the `--json`
# report (its timing field dropped), the binary counts file and, for some, the
# JSON counts file; the check compares every file with `cmp`.
#
#   bench/complexity_identity.sh record DIR [ITGFX]   # e.g. with main's binary
#   bench/complexity_identity.sh check  DIR [ITGFX]   # default target/release/itgfx
#
# Thread counts vary between cases (1, 2, default): the outputs must not
# depend on them.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:?record or check}
dir=${2:?directory}
bin=${3:-target/release/itgfx}
meshes=$(cd "${MESHES:-$PWD/../shared/data/meshes}" && pwd -P)
cases=(
    "c30|cube-enclosure:30 --lines 2e6 --seed 1"
    "c30t1|cube-enclosure:30 --lines 3e5 --seed 1 --threads 1 --blocks 3"
    "c10|cube-enclosure:10 --lines 1e6 --seed 7 --threads 2"
    "room512|cubes-room:512 --lines 1e6 --seed 2"
    "cornell|cornell-box --lines 5e5 --seed 3 --blocks 5"
    "sphere|sphere --lines 5e5 --seed 4 --offset 123456789"
    "dodeca-local|dodecahedron --lines 3e5 --local --seed 5"
    "chairs|table-chairs:2 --lines 5e5 --seed 6 --shard 1/3"
    "spot|$meshes/spot.obj --lines 3e5 --seed 8 --threads 1"
)
mkdir -p "$dir"
new=$dir
if [ "$mode" = check ]; then
    new=$(mktemp -d)
    trap 'rm -rf "$new"' EXIT
fi
for c in "${cases[@]}"; do
    name=${c%%|*}
    args=${c#*|}
    extra=()
    case $name in c10|sphere|chairs) extra=(--save-counts "$new/$name.counts.json") ;; esac
    # shellcheck disable=SC2086
    "$bin" complexity $args --json --save-counts "$new/$name.counts" >"$new/$name.raw"
    [ ${#extra[@]} -eq 0 ] || "$bin" complexity $args --json "${extra[@]}" >/dev/null
    sed -E 's/,"seconds":[^,}]*//' "$new/$name.raw" >"$new/$name.json"
    rm "$new/$name.raw"
done
if [ "$mode" = check ]; then
    bad=0
    for f in "$dir"/*; do
        if ! cmp -s "$f" "$new/$(basename "$f")"; then
            echo "DIFFERS: $(basename "$f")"
            bad=1
        fi
    done
    [ $bad = 0 ] && echo "identical: $(ls "$dir" | wc -l) files"
    exit $bad
fi
echo "recorded $(ls "$dir" | wc -l) files in $dir"
