#!/usr/bin/env bash
# steernav's ATE beside the 40-line OpenCV visual odometry (tools/vo_baseline.py) on one
# sequence, both after Sim(3) alignment against the sequence's ground truth:
#   bash tools/compare-vo.sh SEQUENCE [steernav slam flags, e.g. --calib F]
# Installs the peers' venv (tools/setup-peers.sh) and builds steernav on first use. Outputs go
# to $OUT (default vo-out/).
set -euo pipefail
cd "$(dirname "$0")/.."
seq=${1:?usage: compare-vo.sh SEQUENCE [slam flags]}
shift
OUT=${OUT:-vo-out}
mkdir -p "$OUT"
truth=""
for name in poses.txt groundtruth.txt groundtruth_tum.txt; do
  if [ -f "$seq/$name" ]; then truth="$seq/$name"; break; fi
done
[ -n "$truth" ] || { echo "$seq: no poses.txt / groundtruth.txt to compare against" >&2; exit 2; }
times=()
[ -f "$seq/times.txt" ] && times=(--times "$seq/times.txt")
calib=()
for ((i = 1; i <= $#; i++)); do
  if [ "${!i}" = "--calib" ]; then j=$((i + 1)); calib=(--calib "${!j}"); fi
done
[ -x .venv-peers/bin/python ] || bash tools/setup-peers.sh >/dev/null
cargo build --release --quiet
./target/release/steernav slam "$seq" --out "$OUT" "$@" >"$OUT/steernav.log" 2>&1 \
  || { cat "$OUT/steernav.log" >&2; exit 1; }
.venv-peers/bin/python tools/vo_baseline.py "$seq" --out "$OUT/vo.txt" "${calib[@]}" >/dev/null
printf '%-28s' "steernav slam:"
./target/release/steernav slam-eval "$OUT/trajectory.txt" "$truth" "${times[@]}"
printf '%-28s' "OpenCV VO (vo_baseline.py):"
./target/release/steernav slam-eval "$OUT/vo.txt" "$truth" "${times[@]}"
