"""Run the YAML cable mission from Python, look at its time series and save the error plot.

    python examples/run_mission.py out/example
"""

import sys
from pathlib import Path

import numpy as np

from tactile_bt import load_tree, run_mission

ROOT = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/example")

tree = load_tree(ROOT / "trees" / "cable_follow.yaml")
result = run_mission(tree, scene=ROOT / "sim" / "cable.yaml", duration=20.0, seed=0,
                     overrides=["objects.1.radius=0.004"])  # a thicker cable
log = result.log
settled = log["t"] > 2.0
print(f"pressure after 2 s: {np.mean(log['pressure_pa'][settled]):.0f} ± {np.std(log['pressure_raw_pa'][settled]):.0f} Pa")
print(f"{len(result.contacts)} contact points, path error {result.report['path_error_m']['mean'] * 1e3:.2f} mm")
result.save(out)  # report.json, log.npz, errors.png, contacts.ply
print(f"written to {out}")
