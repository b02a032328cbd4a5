#!/usr/bin/env bash
# Every complexity row of Part III Tables 1-9 (docs/TABLES.md), one JSON line
# per run in $OUT/runs.jsonl and a tab-separated summary on stdout.
# Usage: bench/tables.sh [ITGFX] [OUT]   (defaults: target/release/itgfx, /tmp/itgfx-tables)
# BIG=1 adds the 10^9-line rows of Tables 2 and 6 (about 15 CPU-minutes).
set -euo pipefail
BIN=${1:-target/release/itgfx}
OUT=${2:-/tmp/itgfx-tables}
mkdir -p "$OUT"
: > "$OUT/runs.jsonl"
printf 'table\trow\tscene\tlines\tlocal\tpatches\tH_P\tH_S\tI_S\tI_S_se\tI_S_corr\tI_S^c\tI_S^c_se\tescaped\tcpu_s\n'
run() { # table row scene lines [--local|--subdivide K ...]
  local t=$1 r=$2 s=$3 l=$4; shift 4
  local j
  j=$(/usr/bin/time -f '%U %S' -o "$OUT/time" "$BIN" complexity "$s" --lines "$l" --seed 1 --json "$@" 2>/dev/null)
  local cpu
  cpu=$(awk '{printf "%.2f", $1+$2}' "$OUT/time")
  echo "$j" | jq -c --arg t "$t" --arg r "$r" --arg a "$*" --argjson c "$cpu" '. + {table:$t,row:$r,args:$a,cpu_s:$c}' >> "$OUT/runs.jsonl"
  echo "$j" | jq -r --arg t "$t" --arg r "$r" --arg a "$*" --arg c "$cpu" \
    '[$t,$r,.scene,.lines,$a,.patches,(.H_P*1000|round/1000),(.H_S*1000|round/1000),(.I_S*1000|round/1000),(.I_S_stderr*1e4|round/1e4),(.I_S_corrected*1000|round/1000),(.I_S_cont*1000|round/1000),(.I_S_cont_stderr*1e4|round/1e4),.escaped,$c]|@tsv'
}
# Table 1 (10^7 global lines): Fig. 11a random, 11c clustered (11b: no second clustered layout built in).
run 1 11a cubes-room:512 1e7
run 1 11c cubes-room:512:clustered 1e7
# Table 3 (10^7): empty enclosure, 27 and 64 cubes random/clustered, 512 random/clustered.
run 3 13a cube-enclosure:10 1e7
run 3 15a cubes-room:27 1e7
run 3 15b cubes-room:27:clustered 1e7
run 3 16a cubes-room:64 1e7
run 3 16b cubes-room:64:clustered 1e7
# Table 4 (10^6 global lines).
for s in sphere icosahedron dodecahedron octahedron cube tetrahedron cornell-box; do run 4 "$s" "$s" 1e6; done
# Table 5 (10^6): Fig. 18a analogue only (the table and four chairs in a room).
run 5 18a chairs-room 1e6
# Tables 2 and 6: the enclosure at 10^5, 10^7 (10^9 with BIG=1) global lines.
for n in 10 20 30; do
  run 6 "13 N=$n" "cube-enclosure:$n" 1e5
  run 6 "13 N=$n" "cube-enclosure:$n" 1e7
  if [ "${BIG:-0}" = 1 ]; then run 6 "13 N=$n" "cube-enclosure:$n" 1e9; fi
done
# Table 7: 512 random cubes at 10^4 .. 10^7 global lines.
for l in 1e4 1e5 1e6 1e7; do run 7 11a cubes-room:512 "$l"; done
# Table 8 (10^7 local lines): the tetrahedron, and uniform splits near 151 and 793 patches.
run 8 19a tetrahedron 1e7 --local
run 8 "19b~" tetrahedron 1e7 --local --subdivide 6
run 8 "19c~" tetrahedron 1e7 --local --subdivide 14
# Table 9 (10^7 global lines): the Cornell box split uniformly.
for k in 1 3 7 10; do run 9 "20~ K=$k" cornell-box 1e7 --subdivide "$k"; done
