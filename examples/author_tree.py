"""Author the cable-following tree of ``trees/cable_follow.yaml`` in Python with the same
classes the YAML loader uses, run it on the simulated cable and print the report.

Node for node the same tree as the YAML file, including its levelling row (see the comment at
the top of ``trees/cable_follow.yaml``: without it the compliant arm's tilt stalls the pad).

    python examples/author_tree.py
"""

from pathlib import Path

import numpy as np
import py_trees

from tactile_bt import run_mission
from tactile_bt.tree.behaviours import (AdaptForceTarget, AlignEdge, Approach, Backtrack, CableEnd, Centre, ContactLost, ForceHold,
                                       GuidedSlide, MissionTimeout, RecordContacts, Retry, TactileServo)

ROOT = Path(__file__).resolve().parent.parent


def build_tree() -> py_trees.trees.BehaviourTree:
    """The cable-following tree, node for node as trees/cable_follow.yaml."""

    def level(name: str) -> TactileServo:  # P row wx <- dy: level the pad along the cable
        return TactileServo(name=name, P=(0, 0, 0, 1, 0, 0), kp=(0.0, 1.0, 0.0, 0.0), ki=(0.0, 0.2, 0.0, 0.0),
                            kd=(0.0, 0.0, 0.0, 0.0))

    approach = Approach(speed_mps=0.01, pressure_pa=800.0, timeout_s=5.0)
    # Settle on the cable (centred and aligned) before recording anything, at most 3 s.
    centred_and_aligned = py_trees.composites.Parallel(
        "centred_and_aligned",
        policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=True),
        children=[
            Centre(target_m=(0.0, 0.0), ki=0.0, converge=True, band=0.2 * 0.005, dwell_s=0.2),
            AlignEdge(target_rad=np.pi / 2, converge=True, band=np.deg2rad(2.0), dwell_s=0.2),
        ],
    )
    settle = py_trees.composites.Parallel(
        "settle",
        policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[ForceHold(target_pa=2000.0, target_key="/force/target_pa"), level("level_while_settling"),
                  centred_and_aligned,
                  ContactLost(grace_s=0.3)],
    )
    follow = py_trees.composites.Parallel(
        "follow",
        policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[
            ForceHold(target_pa=2000.0, target_key="/force/target_pa"),  # P row vz, at what the cable carries
            Centre(target_m=(0.0, 0.0), ki=0.0),  # P rows vx, vy
            level("level_along_cable"),
            AlignEdge(target_rad=np.pi / 2),  # P row wz: the cable along the sensor y axis
            # V_ext along y, slower where the line turns in the pad or its COP leaves the centre
            GuidedSlide(twist=(0.0, 0.02, 0.0, 0.0, 0.0, 0.0), slow_turn_rad=np.deg2rad(5.0), slow_offset_m=0.002,
                        min_scale=0.2),
            CableEnd(),  # success at the end of the cable, failure when the line is lost
            RecordContacts(point="local", only_when="/cable/on_line"),
        ],
    )
    # After a loss, back along the pad's recorded path (at once the first time), settle, follow.
    back_up = py_trees.composites.Parallel("back_up", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                           children=[ForceHold(target_pa=2000.0, target_key="/force/target_pa"),
                                                     Backtrack(distance_m=0.03)])
    attempt = py_trees.composites.Sequence("attempt", memory=True, children=[
        back_up,
        MissionTimeout(settle, name="settle_on_cable", duration_s=3.0, succeed=True),
        follow,
    ])
    task = py_trees.composites.Sequence("follow_cable", memory=True, children=[
        approach,
        Retry(attempt, name="follow_or_recover", num_failures=3),
    ])
    # Beside the whole task: the contact's stiffness, and the pressure target the cable carries.
    root = py_trees.composites.Parallel("cable_follow", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                        children=[AdaptForceTarget(target_pa=2000.0), task])
    return py_trees.trees.BehaviourTree(root)

if __name__ == "__main__":
    tree = build_tree()
    print(py_trees.display.unicode_tree(tree.root))
    result = run_mission(tree, ROOT / "sim" / "cable.yaml", duration=40.0, seed=0)  # ends by touch
    report = result.report
    print(f"status {report['status']} {report['reason']}, {report['real_time_factor']:.1f}x real time")
    for name, m in report["metrics"].items():
        print(f"{name:16s} steady-state {m['steady_state_error']:+.4g}  std {m['std']:.4g}  response {m['response_time_s']:.2f} s")
    p = report["path_error_m"]
    print(f"path error mean {p['mean'] * 1e3:.2f} mm, max {p['max'] * 1e3:.2f} mm, "
          f"followed {p['followed_m'] * 1e3:.0f} of {p['cable_length_m'] * 1e3:.0f} mm")
