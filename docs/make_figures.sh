#!/usr/bin/env bash
# Regenerates every figure and number quoted in README.md (after `pip install .`).
# About 20 minutes on 2 cores, most of it the 100 runs of `tactile-bt paper` and the scans.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out docs/figures
tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --out out/cable | tee out/cable.txt
tactile-bt view out/cable --png docs/figures/cable_render.png
cp out/cable/errors.png docs/figures/cable_errors.png
cp out/cable/tree.png docs/figures/cable_tree.png
python docs/cable_scenes.py | tee out/cable_scenes.txt
python docs/cable_scenes.py --random 4 --seed 7 | tee out/cable_random.txt
tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --orientation hough --out out/cable_hough | tee out/cable_hough.txt
tactile-bt accuracy --png docs/figures/orientation_accuracy.png | tee out/accuracy.txt
tactile-bt stability --out out/stability | tee out/stability.txt
cp out/stability/error_vs_runtime.png docs/figures/error_vs_runtime.png
tactile-bt paper --out out/paper | tee out/paper.txt
for f in fig8_force fig9_position fig10_hybrid fig11_roll; do cp "out/paper/$f.png" "docs/figures/$f.png"; done
for sc in box cylinder ellipsoid; do
  tactile-bt run trees/surface_scan_stripes.yaml --scene "sim/scan_$sc.yaml" --out "out/scan_$sc" | tee "out/scan_$sc.txt"
  tactile-bt view "out/scan_$sc" --png "docs/figures/scan_$sc.png"
done
for sc in object scan_stone scan_box_turned scan_log scan_box scan_cylinder scan_ellipsoid; do
  tactile-bt run trees/scan_object.yaml --scene "sim/$sc.yaml" --out "out/scan_object/$sc" | tee "out/scan_object_$sc.txt"
done
for sc in object stone box_turned log; do
  d="out/scan_object/$sc"; [ -d "$d" ] || d="out/scan_object/scan_$sc"
  tactile-bt view "$d" --png "docs/figures/scan_object_$sc.png"
done
tactile-bt bench | tee out/bench.txt
bash docs/first_run.sh 4 | tee out/first_run.txt
tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --record out/cable.tbr --out out/cable_recorded > /dev/null
tactile-bt replay out/cable.tbr --tree trees/cable_follow.yaml | tee out/replay.txt
python -m tactile_bt.sense.hardware.soak --seconds 10 --rate 1900 | tee out/soak.txt
