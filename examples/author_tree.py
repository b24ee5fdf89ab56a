"""Author the cable-following tree in Python with the same classes the YAML loader uses, run it
on the simulated cable and print the report.

    python examples/author_tree.py
"""

from pathlib import Path

import numpy as np
import py_trees

from tactile_bt import run_mission
from tactile_bt.behaviours import AlignEdge, Approach, Centre, ContactLost, ForceHold, GuidedSlide, RecordContacts

ROOT = Path(__file__).resolve().parent.parent

follow = py_trees.composites.Parallel(
    "follow",
    policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
    children=[
        ForceHold(target_pa=2000.0),  # P row vz
        Centre(target_m=(0.0, 0.0)),  # P rows vx, vy
        AlignEdge(target_rad=np.pi / 2),  # P row wz: the cable along the sensor y axis
        GuidedSlide(twist=(0.0, 0.02, 0.0, 0.0, 0.0, 0.0)),  # V_ext along y
        RecordContacts(point="local"),
        ContactLost(grace_s=0.3),
    ],
)
root = py_trees.composites.Sequence("cable_follow", memory=True, children=[Approach(pressure_pa=800.0), follow])
tree = py_trees.trees.BehaviourTree(root)
print(py_trees.display.unicode_tree(root))

result = run_mission(tree, ROOT / "sim" / "cable.yaml", duration=10.0, seed=0)
report = result.report
print(f"status {report['status']}, {report['real_time_factor']:.1f}x real time")
for name, m in report["metrics"].items():
    print(f"{name:16s} steady-state {m['steady_state_error']:+.4g}  std {m['std']:.4g}  response {m['response_time_s']:.2f} s")
print(f"path error mean {report['path_error_m']['mean'] * 1e3:.2f} mm, max {report['path_error_m']['max'] * 1e3:.2f} mm")
