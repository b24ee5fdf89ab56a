"""Run examples/slide_and_record.yaml on the simulated cable: the tree reads its target pressure
from the blackboard key /goal/pressure, which this script writes before the mission starts.

    python examples/slide_and_record.py [PRESSURE_PA]
"""

import sys
from pathlib import Path

import py_trees

from tactile_bt import load_tree, run_mission

ROOT = Path(__file__).resolve().parent.parent
pressure = float(sys.argv[1]) if len(sys.argv) > 1 else 1800.0

# Whoever sets the goal (a planner, a GUI, this script) writes the key; the tree's references
# ("@/goal/pressure", {blackboard: /goal/pressure}) read it each time their leaf starts.
goal = py_trees.blackboard.Client(name="goal")
goal.register_key(key="/goal/pressure", access=py_trees.common.Access.WRITE)
goal.set("/goal/pressure", pressure)

tree = load_tree(ROOT / "examples" / "slide_and_record.yaml")
print(py_trees.display.unicode_tree(tree.root))
result = run_mission(tree, scene=ROOT / "sim" / "cable.yaml", duration=15.0, seed=0)
report = result.report
print(f"status {report['status']} after {report['sim_time_s']:.1f} s of mission time")
print(f"pressure error {report['metrics']['pressure_pa']['steady_state_error']:+.0f} Pa around {pressure:.0f} Pa")
print(f"{len(result.contacts)} contact points recorded")
