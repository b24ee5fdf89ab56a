"""A real-time digital twin: a scene's simulator served as the hardware would appear.

``tactile-bt twin SCENE --out DIR`` steps the scene's world in wall-clock time and shows it as a
live mission sees a real set-up:

- **the arm** is a ROS 2 node: it takes ``geometry_msgs/TwistStamped`` (base frame, the velocity
  of the pad's origin and the angular velocity, as MoveIt Servo takes it) on
  ``/servo_node/delta_twist_cmds``, publishes the pad's ``geometry_msgs/PoseStamped`` on
  ``/tactile_bt/pad_pose`` and, for an arm, ``sensor_msgs/JointState`` on ``/joint_states``, at
  the control rate; it holds still when no twist came for ``hold_s`` (100 ms);
- **the pad** streams its raw frames through the device emulator on a pseudo-terminal, at the
  scene's rate, in the cell order of the module it emulates.

Before it prints the port on the first line of its standard output, the twin writes
``DIR/robot.yaml`` (the robot file ``tactile-bt live`` needs to reach it) and
``DIR/calibration.npz`` (the simulated pad's calibration). When it ends (SIGINT, SIGTERM, or its
duration), it writes ``DIR/twin.npz``: every twist it received (``command_time_s`` (N,),
``command_twist`` (N, 6), as the messages carried them) and the pad's true pose over time
(``pose_time_s`` (M,), ``pose`` (M, 4, 4)), on the twin's clock (s from its start).

Layer: mission.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from tactile_bt.control.spatial import point_to_spatial
from tactile_bt.mission.robot_file import write_robot_file
from tactile_bt.robot.ros2 import SERVO_TWIST_TOPIC, RosNode, fill_pose_message, twist_from_message

__all__ = ["TWIN_POSE_TOPIC", "TWIN_JOINT_TOPIC", "TwinResult", "serve_twin"]

TWIN_POSE_TOPIC = "/tactile_bt/pad_pose"
TWIN_JOINT_TOPIC = "/joint_states"
BASE_FRAME = "world"
#: No twist for this long (s): the twin's arm holds still.
HOLD_AFTER_S = 0.1


@dataclass
class TwinResult:
    """What a twin run did: its outputs and counts."""

    out: Path
    cycles: int
    commands: int
    late_cycles: int
    wall_time_s: float


class _Commands:
    """The twists received, as the messages carried them, with their arrival time (s)."""

    def __init__(self, t0: float) -> None:
        self._lock = threading.Lock()
        self._t0 = t0
        self.times: list[float] = []
        self.twists: list[np.ndarray] = []

    def receive(self, msg) -> None:
        twist = twist_from_message(msg.twist)
        with self._lock:
            self.times.append(time.monotonic() - self._t0)
            self.twists.append(twist)

    def latest(self) -> tuple[float, np.ndarray] | None:
        with self._lock:
            return (self.times[-1], self.twists[-1]) if self.times else None


class _Frames:
    """The emulator's frame source: the newest simulated frame; ``stall()`` stops the stream (a
    sensor that falls silent), without closing its port."""

    def __init__(self, first: np.ndarray) -> None:
        self._raw = first
        self._stalled = threading.Event()
        self._closing = threading.Event()

    def update(self, raw: np.ndarray) -> None:
        self._raw = raw

    def stall(self) -> None:
        self._stalled.set()

    def close(self) -> None:
        self._closing.set()

    def __call__(self) -> np.ndarray:
        while self._stalled.is_set() and not self._closing.is_set():
            time.sleep(0.01)
        return self._raw


def serve_twin(scene, out: str | Path, *, seed: int | None = None, duration: float | None = None,
               module: str | None = None, stall_after_s: float | None = None,
               stop: threading.Event | None = None, announce: Callable[[str], None] = print,
               network: bool = False) -> TwinResult:
    """Serve ``scene`` as hardware until ``stop`` is set (or for ``duration`` s of wall-clock time).

    Parameters
    ----------
    scene : Scene or path to a YAML scene
    out : path
        Where ``robot.yaml``, ``calibration.npz`` and ``twin.npz`` go.
    seed : int, optional
        Seed of the simulated sensor (default: the scene's).
    duration : float, optional
        Run this long (s); default: until ``stop`` is set.
    module : str, optional
        The tactile module the emulator sends as (its cell order); default row-major.
    stall_after_s : float, optional
        Fault injection: the sensor stops streaming after this long (s), the arm goes on.
    stop : threading.Event, optional
        Set it to end the twin (SIGINT and SIGTERM do, from the command line).
    announce : callable(str)
        Told the port once the outputs that reach the twin are written.
    network : bool
        Discover ROS 2 peers on the network; default: this host only.
    """
    from geometry_msgs.msg import PoseStamped, TwistStamped

    from tactile_bt.mission.run import scene_table_height
    from tactile_bt.sense.hardware.emulator import DeviceEmulator
    from tactile_bt.sim.scene import Scene, load_scene

    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(scene.seed if seed is None else seed)
    world = scene.build_world(rng)
    dt = 1.0 / scene.rate_hz
    pad = scene.sensor.geometry
    stop = stop or threading.Event()
    world.calibration.save(out / "calibration.npz")

    ros = RosNode("tactile_bt_twin", network)
    frames = _Frames(world.sense())
    emulator = None
    try:
        t0 = time.monotonic()
        commands = _Commands(t0)
        node = ros.node
        node.create_subscription(TwistStamped, SERVO_TWIST_TOPIC, commands.receive, 10)
        pose_pub = node.create_publisher(PoseStamped, TWIN_POSE_TOPIC, 10)
        joint_state = getattr(world.mount, "joint_state", lambda: None)()
        joint_pub = None
        if joint_state is not None:
            from sensor_msgs.msg import JointState as JointStateMessage

            joint_pub = node.create_publisher(JointStateMessage, TWIN_JOINT_TOPIC, 10)
        emulator = DeviceEmulator(frames, rate_hz=scene.rate_hz, rows=pad.rows, cols=pad.cols, module=module,
                                  keep_log=False)
        write_robot_file(
            out / "robot.yaml", rate_hz=scene.rate_hz, pose_topic=TWIN_POSE_TOPIC, base_frame=BASE_FRAME,
            joint_state_topic=TWIN_JOINT_TOPIC if joint_pub is not None else None,
            joint_limits=None if joint_state is None else (joint_state.lower_rad, joint_state.upper_rad),
            module=module, calibration="calibration.npz", table_z_m=scene_table_height(scene),
            comment=f"The digital twin of {scene.file}: tactile-bt live TREE --sensor {emulator.port} "
                    f"--robot {out / 'robot.yaml'} --out DIR")
        announce(emulator.port)

        pose_times, poses = [], []
        late = k = 0
        pose_msg, joint_msg = PoseStamped(), None
        pose_msg.header.frame_id = BASE_FRAME
        while not stop.is_set():
            due = t0 + k * dt
            wait = due - time.monotonic()
            if wait > 0:
                stop.wait(wait)
                if stop.is_set():
                    break
            elif wait < -dt:
                late += 1
            now = time.monotonic() - t0
            if duration is not None and now >= duration:
                break
            t = k * dt
            world.update(t)
            T = world.pose
            latest = commands.latest()
            if latest is None or now - latest[0] > HOLD_AFTER_S:
                twist_g = np.zeros(6)
            else:
                twist_g = point_to_spatial(latest[1], T[:3, 3])  # the pad origin's velocity -> spatial twist
            pose_times.append(now)
            poses.append(T.copy())
            pose_msg.header.stamp = node.get_clock().now().to_msg()
            fill_pose_message(pose_msg.pose, T)
            pose_pub.publish(pose_msg)
            if joint_pub is not None:
                joint_msg = _joint_message(world.mount.joint_state(), pose_msg.header.stamp, joint_msg)
                joint_pub.publish(joint_msg)
            if stall_after_s is not None and now >= stall_after_s:
                frames.stall()
            frames.update(world.sense())
            world.move(twist_g, dt)
            k += 1
        wall = time.monotonic() - t0
    finally:
        frames.close()
        if emulator is not None:
            emulator.close()
        ros.close()
    times, twists = commands.times, commands.twists
    np.savez(out / "twin.npz", command_time_s=np.asarray(times, dtype=float),
             command_twist=np.asarray(twists, dtype=float).reshape(-1, 6),
             pose_time_s=np.asarray(pose_times, dtype=float), pose=np.asarray(poses, dtype=float).reshape(-1, 4, 4),
             rate_hz=scene.rate_hz, hold_after_s=HOLD_AFTER_S)
    return TwinResult(out, k, len(times), late, wall)


def _joint_message(state, stamp, msg=None):
    from sensor_msgs.msg import JointState as JointStateMessage

    if msg is None:
        msg = JointStateMessage()
        msg.name = [f"joint_{i + 1}" for i in range(len(state.positions_rad))]
    msg.header.stamp = stamp
    msg.position = [float(q) for q in state.positions_rad]
    return msg


def twin_summary(result: TwinResult) -> str:
    """One line on what the twin did."""
    rate = result.cycles / result.wall_time_s if result.wall_time_s > 0 else math.nan
    return (f"twin ended after {result.wall_time_s:.1f} s: {result.cycles} cycles ({rate:.0f} Hz), "
            f"{result.commands} twists received, {result.late_cycles} cycles late; {result.out / 'twin.npz'}")
