"""Joint-limit reporting: runs of saturated cycles become report warnings that `tactile-bt run`
prints; an arm mission logs which joints sat on a limit; an unreachable start is one error line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tactile_bt.cli import main
from tactile_bt.mission.joints import SaturationRun, saturation_runs, saturation_warnings
from tactile_bt.mission.run import run_mission
from tactile_bt.robot.kinematics import Q_MAX, Q_MIN

DT = 0.004


def flags(n: int, joint: int, *spans) -> np.ndarray:
    sat = np.zeros((n, 7), dtype=bool)
    for first, last in spans:
        sat[first:last + 1, joint] = True
    return sat


def test_a_run_is_found_with_its_span_and_task_error():
    n = 1000
    t = np.arange(n) * DT
    sat = flags(n, 3, (100, 599))  # 2 s from 0.4 s
    residual = np.zeros((n, 6))
    residual[100:600, 0] = 0.01  # 10 mm/s of commanded translation not made
    residual[100:600, 5] = 0.1  # 0.1 rad/s of rotation not made
    q = np.zeros((n, 7))
    q[:, 3] = Q_MAX[3]
    runs = saturation_runs(t, sat, DT, residual=residual, joints=q, q_min=Q_MIN, q_max=Q_MAX)
    assert len(runs) == 1
    run = runs[0]
    assert run.joint == 4 and run.side == 1 and run.limit_rad == pytest.approx(Q_MAX[3])
    assert run.start_s == pytest.approx(0.4) and run.end_s == pytest.approx(2.4)
    assert run.duration_s == pytest.approx(2.0)
    assert run.error_m == pytest.approx(0.02) and run.error_rad == pytest.approx(0.2)
    assert run.message() == ("joint 4 at its upper limit (+120°) from 0.40 s to 2.40 s (2.00 s); "
                             "largest task-space error meanwhile 20.0 mm / 11.5°")


def test_the_task_error_is_the_largest_integrated_shortfall_not_its_end_value():
    n = 200
    t = np.arange(n) * DT
    residual = np.zeros((n, 6))
    residual[:100, 1] = 0.05  # 20 mm behind after 0.4 s ...
    residual[100:, 1] = -0.05  # ... and caught up again at the end
    runs = saturation_runs(t, flags(n, 6, (0, n - 1)), DT, residual=residual)
    assert runs[0].error_m == pytest.approx(0.02)
    assert math.isnan(runs[0].limit_rad) and runs[0].side == 0
    assert runs[0].message().startswith("joint 7 at its limit from 0.00 s to 0.80 s (0.80 s)")


def test_short_runs_are_ignored_and_short_gaps_bridged():
    n = 1000
    t = np.arange(n) * DT
    # joint 2: 0.08 s, ignored; joint 7: two 0.2 s runs 0.04 s apart (one run) and one 0.3 s apart
    sat = flags(n, 1, (10, 29)) | flags(n, 6, (100, 149), (160, 209), (285, 334))
    runs = saturation_runs(t, sat, DT)
    assert [(r.joint, round(r.start_s, 3), round(r.end_s, 3)) for r in runs] == [(7, 0.4, 0.84), (7, 1.14, 1.34)]
    assert math.isnan(runs[0].error_m) and "task-space" not in runs[0].message()
    assert saturation_runs(t, sat, DT, min_duration_s=0.05)[0].joint == 2
    assert len(saturation_runs(t, sat, DT, max_gap_s=0.0)) == 3
    assert saturation_runs(t, np.zeros((n, 7), bool), DT) == []


def test_many_runs_of_one_joint_are_summed_up():
    runs = [SaturationRun(4, 1.0 * k, 1.0 * k + 0.5) for k in range(8)]
    lines = saturation_warnings(runs, max_per_joint=5)
    assert len(lines) == 6 and lines[-1] == "joint 4 at its limit 3 more times (1.50 s in all)"


def test_bad_series_are_rejected():
    with pytest.raises(ValueError):
        saturation_runs(np.arange(5.0), np.zeros((4, 7), bool), DT)
    with pytest.raises(ValueError):
        saturation_runs(np.arange(5.0), np.zeros((5, 7), bool), 0.0)


# --------------------------------------------------------------------- missions
#: The shoulder just below and behind the pad, the elbow 5° from its stop: moving the pad down
#: at 50 mm/s (an approach over a table far below) folds the elbow onto its limit after 0.8 s.
FOLDED_SCENE = """name: folded
description: the elbow nearly folded; the pad far above the table
rate_hz: 250
duration_s: 1.2
seed: 0
mount:
  type: lwr4
  base: [-0.2, 0.0, -0.2735]
  position: [0.0, 0.0, 0.3]
  rpy_deg: [180, 0, 0]
objects:
  - type: table
    height: 0.0
    stiffness: 1.0e6
"""
DESCEND_TREE = """name: descend
description: move the pad down along its normal until it touches
root:
  approach: {speed_mps: 0.05, pressure_pa: 800, timeout_s: 10}
"""


@pytest.fixture
def folded(tmp_path):
    scene, tree = tmp_path / "folded.yaml", tmp_path / "descend.yaml"
    scene.write_text(FOLDED_SCENE)
    tree.write_text(DESCEND_TREE)
    return scene, tree


def test_a_mission_that_folds_the_elbow_onto_its_limit_warns(folded, tmp_path, capsys):
    scene, tree = folded
    out = tmp_path / "out"
    code = main(["run", str(tree), "--scene", str(scene), "--out", str(out)])
    assert code == 1  # the table is never reached: "no contact was made"
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if line.startswith("warning: joint")]
    assert len(warnings) == 1 and warnings[0].startswith("warning: joint 4 at its upper limit (+120°) from 0.")
    assert "to 1.20 s" in warnings[0] and "largest task-space error meanwhile" in warnings[0]
    report = json.loads((out / "report.json").read_text())
    assert report["warnings"] == [warnings[0][len("warning: "):]]
    log = np.load(out / "log.npz")
    assert log["joint_saturated"].shape == (300, 7) and log["rate_residual"].shape == (300, 6)
    sat = log["joint_saturated"]
    assert sat[:, 3].sum() > 25 and not sat[:, [0, 1, 2, 4, 5, 6]].any()
    # what the elbow could not do: the descent, 50 mm/s (minus what the others still made)
    assert 0.0 < np.linalg.norm(log["rate_residual"][-1, :3]) <= 0.05 + 1e-6


def test_a_mission_without_saturation_has_no_joint_warning(folded):
    scene, tree = folded
    result = run_mission(str(tree), str(scene), duration=0.4)
    assert result.summary.warnings == []
    assert result.log["joint_saturated"].shape == (100, 7) and not result.log["joint_saturated"].any()


def test_an_unreachable_start_is_one_error_line_naming_the_scene(folded, tmp_path, capsys):
    _, tree = folded
    scene = tmp_path / "far.yaml"
    scene.write_text(FOLDED_SCENE.replace("base: [-0.2, 0.0, -0.2735]", "base: [-0.1, 0.0, -0.1]"))
    out = tmp_path / "out"
    code = main(["run", str(tree), "--scene", str(scene), "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    line = lines[0]
    assert line.startswith(f"error: {scene}:") and "mount.base" in line
    assert "cannot reach the start pose" in line and "mount.position [0, 0, 0.3] m" in line
    assert "mount.rpy_deg [180, 0, 0]" in line and "move mount.base within reach of mount.position" in line
    assert not (out / "report.json").exists()


def test_the_arm_says_how_far_the_pad_can_turn_about_its_normal_before_joint_7_stops_it():
    from tactile_bt.control.spatial import body_to_spatial
    from tactile_bt.robot.mounts import MountSpec

    mount = MountSpec(type="lwr4", rpy_deg=(180.0, 0.0, 180.0)).build()  # the ready wrist, as the scan scenes
    joint, about_plus, about_minus = mount.turn_room()
    assert joint == 7
    assert about_plus + about_minus == pytest.approx(Q_MAX[6] - Q_MIN[6])  # joint 7's range, split
    # at the ready posture joint 7 is mid-range: the same room either way
    assert about_plus == pytest.approx(about_minus, abs=math.radians(1))
    for _ in range(250):  # 1 s turning the pad about its +z at 0.5 rad/s
        mount.move(body_to_spatial(mount.pose, np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.5])), DT)
    _, plus_after, minus_after = mount.turn_room()
    assert plus_after < about_plus - math.radians(10) and minus_after > about_minus + math.radians(10)
    assert MountSpec(type="cartesian").build().joint_state() is None  # a mount without joints says nothing
