#!/usr/bin/env bash
# Peak memory of CPU detection on a 24 MP image (issue 11's bar: 2 GB), measured with
# /usr/bin/time -v on a generated 6000×4000 scene. Usage: bash benches/memory.sh [LIMIT_MB]
set -euo pipefail
cd "$(dirname "$0")/.."
limit_mb=${1:-2048}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cargo build --release --quiet --bin steernav --example generate_sample
./target/release/examples/generate_sample 6000 4000 "$dir/24mp.ppm" >/dev/null
/usr/bin/time -v ./target/release/steernav detect "$dir/24mp.ppm" --backend cpu \
  >"$dir/keypoints.json" 2>"$dir/time.txt"
peak_kb=$(awk -F: '/Maximum resident set size/ {gsub(/ /, "", $2); print $2}' "$dir/time.txt")
wall=$(awk '/Elapsed \(wall clock\)/ {print $NF}' "$dir/time.txt")
echo "24 MP CPU detect: peak $((peak_kb / 1024)) MB, wall $wall (limit ${limit_mb} MB)"
[ "$((peak_kb / 1024))" -le "$limit_mb" ]
