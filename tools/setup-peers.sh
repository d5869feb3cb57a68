#!/usr/bin/env bash
# Creates .venv-peers with a pinned OpenCV (contrib build, for StarDetector/CenSurE) so that
# `steernav eval` can run the classic detectors as peers. Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv-peers/bin/python ]; then
  python3 -m venv .venv-peers
fi
.venv-peers/bin/pip install --quiet --disable-pip-version-check \
  "opencv-contrib-python-headless==4.10.0.84" "numpy>=1.26,<2.3"
.venv-peers/bin/python tools/peers.py list
