"""The robot file of a live mission (``tactile-bt live --robot ROBOT.yaml``).

It describes the hardware set-up a live mission runs on: the arm's backend and its topics, the
sensor module and its calibration, the set-up a tree may know (the table's height) and the
supervisor's limits. Every key is checked on load; an unknown key, a wrong type or a value out of
range is an error naming the file, the line and the field::

    type: ros2                       # the arm's backend (ROS 2: MoveIt Servo or a twist controller)
    rate_hz: 250                     # the control rate the sensor's frames pace (Hz)
    ros2:
      twist_topic: /servo_node/delta_twist_cmds   # geometry_msgs/TwistStamped, base frame
      base_frame: base_link
      pose_topic: /tactile_bt/pad_pose            # geometry_msgs/PoseStamped of the pad ...
      flange_to_pad: {xyz_m: [0, 0, 0.045], rpy_deg: [0, 0, 0]}   # ... or of the flange, with this
      joint_state_topic: /joint_states            # optional
      joint_limits_rad: {lower: [...], upper: [...]}   # optional, in the joint state's order
      network: false                 # true: discover ROS 2 peers on the network
    sensor:
      module: tactile_module_16x16_v2   # the cell order (tactile-bt sensor --help lists modules)
      calibration: calibration.npz   # raw counts -> N per tactel; relative to this file
    setup:
      table_z_m: 0.0                 # the table's height in the base frame, for scan trees
    supervisor:                      # limits within the bounds of the scene's supervisor section
      sensor_silence_s: 0.02
      pose_stale_s: 0.02
      workspace_min_m: [-0.8, -0.8, -0.1]
      workspace_max_m: [0.8, 0.8, 1.2]

Layer: mission.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tactile_bt.control.spatial import make_pose
from tactile_bt.robot.ros2 import SERVO_TWIST_TOPIC, Ros2Settings
from tactile_bt.yamlutil import Located, load_located, plain

__all__ = ["RobotFile", "load_robot_file", "write_robot_file"]

_TOP = ("type", "rate_hz", "ros2", "sensor", "setup", "supervisor")
_ROS2 = ("twist_topic", "base_frame", "pose_topic", "flange_to_pad", "joint_state_topic", "joint_limits_rad",
         "node_name", "network")
_SENSOR = ("module", "calibration")
_SETUP = ("table_z_m",)
_SUPERVISOR = ("pressure_limit_pa", "force_limit_n", "grace_s", "clear_s", "retreat_speed_mps", "sensor_silence_s",
               "pose_stale_s", "workspace_min_m", "workspace_max_m")


@dataclass(frozen=True)
class RobotFile:
    """A checked robot file.

    Attributes
    ----------
    file : str
    type : str
        The backend: ``"ros2"``.
    rate_hz : float
        Control rate (Hz): the sensor streams at it, and the controller's period is ``1 / rate_hz``.
    ros2 : Ros2Settings
    module : str or None
        The sensor module (its cell order); None: as the driver decides (row-major).
    calibration : Path or None
        Calibration file of the sensor; None: the nominal characteristic.
    table_z_m : float
        The table's height in the base frame (m); NaN when the set-up has none.
    supervisor : dict
        Supervisor limits the file sets (field -> value), checked by the supervisor.
    """

    file: str
    type: str = "ros2"
    rate_hz: float = 250.0
    ros2: Ros2Settings = field(default_factory=Ros2Settings)
    module: str | None = None
    calibration: Path | None = None
    table_z_m: float = math.nan
    supervisor: dict = field(default_factory=dict)


def _section(loc: Located, name: str, keys: tuple[str, ...]) -> dict[str, Located]:
    if not isinstance(loc.value, dict):
        raise loc.error(f"{name}: expected a mapping of {', '.join(keys)}")
    for key in loc.value:
        if key not in keys:
            raise loc.keys[key].error(f"{name + '.' if name else ''}{key}: unknown key; valid: {', '.join(keys)}")
    return loc.value


def _number(loc: Located, name: str, positive: bool = False) -> float:
    v = loc.value
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
        raise loc.error(f"{name}: expected a {'positive' if positive else 'finite'} number, got {plain(v)!r}")
    return float(v)


def _text(loc: Located, name: str) -> str:
    if not isinstance(loc.value, str) or not loc.value.strip():
        raise loc.error(f"{name}: expected a non-empty string, got {plain(loc.value)!r}")
    return loc.value.strip()


def _numbers(loc: Located, name: str, length: int | None = None) -> tuple[float, ...]:
    if not isinstance(loc.value, list) or (length is not None and len(loc.value) != length):
        size = f"{length} " if length is not None else ""
        raise loc.error(f"{name}: expected a list of {size}numbers, got {plain(loc.value)!r}")
    return tuple(_number(v, f"{name}[{i}]") for i, v in enumerate(loc.value))


def _transform(loc: Located, name: str) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    body = _section(loc, name, ("xyz_m", "rpy_deg"))
    xyz = _numbers(body["xyz_m"], f"{name}.xyz_m", 3) if "xyz_m" in body else (0.0, 0.0, 0.0)
    rpy = _numbers(body["rpy_deg"], f"{name}.rpy_deg", 3) if "rpy_deg" in body else (0.0, 0.0, 0.0)
    return make_pose(Rotation.from_euler("xyz", rpy, degrees=True), xyz)


def _ros2(loc: Located) -> Ros2Settings:
    body = _section(loc, "ros2", _ROS2)
    kw: dict[str, Any] = {}
    for key in ("twist_topic", "base_frame", "pose_topic", "joint_state_topic", "node_name"):
        if key in body:
            kw[key] = _text(body[key], f"ros2.{key}")
    if "network" in body:
        if not isinstance(body["network"].value, bool):
            raise body["network"].error(f"ros2.network: expected true or false, got {plain(body['network'].value)!r}")
        kw["network"] = body["network"].value
    if "flange_to_pad" in body:
        kw["flange_to_pad"] = _transform(body["flange_to_pad"], "ros2.flange_to_pad")
    if "joint_limits_rad" in body:
        limits = _section(body["joint_limits_rad"], "ros2.joint_limits_rad", ("lower", "upper"))
        lower = _numbers(limits["lower"], "ros2.joint_limits_rad.lower") if "lower" in limits else ()
        upper = _numbers(limits["upper"], "ros2.joint_limits_rad.upper") if "upper" in limits else ()
        if len(lower) != len(upper) or any(lo >= hi for lo, hi in zip(lower, upper)):
            raise body["joint_limits_rad"].error("ros2.joint_limits_rad: lower and upper need the same length, "
                                                 "each lower below its upper")
        kw["joint_lower_rad"], kw["joint_upper_rad"] = lower, upper
    return Ros2Settings(**kw)


def load_robot_file(path: str | Path) -> RobotFile:
    """Read and check a robot file.

    Raises
    ------
    YamlError
        With file, line and column, for a syntax error, an unknown key or a bad value.
    """
    root = load_located(path)
    body = _section(root, "", _TOP)
    kw: dict[str, Any] = {"file": str(path)}
    if "type" in body:
        kind = _text(body["type"], "type")
        if kind != "ros2":
            raise body["type"].error(f"type: unknown robot type {kind!r}; valid: ros2")
        kw["type"] = kind
    if "rate_hz" in body:
        kw["rate_hz"] = _number(body["rate_hz"], "rate_hz", positive=True)
    kw["ros2"] = _ros2(body["ros2"]) if "ros2" in body else Ros2Settings()
    if "sensor" in body:
        sensor = _section(body["sensor"], "sensor", _SENSOR)
        if "module" in sensor:
            kw["module"] = _text(sensor["module"], "sensor.module")
        if "calibration" in sensor:
            file = Path(_text(sensor["calibration"], "sensor.calibration"))
            file = file if file.is_absolute() else Path(path).resolve().parent / file
            if not file.is_file():
                raise sensor["calibration"].error(f"sensor.calibration: file not found: {file}")
            kw["calibration"] = file
    if "setup" in body:
        setup = _section(body["setup"], "setup", _SETUP)
        if "table_z_m" in setup:
            kw["table_z_m"] = _number(setup["table_z_m"], "setup.table_z_m")
    if "supervisor" in body:
        sup = _section(body["supervisor"], "supervisor", _SUPERVISOR)
        kw["supervisor"] = {k: (_numbers(v, f"supervisor.{k}", 3) if k.startswith("workspace")
                                else _number(v, f"supervisor.{k}", positive=True)) for k, v in sup.items()}
    return RobotFile(**kw)


def write_robot_file(path: str | Path, *, rate_hz: float, pose_topic: str, twist_topic: str = SERVO_TWIST_TOPIC,
                     base_frame: str = "world", joint_state_topic: str | None = None,
                     joint_limits: tuple[list[float], list[float]] | None = None, module: str | None = None,
                     calibration: str | None = None, table_z_m: float | None = None, comment: str = "") -> Path:
    """Write a robot file that :func:`load_robot_file` reads (the twin writes the one that reaches it)."""
    lines = [f"# {line}" for line in comment.splitlines()] + [
        "type: ros2", f"rate_hz: {rate_hz:g}", "ros2:", f"  twist_topic: {twist_topic}", f"  base_frame: {base_frame}",
        f"  pose_topic: {pose_topic}"]
    if joint_state_topic:
        lines.append(f"  joint_state_topic: {joint_state_topic}")
    if joint_limits is not None:
        lower, upper = ([round(float(x), 6) for x in v] for v in joint_limits)
        lines.append(f"  joint_limits_rad: {{lower: {lower}, upper: {upper}}}")
    if module or calibration:
        lines.append("sensor:")
        if module:
            lines.append(f"  module: {module}")
        if calibration:
            lines.append(f"  calibration: {calibration}")
    if table_z_m is not None and math.isfinite(table_z_m):
        lines += ["setup:", f"  table_z_m: {table_z_m!r}"]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
