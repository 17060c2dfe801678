#!/bin/bash
# The Blender rules set (issue 34): Blender 5.0.1 writes one subdivision surface per
# rule the fit must know (make_rules_set.py), subwave codes each.
#
#   BPY_PYTHON=venv/bin/python [DRACO_PYTHON=peers-venv/bin/python] \
#     bash benches/blender/rules_set.sh OUT_DIR [--quality N]
#
# BPY_PYTHON: a Python 3.11 with `pip install bpy==5.0.1` (Blender as a module, ~370 MB;
# PyPI). DRACO_PYTHON (optional): a Python with ../shared/tools/peers' requirements,
# for Draco cl10 at 16 bits. Prints per file: the container (exact, the file's bytes
# kept, default effort), its positions' bits per vertex (BASE + LEVL sections), its
# attributes' bytes (ATTR sections: the UV map), whether decompression gave the same
# bytes, at --bits 16 --geometry-only the container against Draco cl10's, and the
# transform.
set -euo pipefail
OUT=${1:?usage: rules_set.sh OUT_DIR [--quality N]}
shift
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
mkdir -p "$OUT/files" "$OUT/coded"
"${BPY_PYTHON:?set BPY_PYTHON to a Python with bpy 5.0.1}" "$HERE/make_rules_set.py" "$@" "$OUT/files" > "$OUT/blender.log" 2>&1
(cd "$ROOT" && cargo build --release -q -p subwave-cli)
SW="$(cd "$ROOT" && realpath "${CARGO_TARGET_DIR:-target}")/release/subwave"
if [ -n "${DRACO_PYTHON:-}" ]; then
  "$DRACO_PYTHON" "$ROOT/../shared/tools/peers/peers.py" "$OUT/files" --bits 16 \
    --peers draco_cl10 --fast --out "$OUT/draco" > /dev/null 2>&1 || true
fi
printf "%-42s %9s %8s %7s %-5s %9s %9s %6s  %s\n" file bytes pos_bpv attr_B back q16_B draco_B ratio transform
for f in "$OUT"/files/*.obj "$OUT"/files/*.ply; do
  b=$(basename "$f")
  "$SW" compress "$f" "$OUT/coded/$b.swv" -f -q
  "$SW" decompress "$OUT/coded/$b.swv" "$OUT/coded/back_$b" -f -q
  back=$(cmp -s "$f" "$OUT/coded/back_$b" && echo same || echo DIFF)
  info=$("$SW" info "$OUT/coded/$b.swv")
  v=$(echo "$info" | awk '/^vertices/{print $2}')
  geo=$(echo "$info" | grep '^sections' | grep -o -E '(BASE|LEVL) [0-9]+' | awk '{s+=$2} END{print s}')
  attr=$(echo "$info" | grep '^sections' | grep -o -E 'ATTR [0-9]+' | awk '{s+=$2} END{print s+0}')
  tr=$(echo "$info" | grep '^transform' | sed 's/transform *//')
  "$SW" compress "$f" "$OUT/coded/$b.q16.swv" -f -q --bits 16 --geometry-only
  q=$(stat -c %s "$OUT/coded/$b.q16.swv")
  d=-
  ratio=-
  if [ -f "$OUT/draco/results.csv" ]; then
    d=$(python3 - "$OUT/draco/results.csv" "${b%.*}" <<'PY'
import csv, sys
for row in csv.DictReader(open(sys.argv[1])):
    if row.get("mesh") == sys.argv[2] and row.get("peer") == "draco_cl10":
        print(row.get("bytes", "-")); break
else:
    print("-")
PY
)
    [ "$d" != "-" ] && ratio=$(echo "scale=3; $q / $d" | bc)
  fi
  printf "%-42s %9d %8.2f %7d %-5s %9d %9s %6s  %s\n" "$b" "$(stat -c %s "$OUT/coded/$b.swv")" \
    "$(echo "$geo * 8 / $v" | bc -l)" "$attr" "$back" "$q" "$d" "$ratio" "$tr"
done
