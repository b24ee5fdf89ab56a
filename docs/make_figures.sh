#!/usr/bin/env bash
# Regenerates every figure and number quoted in README.md (after `pip install .`).
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out docs/figures
tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --out out/cable | tee out/cable.txt
tactile-bt view out/cable --png docs/figures/cable_render.png
cp out/cable/errors.png docs/figures/cable_errors.png
tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --orientation hough --out out/cable_hough | tee out/cable_hough.txt
tactile-bt accuracy --png docs/figures/orientation_accuracy.png | tee out/accuracy.txt
tactile-bt bench | tee out/bench.txt
tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --record out/cable.tbr --out out/cable_recorded > /dev/null
tactile-bt replay out/cable.tbr --tree trees/cable_follow.yaml | tee out/replay.txt
python -m tactile_bt.hardware.soak --seconds 10 --rate 1900 | tee out/soak.txt
