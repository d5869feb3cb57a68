#!/usr/bin/env bash
# Runs `steernav slam` on many sequences and prints frames lost and ATE (% of the path) for
# each, then a summary. A SLAM change is judged on this table, not on one clip: on short
# clips the outcome hangs on a few early decisions.
#
#   bash tools/slam-suite.sh [KITTI_CLIPS_DIR] [-- extra slam flags, e.g. --config F]
#
# Sequences:
# - generated: the room (30 Hz) for seeds 1 2 3 7 11, the drive (10 Hz) for seeds 1 2 3 7 11,
#   the drive at 5 Hz for seeds 7 and 3, and (with INDOOR=1, the default) the walk through
#   two furnished rooms (30 Hz, 640x480), the rover (15 Hz, 640x480) and the slider (1 m of
#   pure sideways travel, 30 Hz, 240x180 with barrel distortion) for seeds 1 2 3 7 11;
# - real, when KITTI_CLIPS_DIR is given (a folder of KITTI odometry clips): each clip as is,
#   from its 16th frame, at 5 Hz (even and odd frames), played backwards, and standing still
#   on its first frame for 1.5 s before it drives off.
# SUPERSAMPLE=N renders the generated sequences with N² rays a pixel (a sensor's pixel area;
# default 1, `slam-synth`'s default, one ray through each pixel's centre, whose aliased texture
# slides against the scene: docs/SLAM.md, "The generator aliased" and "The suite rendered
# with four rays a pixel").
# Generated and derived sequences are cached in $SUITE_DIR (default /tmp/steernav-suite).
# WHEELED=1 runs the vehicles (drive, rover, KITTI clips) with `--wheeled`, the wheeled motion
# model; the room and the walk, carried by hand, keep the constant-velocity model, which
# HANDHELD=1 runs with `--hand-held` (its larger linear acceleration).
# STEERNAV names the binary (default: target/release/steernav, built first), so that a saved
# build can be judged beside the tree's in one session.
# With BASELINE=1, a last column gives the ATE of the 40-line OpenCV visual odometry
# (tools/vo_baseline.py, in the peers' venv that tools/setup-peers.sh installs).
set -euo pipefail
cd "$(dirname "$0")/.."
clips=""
if [ $# -gt 0 ] && [ "$1" != "--" ]; then clips=$(realpath "$1"); shift; fi
[ "${1:-}" = "--" ] && shift
SUITE_DIR=${SUITE_DIR:-/tmp/steernav-suite}
supersample=${SUPERSAMPLE:-1}
mkdir -p "$SUITE_DIR"
if [ -n "${STEERNAV:-}" ]; then
  bin=$STEERNAV
else
  cargo build --release --quiet
  bin=./target/release/steernav
fi

synth() { # name motion seed fps
  local dir="$SUITE_DIR/$1"
  local cfg="$SUITE_DIR/$1.toml"
  printf '[synthetic]\nseed = %s\n' "$3" >"$cfg.new"
  [ -n "$4" ] && printf 'fps = %s\n' "$4" >>"$cfg.new"
  [ "$supersample" != 1 ] && printf 'supersample = %s\n' "$supersample" >>"$cfg.new"
  # A cached sequence is reused only when it was made with these settings.
  if [ -f "$dir/rgb.txt" ] && cmp -s "$cfg.new" "$cfg"; then rm "$cfg.new"; return 0; fi
  mv "$cfg.new" "$cfg"
  local frames=()
  [ "$2" = drive ] && [ -n "$4" ] && frames=(--frames 30)
  # Generated aside and moved into place: an interrupted run leaves no half sequence behind.
  rm -rf "$dir.part" "$dir"
  "$bin" slam-synth --out "$dir.part" --motion "$2" --config "$cfg" "${frames[@]}" >/dev/null
  mv "$dir.part" "$dir"
}

# A KITTI clip made of the frames of $src listed (0-based) on stdin, in that order.
derive() { # name src
  local dir="$SUITE_DIR/$1" src=$2
  if [ -f "$dir/poses.txt" ]; then cat >/dev/null; return 0; fi
  rm -rf "$dir" && mkdir -p "$dir/image_l"
  cp "$src/calib.txt" "$dir/"
  local frames=() i=0 f
  mapfile -t frames < <(find "$src/image_l" -maxdepth 1 -name '*.png' | sort)
  : >"$dir/poses.txt"
  while read -r f; do
    ln -s "${frames[$f]}" "$dir/image_l/$(printf '%06d' "$i").png"
    awk -v n="$((f + 1))" 'NR == n' "$src/poses.txt" >>"$dir/poses.txt"
    i=$((i + 1))
  done
}

vehicle=""
[ "${WHEELED:-0}" = 1 ] && vehicle="--wheeled"
carried=""
[ "${HANDHELD:-0}" = 1 ] && carried="--hand-held"
sequences=()
for seed in 1 2 3 7 11; do synth "room-$seed" room "$seed" "" && sequences+=("room-$seed|$carried"); done
for seed in 1 2 3 7 11; do synth "drive-$seed" drive "$seed" "" && sequences+=("drive-$seed|$vehicle"); done
for seed in 7 3; do synth "drive5hz-$seed" drive "$seed" 5 && sequences+=("drive5hz-$seed|$vehicle"); done
if [ "${INDOOR:-1}" = 1 ]; then
  for seed in 1 2 3 7 11; do synth "walk-$seed" walk "$seed" "" && sequences+=("walk-$seed|$carried"); done
  for seed in 1 2 3 7 11; do
    synth "rover-$seed" rover "$seed" "" && sequences+=("rover-$seed|$vehicle")
  done
  for seed in 1 2 3 7 11; do synth "slider-$seed" slider "$seed" "" && sequences+=("slider-$seed|"); done
fi
if [ -n "$clips" ]; then
  for src in "$clips"/*/; do
    src=${src%/}
    name=$(basename "$src")
    n=$(find "$src/image_l" -maxdepth 1 -name '*.png' | wc -l)
    seq 0 $((n - 1)) | derive "$name" "$src" && sequences+=("$name|--fps 10 $vehicle")
    seq 15 $((n - 1)) | derive "$name-from15" "$src" && sequences+=("$name-from15|--fps 10 $vehicle")
    seq 0 2 $((n - 1)) | derive "$name-5hz-even" "$src" && sequences+=("$name-5hz-even|--fps 5 $vehicle")
    seq 1 2 $((n - 1)) | derive "$name-5hz-odd" "$src" && sequences+=("$name-5hz-odd|--fps 5 $vehicle")
    seq $((n - 1)) -1 0 | derive "$name-reversed" "$src" && sequences+=("$name-reversed|--fps 10 $vehicle")
    { yes 0 | head -15; seq 0 $((n - 1)); } | derive "$name-stopped" "$src" &&
      sequences+=("$name-stopped|--fps 10 $vehicle")
  done
fi

baseline=${BASELINE:-0}
if [ "$baseline" = 1 ] && [ ! -x .venv-peers/bin/python ]; then bash tools/setup-peers.sh >/dev/null; fi
printf '%-22s %6s %8s %8s %7s' sequence lost frames ATE% drift
[ "$baseline" = 1 ] && printf ' %12s' "OpenCV-VO%"
printf '\n'
total_lost=0 over=0 worst=0 count=0 sum=0 drifting=0
for entry in "${sequences[@]}"; do
  name=${entry%%|*}
  read -r -a flags <<<"${entry#*|}"
  log="$SUITE_DIR/$name.log"
  if ! "$bin" slam "$SUITE_DIR/$name" --backend cpu --out "$SUITE_DIR/$name.out" \
    "${flags[@]}" "$@" >"$log" 2>&1; then
    printf '%-22s failed, see %s\n' "$name" "$log"
    over=$((over + 1))
    continue
  fi
  lost=$(sed -n 's/.*tracking lost on \([0-9]*\) frames.*/\1/p' "$log")
  frames=$(sed -n 's/.*: \([0-9]*\) frames (.*/\1/p' "$log" | head -1)
  ate=$(sed -n 's/.*RMSE (\([0-9.]*\)% of the.*/\1/p' "$log")
  drift=$(sed -n 's/.*scale drift \([0-9.]*\) (last.*/\1/p' "$log")
  printf '%-22s %6s %8s %8s %7s' "$name" "$lost" "$frames" "$ate" "${drift:--}"
  if [ "$baseline" = 1 ]; then
    # The baseline and slam-eval take the rate, not the motion model.
    for i in "${!flags[@]}"; do case ${flags[$i]} in --wheeled | --hand-held) unset 'flags[i]' ;; esac; done
    truth=$(find "$SUITE_DIR/$name" -maxdepth 1 \( -name poses.txt -o -name groundtruth.txt \) | head -1)
    vo="$SUITE_DIR/$name.vo.txt"
    if .venv-peers/bin/python tools/vo_baseline.py "$SUITE_DIR/$name" "${flags[@]}" --out "$vo" \
      >/dev/null 2>&1; then
      printf ' %12s' "$("$bin" slam-eval "$vo" "$truth" "${flags[@]}" --json |
        sed -n 's/.*"ate_rmse": *\([0-9.e+-]*\).*"path_length": *\([0-9.e+-]*\).*/\1 \2/p' |
        awk '{ printf "%.2f", 100 * $1 / $2 }')"
    else
      printf ' %12s' failed
    fi
  fi
  printf '\n'
  total_lost=$((total_lost + lost))
  count=$((count + 1))
  if awk -v a="$ate" 'BEGIN { exit !(a > 2.0) }'; then over=$((over + 1)); fi
  if [ -n "$drift" ] && awk -v d="$drift" 'BEGIN { exit !(d > 1.1 || d < 1 / 1.1) }'; then
    drifting=$((drifting + 1))
  fi
  sum=$(awk -v a="$ate" -v s="$sum" 'BEGIN { print s + a }')
  worst=$(awk -v a="$ate" -v w="$worst" 'BEGIN { print (a > w ? a : w) }')
done
mean=$(awk -v s="$sum" -v n="$count" 'BEGIN { printf "%.2f", n ? s / n : 0 }')
printf 'summary: %d sequences, %d frames lost, %d above 2%% (or failed), mean ATE %s%%, worst %s%%, %d with scale drift beyond 10%%\n' \
  "$count" "$total_lost" "$over" "$mean" "$worst" "$drifting"
