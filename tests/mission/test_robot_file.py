"""The robot file of live missions, the twist's form on the wire, and ROS 2 staying out of the way."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt.control.spatial import point_to_spatial, spatial_to_point
from tactile_bt.errors import YamlError
from tactile_bt.mission.robot_file import load_robot_file, write_robot_file


def test_a_robot_file_reads_with_its_defaults(tmp_path):
    (tmp_path / "cal.npz").write_bytes(b"")
    f = tmp_path / "robot.yaml"
    f.write_text("type: ros2\nrate_hz: 500\nros2:\n  pose_topic: /arm/tool_pose\n"
                 "  flange_to_pad: {xyz_m: [0, 0, 0.05], rpy_deg: [0, 0, 90]}\n"
                 "sensor: {module: tactile_module_16x16_v2, calibration: cal.npz}\n"
                 "setup: {table_z_m: 0.01}\nsupervisor: {force_limit_n: 12, workspace_min_m: [0, 0, 0],"
                 " workspace_max_m: [1, 1, 1]}\n")
    r = load_robot_file(f)
    assert r.rate_hz == 500 and r.ros2.pose_topic == "/arm/tool_pose"
    assert r.ros2.twist_topic == "/servo_node/delta_twist_cmds" and r.ros2.network is False
    assert_allclose(r.ros2.flange_to_pad[:3, 3], [0, 0, 0.05])
    assert_allclose(r.ros2.flange_to_pad[:3, 0], [0, 1, 0], atol=1e-12)
    assert r.module == "tactile_module_16x16_v2" and r.calibration == tmp_path / "cal.npz"
    assert r.table_z_m == 0.01 and r.supervisor["force_limit_n"] == 12


@pytest.mark.parametrize("text, where, message", [
    ("type: ur5\n", "1:7", "unknown robot type 'ur5'; valid: ros2"),
    ("rate_hz: -5\n", "1:10", "rate_hz: expected a positive number"),
    ("ros2:\n  twist_topc: /x\n", "2:3", "unknown field 'ros2.twist_topc' (did you mean 'twist_topic'?)"),
    ("ros2:\n  network: yes please\n", "2:12", "ros2.network: expected true or false"),
    ("sensor:\n  calibration: missing.npz\n", "2:16", "sensor.calibration: file not found"),
    ("supervisor:\n  workspace_min_m: [0, 0]\n", "2:20", "supervisor.workspace_min_m: expected a list of 3 numbers"),
])
def test_a_bad_robot_file_names_its_line_and_field(tmp_path, text, where, message):
    f = tmp_path / "robot.yaml"
    f.write_text(text)
    with pytest.raises(YamlError) as err:
        load_robot_file(f)
    assert f"robot.yaml:{where}" in str(err.value) and message in str(err.value)


def test_the_twin_writes_a_robot_file_that_reads_back(tmp_path):
    path = write_robot_file(tmp_path / "robot.yaml", rate_hz=250, pose_topic="/p", joint_state_topic="/j",
                            joint_limits=([-1.0, -2.0], [1.0, 2.0]), module="row_major", table_z_m=math.nan)
    r = load_robot_file(path)
    assert r.ros2.joint_lower_rad == (-1.0, -2.0) and math.isnan(r.table_z_m) and r.module == "row_major"


def test_the_twist_on_the_wire_is_the_velocity_of_the_commanded_frames_origin():
    rng = np.random.default_rng(0)
    for _ in range(20):
        twist_g, point = rng.normal(size=6), rng.normal(size=3)
        wire = spatial_to_point(twist_g, point)
        # a point moving with the body: v(point) = v_g + w x point
        assert_allclose(wire[:3], twist_g[:3] + np.cross(twist_g[3:], point))
        assert_allclose(point_to_spatial(wire, point), twist_g)


def test_run_and_view_never_import_rclpy(tmp_path):
    code = ("import sys\nfrom tactile_bt import run_mission\n"
            f"run_mission('trees/force_hold.yaml', 'sim/pen.yaml', duration=0.2, out={str(tmp_path / 'o')!r})\n"
            "from tactile_bt.mission.view import render_mission\n"
            "assert 'rclpy' not in sys.modules, 'rclpy was imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
