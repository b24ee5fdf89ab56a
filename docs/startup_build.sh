#!/usr/bin/env bash
# The first run's kernel build, two processes (tactile_bt/sim/warmup.py) against one: the README's
# mission on an empty kernel cache, N times each (default 8), interleaved; prints each wall time
# and the medians. Run it on a quiet machine, from a checkout with the package installed.
set -euo pipefail
n=${1:-8}
cd "$(dirname "$0")/.."
now() { python3 -c 'import time; print(time.monotonic())'; }
log=$(mktemp)
for i in $(seq "$n"); do
  for mode in two one; do
    cache=$(mktemp -d); out=$(mktemp -d); start=$(now)
    if [ "$mode" = two ]; then
      NUMBA_CACHE_DIR=$cache python -m tactile_bt.cli run trees/cable_follow.yaml --scene sim/cable.yaml \
        --out "$out" > /dev/null 2>&1
    else  # the build as on one core: this process compiles every group itself
      NUMBA_CACHE_DIR=$cache python -c "import sys, tactile_bt.sim.warmup as w; w._cores = lambda: 1
from tactile_bt.cli import main
sys.exit(main(['run', 'trees/cable_follow.yaml', '--scene', 'sim/cable.yaml', '--out', '$out']))" > /dev/null 2>&1
    fi
    echo "$mode $(python3 -c "print(round($(now) - $start, 2))")" | tee -a "$log"
    rm -rf "$cache" "$out"
  done
done
python3 - "$log" <<'PY'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1]) if line.strip()]
medians = {m: statistics.median(float(t) for k, t in rows if k == m) for m in ("two", "one")}
print(f"median: two processes {medians['two']:.2f} s, one process {medians['one']:.2f} s "
      f"({1 - medians['two'] / medians['one']:.0%} saved)")
PY
rm -f "$log"
