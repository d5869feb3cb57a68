#!/usr/bin/env bash
# The detector's held figures in one line per setting, to judge a change on every input at
# once (issue 20): correct matches at 3 px and homography accuracy at 3 px on each Oxford
# sequence and over all four (1000 keypoints), and the rotation sweep's mean and minimum
# repeatability and recall (15–75° every 15°, ε = 2 px, 500 keypoints, the sample and img1 of
# each sequence; the keypoints whose regions lie inside both views), the inliers of `steernav
# match` on bark and graf img1 against img4 (its defaults: 1000 keypoints, guided), and the same
# homography figures over sequences generated from the five images (`steernav eval generate`:
# blur, JPEG, zoom; 25 pairs each). steernav
# only, CPU; about 45 s on two cores. The generated sequences are cached in $GENERATED (default
# /tmp/steernav-generated).
#
#   tools/detector-suite.sh [SETTINGS.toml] [detector flags...]
#
# OXFORD (default ../shared/data/oxford) holds bark/ graf/ leuven/ wall/; STEERNAV the binary
# (default target/release/steernav).
set -euo pipefail
cd "$(dirname "$0")/.."
steernav=${STEERNAV:-target/release/steernav}
oxford=${OXFORD:-../shared/data/oxford}
config=()
if [[ $# -gt 0 && $1 == *.toml ]]; then
  config=(--config "$1")
  shift
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
sequences=(bark graf leuven wall)
"$steernav" eval homography "${sequences[@]/#/$oxford/}" --detectors steernav --keypoints 1000 \
  --backend cpu --out "$out/h" "${config[@]}" "$@" >"$out/h.txt" 2>"$out/h.err" ||
  { cat "$out/h.err" >&2; exit 1; }
images=(assets/sample.png)
for s in "${sequences[@]}"; do images+=("$oxford/$s/img1.ppm"); done
"$steernav" eval rotation --images "${images[@]}" --angles 15:90:15 --detectors steernav \
  --backend cpu --out "$out/r" "${config[@]}" "$@" >"$out/r.txt" 2>"$out/r.err" ||
  { cat "$out/r.err" >&2; exit 1; }
# One steernav row per sequence, then the one over all sequences.
paste -d' ' <(printf '%s\n' "${sequences[@]}" all) \
  <(grep '^| steernav' "$out/h.txt" | awk -F'|' '{print "correct", $3, "H acc @3", $9}')
awk '/^steernav/ {print "rotation mean", $2, "min", $3, "recall", $5; exit}' "$out/r.txt"
for s in bark graf; do
  "$steernav" match "$oxford/$s/img1.ppm" "$oxford/$s/img4.ppm" --backend cpu "${config[@]}" "$@" \
    2>"$out/m.err" | awk -v s="$s" '{for (i = 1; i < NF; i++) if ($(i + 1) ~ /^inliers/) print "match", s, "img1-img4 inliers", $i}' ||
    { cat "$out/m.err" >&2; exit 1; }
done
# Blur, JPEG and zoom, generated from the same five images.
generated=${GENERATED:-/tmp/steernav-generated}
for change in blur jpeg zoom; do
  if [ ! -f "$generated/$change/done" ]; then
    rm -rf "$generated/$change"
    "$steernav" eval generate "${images[@]}" --change "$change" --out "$generated/$change" >/dev/null
    touch "$generated/$change/done"
  fi
  dirs=()
  for d in "$generated/$change"/*/; do dirs+=("${d%/}"); done
  "$steernav" eval homography "${dirs[@]}" --detectors steernav --keypoints 1000 --backend cpu \
    --out "$out/$change" "${config[@]}" "$@" >"$out/$change.txt" 2>"$out/$change.err" ||
    { cat "$out/$change.err" >&2; exit 1; }
  grep -A3 '^== all' "$out/$change.txt" | grep '^| steernav' |
    awk -F'|' -v c="$change" '{print c, "correct", $3, "H acc @1", $8, "@3", $9}'
done
