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
from tactile_bt.sim.scene import SUPERVISOR
from tactile_bt.sim.schema import (ANGLE_DEG, BOOL, COORD, LIST, MAPPING, NUMBER, STR, ListOf, Range, check_fields,
                                   check_keys, check_value)
from tactile_bt.yamlutil import Located, load_located

__all__ = ["RobotFile", "load_robot_file", "write_robot_file"]

#: The robot file's sections and fields, checked by :func:`tactile_bt.sim.schema.check_fields`
#: like a scene (the ``supervisor`` section is the scene's, with the same bounds).
_TOP = {"type": STR, "rate_hz": Range(0.0, lo_open=True, unit="Hz"), "ros2": MAPPING, "sensor": MAPPING,
        "setup": MAPPING, "supervisor": MAPPING}
_ROS2 = {"twist_topic": STR, "base_frame": STR, "pose_topic": STR, "flange_to_pad": MAPPING,
         "joint_state_topic": STR, "joint_limits_rad": MAPPING, "node_name": STR, "network": BOOL}
_TRANSFORM = {"xyz_m": ListOf(3, COORD), "rpy_deg": ListOf(3, ANGLE_DEG)}
_LIMITS = {"lower": LIST, "upper": LIST}
_SENSOR = {"module": STR, "calibration": STR}
_SETUP = {"table_z_m": COORD}


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


def _section(loc: Located, schema: dict, where: str) -> dict[str, Located]:
    """The located fields of the section ``loc`` (``where``: its path with a dot), every key in
    ``schema``; their values are checked with :func:`_checked`."""
    check_value(loc, MAPPING, where.rstrip(".") or "the robot file")
    check_keys(loc, schema, where)
    return loc.value


def _checked(body: dict[str, Located], schema: dict, where: str) -> dict[str, Any]:
    """The checked values of the fields present in ``body``; a string must not be empty."""
    out = {}
    for key, loc in body.items():
        value = check_value(loc, schema[key], where + key)
        if schema[key] == STR and not value.strip():
            raise loc.error(f"{where}{key}: expected a non-empty string")
        out[key] = value.strip() if schema[key] == STR else value
    return out


def _transform(loc: Located, name: str) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    body = _checked(_section(loc, _TRANSFORM, name + "."), _TRANSFORM, name + ".")
    return make_pose(Rotation.from_euler("xyz", body.get("rpy_deg", (0.0, 0.0, 0.0)), degrees=True),
                     body.get("xyz_m", (0.0, 0.0, 0.0)))


def _ros2(loc: Located) -> Ros2Settings:
    body = _section(loc, _ROS2, "ros2.")
    kw: dict[str, Any] = _checked({k: v for k, v in body.items() if k not in ("flange_to_pad", "joint_limits_rad")},
                                  _ROS2, "ros2.")
    if "flange_to_pad" in body:
        kw["flange_to_pad"] = _transform(body["flange_to_pad"], "ros2.flange_to_pad")
    if "joint_limits_rad" in body:
        limits = _checked(_section(body["joint_limits_rad"], _LIMITS, "ros2.joint_limits_rad."), _LIMITS,
                          "ros2.joint_limits_rad.")
        lower, upper = ([check_value(v, NUMBER, f"ros2.joint_limits_rad.{side}[{i}]")
                         for i, v in enumerate(body["joint_limits_rad"].value[side].value)] if side in limits else []
                        for side in ("lower", "upper"))
        if len(lower) != len(upper) or any(lo >= hi for lo, hi in zip(lower, upper)):
            raise body["joint_limits_rad"].error("ros2.joint_limits_rad: lower and upper need the same length, "
                                                 "each lower below its upper")
        kw["joint_lower_rad"], kw["joint_upper_rad"] = tuple(lower), tuple(upper)
    return Ros2Settings(**kw)


def load_robot_file(path: str | Path) -> RobotFile:
    """Read and check a robot file.

    Raises
    ------
    YamlError
        With file, line and column, for a syntax error, an unknown key or a bad value.
    """
    root = load_located(path)
    body = _section(root, _TOP, "")
    top = _checked({k: v for k, v in body.items() if k in ("type", "rate_hz")}, _TOP, "")
    kw: dict[str, Any] = {"file": str(path), **top}
    if kw.get("type", "ros2") != "ros2":
        raise body["type"].error(f"type: unknown robot type {kw['type']!r}; valid: ros2")
    kw["ros2"] = _ros2(body["ros2"]) if "ros2" in body else Ros2Settings()
    if "sensor" in body:
        sensor = _checked(_section(body["sensor"], _SENSOR, "sensor."), _SENSOR, "sensor.")
        if "module" in sensor:
            kw["module"] = sensor["module"]
        if "calibration" in sensor:
            file = Path(sensor["calibration"])
            file = file if file.is_absolute() else Path(path).resolve().parent / file
            if not file.is_file():
                raise body["sensor"].value["calibration"].error(f"sensor.calibration: file not found: {file}")
            kw["calibration"] = file
    if "setup" in body:
        kw.update(_checked(_section(body["setup"], _SETUP, "setup."), _SETUP, "setup."))
    if "supervisor" in body:
        kw["supervisor"] = check_fields(body["supervisor"], SUPERVISOR, "supervisor.")
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
