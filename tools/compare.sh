#!/usr/bin/env bash
# The whole detector comparison from a fresh clone (paper Fig. 4a–b, eqs 11–12):
#   1. installs the peers' pinned OpenCV into .venv-peers (tools/setup-peers.sh),
#   2. rotation sweep 0..345° every 15° on the bundled sample and on img1 of every Oxford
#      sequence found in $OXFORD (default ../shared/data/oxford), ε = 1.5/2/3 px, 500 keypoints,
#   3. the Oxford homography sequences themselves.
# Outputs in $OUT (default eval-out/): rotation.csv, rotation.png, <sequence>.csv/.png; the
# summary tables go to stdout.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-eval-out}
OXFORD=${OXFORD:-../shared/data/oxford}
bash tools/setup-peers.sh
cargo build --release
images=(assets/sample.png)
sequences=()
if [ -d "$OXFORD" ]; then
  for dir in "$OXFORD"/*/; do
    for ext in ppm pgm png; do
      if [ -f "${dir}img1.$ext" ]; then images+=("${dir}img1.$ext"); sequences+=("$dir"); break; fi
    done
  done
fi
./target/release/steernav eval rotation --images "${images[@]}" --angles 0:360:15 --out "$OUT"
if [ ${#sequences[@]} -gt 0 ]; then
  ./target/release/steernav eval homography "${sequences[@]}" --out "$OUT"
fi
