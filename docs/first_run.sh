#!/usr/bin/env bash
# The README's main command on a fresh install: clone this repository, make a new virtual
# environment, `pip install .`, then run the mission and its render N times (default 3), each
# time on a new, empty kernel cache, and once more on the warm one. Prints wall seconds.
set -euo pipefail
n=${1:-3}
repo="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
git clone -q "$repo" "$work/clone"
cd "$work/clone"
python3 -m venv "$work/venv"
. "$work/venv/bin/activate"
pip install -q . > "$work/pip.log" 2>&1 || { cat "$work/pip.log"; exit 1; }
now() { python3 -c 'import time; print(time.monotonic())'; }
main_command() {
  tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --out out/cable > /dev/null
  local mid; mid=$(now)
  tactile-bt view out/cable --png out/cable/render.png > /dev/null
  echo "$mid"
}
for i in $(seq "$n"); do
  export NUMBA_CACHE_DIR="$work/cache$i"
  start=$(now); mid=$(main_command); end=$(now)
  wstart=$(now); main_command > /dev/null; wend=$(now)
  python3 -c "print(f'first run: {$end - $start:.2f} s (run {$mid - $start:.2f} s, view {$end - $mid:.2f} s); warm: {$wend - $wstart:.2f} s')"
done
