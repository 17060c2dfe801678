#!/usr/bin/env bash
# Whole files back (issue 30): compresses every mesh file of a folder (default
# ../shared/corpus/blender) with --keep-order, decompresses it, checks the bytes, and
# prints "FILE BYTES exact|DIFFERENT SWV XZ SWV/XZ" with xz -9e of the same file.
#   bash benches/whole_files.sh [DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p subwave-cli
bin=$PWD/target/release/subwave
dir=${1:-../shared/corpus/blender}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf "%-34s %9s %-9s %9s %9s %7s\n" file bytes back swv xz9e swv/xz
for f in "$dir"/*.obj "$dir"/*.ply "$dir"/*.off; do
  [ -e "$f" ] || continue
  n=$(basename "$f")
  "$bin" compress "$f" "$tmp/$n.swv" --keep-order -q
  "$bin" decompress "$tmp/$n.swv" "$tmp/out.${n##*.}" -q -f
  back=DIFFERENT
  cmp -s "$f" "$tmp/out.${n##*.}" && back=exact
  size=$(stat -c %s "$f")
  swv=$(stat -c %s "$tmp/$n.swv")
  xzs=$(xz -9e -c "$f" | wc -c)
  printf "%-34s %9d %-9s %9d %9d %7.3f\n" "$n" "$size" "$back" "$swv" "$xzs" "$(echo "$swv / $xzs" | bc -l)"
done
