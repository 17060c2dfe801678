#!/usr/bin/env bash
# Prints "MESH MODE BYTES SHA256" for every mesh of ../shared/corpus (the unshuffled ones)
# compressed exactly, at --bits 16 and at --bits 12, and the sha256 of each container's
# PLY output. Run it before and after a change that must not change a byte, and diff:
#   bash benches/same_bytes.sh > /tmp/before.txt   (at the old commit)
#   bash benches/same_bytes.sh > /tmp/after.txt && diff /tmp/before.txt /tmp/after.txt
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p subwave-cli
bin=$(realpath "${CARGO_TARGET_DIR:-target}")/release/subwave
corpus=${SUBWAVE_CORPUS:-../shared/corpus}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
one() {
  set -e
  local obj=$1 mode=$2 name
  name=$(basename "$obj" .obj)
  local out="$tmp/$name.$mode.swv"
  case $mode in
    exact) "$bin" compress "$obj" "$out" --geometry-only -q ;;
    q*) "$bin" compress "$obj" "$out" --bits "${mode#q}" --geometry-only -q ;;
  esac
  "$bin" decompress "$out" "$out.ply" -q
  echo "$name $mode $(stat -c %s "$out") $(sha256sum < "$out" | cut -c1-16) $(sha256sum < "$out.ply" | cut -c1-16)"
}
export -f one
export bin tmp
ls "$corpus"/*.obj | grep -v shuffled | while read -r f; do
  for m in exact q16 q12; do echo "$f $m"; done
done | xargs -P 2 -n 2 bash -c 'one "$0" "$1"' | sort
