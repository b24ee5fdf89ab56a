"""How much the README's mission figures move with the last bit of floating point.

Two machines differ in the last bits of some results (another BLAS, another CPU's fused
multiply-add, another numba build); a closed loop can amplify that into another path. This
script stands in for another machine: it reruns each mission with the pad's start moved by a
few nanometres (``--set mount.position.0=x+k·1e-9``, far below anything physical), and prints,
per figure, the nominal value and the range over the runs (a Markdown table).

    python docs/last_bit.py                   # the cable mission and the object scan, 5 runs each
    python docs/last_bit.py --runs 8 --only object

A figure whose range is wide varies between machines by about that much; a status that changes
between runs is a fragile algorithm, not a machine's fault.
"""

from __future__ import annotations

import argparse
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: name -> (tree, scene, budget or None): the missions whose figures the README quotes first.
MISSIONS = {
    "cable": ("trees/cable_follow.yaml", "sim/cable.yaml", None),
    "cable_tight": ("trees/cable_follow.yaml", "sim/cable_tight.yaml", None),
    "object": ("trees/scan_object.yaml", "sim/object.yaml", 300.0),
    "scan_box_turned": ("trees/scan_object.yaml", "sim/scan_box_turned.yaml", 300.0),
}


def _figures(name: str, nudge_m: float) -> dict:
    from tactile_bt import run_mission
    from tactile_bt.sim.scene import load_scene

    tree, scene_file, budget = MISSIONS[name]
    start = float(load_scene(ROOT / scene_file).mount.position[0])
    result = run_mission(ROOT / tree, ROOT / scene_file, duration=budget,
                         overrides=[f"mount.position.0={start + nudge_m!r}"])
    r = result.summary
    out = {"status": r.status, "reason": r.reason, "mission time (s)": r.sim_time_s}
    if r.path_error_m:
        p = r.path_error_m
        out.update({"path error mean (mm)": p["mean"] * 1e3, "path error max (mm)": p["max"] * 1e3,
                    "followed (mm)": p["followed_m"] * 1e3})
    rec = r.reconstruction or {}
    if rec.get("coverage") is not None:
        out.update({"coverage": rec["coverage"], "chamfer (mm)": rec["chamfer_m"] * 1e3,
                    "Hausdorff (mm)": rec["hausdorff_m"] * 1e3, "contacts": float(rec["points"])})
    return out


def _job(args: tuple) -> tuple:
    name, k = args
    return name, k, _figures(name, k * 1e-9)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="runs per mission, the first unmoved (default: 5)")
    parser.add_argument("--only", nargs="+", choices=sorted(MISSIONS), default=None, help="only these missions")
    parser.add_argument("--workers", type=int, default=2, help="missions run at once (default: 2)")
    args = parser.parse_args(argv)
    names = args.only or list(MISSIONS)
    with ProcessPoolExecutor(max_workers=max(args.workers, 1)) as pool:
        results = list(pool.map(_job, [(n, k) for n in names for k in range(args.runs)]))
    print(f"| mission | figure | nominal | range over {args.runs} runs moved by 0–{args.runs - 1} nm | spread |")
    print("|---|---|---|---|---|")
    fragile = False
    for name in names:
        runs = [figures for n, _, figures in sorted(results, key=lambda r: r[1]) if n == name]
        for key in runs[0]:
            values = [run.get(key) for run in runs]
            if key == "reason":
                continue
            if key == "status":
                distinct = sorted(set(values))
                fragile |= len(distinct) > 1
                reasons = len({run["reason"] for run in runs})
                print(f"| {name} | status | {values[0]}: {runs[0]['reason']} | {', '.join(distinct)} "
                      f"({reasons} distinct reasons) | {'**changes**' if len(distinct) > 1 else 'same'} |")
                continue
            lo, hi, nominal = min(values), max(values), values[0]
            spread = (hi - lo) / abs(nominal) if nominal else math.nan
            print(f"| {name} | {key} | {nominal:.4g} | {lo:.4g} – {hi:.4g} | {spread:.1%} |")
    return 1 if fragile else 0


if __name__ == "__main__":
    sys.exit(main())
