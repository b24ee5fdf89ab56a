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
(``pose_time_s`` (M,), ``pose`` (M, 4, 4)), on the twin's clock (s from its start), and the time
each cycle's work took (``cycle_work_s`` (M,), s).

Layer: mission.
"""

from __future__ import annotations

import math
import multiprocessing
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from tactile_bt.control.spatial import point_to_spatial
from tactile_bt.mission.robot_file import write_robot_file
from tactile_bt.mission.twin_devices import SharedTwinState, serve_devices
from tactile_bt.robot.ros2 import SERVO_TWIST_TOPIC

__all__ = ["TWIN_POSE_TOPIC", "TWIN_JOINT_TOPIC", "TwinResult", "serve_twin"]

TWIN_POSE_TOPIC = "/tactile_bt/pad_pose"
TWIN_JOINT_TOPIC = "/joint_states"
BASE_FRAME = "world"
#: No twist for this long (s): the twin's arm holds still.
HOLD_AFTER_S = 0.1
#: How long the devices process may take to start or to stop (s).
STARTUP_TIMEOUT_S = 30.0


@dataclass
class TwinResult:
    """What a twin run did: its outputs and counts."""

    out: Path
    cycles: int
    commands: int
    late_cycles: int
    wall_time_s: float


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
    from tactile_bt.mission.run import scene_table_height
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

    joint_state = getattr(world.mount, "joint_state", lambda: None)()
    n_joints = 0 if joint_state is None else len(joint_state.positions_rad)
    state = SharedTwinState(pad.rows, pad.cols, n_joints)
    state.put_pose(world.pose, None if joint_state is None else joint_state.positions_rad)
    state.put_frame(world.sense())
    context = multiprocessing.get_context("spawn")
    conn, child_conn = context.Pipe()
    devices = context.Process(target=serve_devices, name="tactile-bt twin devices", daemon=True, args=(
        state.name, pad.rows, pad.cols, n_joints, scene.rate_hz, module, network, TWIN_POSE_TOPIC, TWIN_JOINT_TOPIC,
        SERVO_TWIST_TOPIC, BASE_FRAME, child_conn))
    times = np.zeros(0)
    twists = np.zeros((0, 6))
    pose_times, poses, work = [], [], []
    late = k = 0
    t0 = time.monotonic()
    try:
        devices.start()
        if not conn.poll(STARTUP_TIMEOUT_S):
            raise RuntimeError(f"the twin's devices did not start within {STARTUP_TIMEOUT_S:g} s")
        port = conn.recv()
        write_robot_file(
            out / "robot.yaml", rate_hz=scene.rate_hz, pose_topic=TWIN_POSE_TOPIC, base_frame=BASE_FRAME,
            joint_state_topic=TWIN_JOINT_TOPIC if n_joints else None,
            joint_limits=None if joint_state is None else (joint_state.lower_rad, joint_state.upper_rad),
            module=module, calibration="calibration.npz", table_z_m=scene_table_height(scene),
            comment=f"The digital twin of {scene.file}: tactile-bt live TREE --sensor {port} "
                    f"--robot {out / 'robot.yaml'} --out DIR")
        announce(port)
        t0 = time.monotonic()
        while not stop.is_set() and devices.is_alive():
            due = t0 + k * dt
            wait = due - time.monotonic()
            if wait > 0:
                stop.wait(wait)
                if stop.is_set():
                    break
            elif wait < -dt:
                late += 1
            now = time.monotonic()
            if duration is not None and now - t0 >= duration:
                break
            began = now
            world.update(k * dt)
            T = world.pose
            twist, received, count = state.get_twist()
            if count == 0 or now - received > HOLD_AFTER_S:  # no twist for 100 ms: hold still
                twist_g = np.zeros(6)
            else:
                twist_g = point_to_spatial(twist, T[:3, 3])  # the pad origin's velocity -> spatial twist
            pose_times.append(now - t0)
            poses.append(T.copy())
            state.put_pose(T, None if not n_joints else world.mount.joint_state().positions_rad)
            if stall_after_s is not None and now - t0 >= stall_after_s:
                state.flags[0] = 1
            state.put_frame(world.sense())
            world.move(twist_g, dt)
            work.append(time.monotonic() - began)
            k += 1
        wall = time.monotonic() - t0
    finally:
        try:
            conn.send("stop")
            if conn.poll(STARTUP_TIMEOUT_S):
                times, twists = conn.recv()
        except (BrokenPipeError, EOFError, OSError):
            pass
        devices.join(timeout=STARTUP_TIMEOUT_S)
        if devices.is_alive():
            devices.kill()
        state.close(unlink=True)
    np.savez(out / "twin.npz", command_time_s=times - t0, command_twist=twists,
             pose_time_s=np.asarray(pose_times, dtype=float), pose=np.asarray(poses, dtype=float).reshape(-1, 4, 4),
             cycle_work_s=np.asarray(work, dtype=float), rate_hz=scene.rate_hz, hold_after_s=HOLD_AFTER_S)
    return TwinResult(out, k, len(times), late, wall)


def twin_summary(result: TwinResult) -> str:
    """One line on what the twin did."""
    rate = result.cycles / result.wall_time_s if result.wall_time_s > 0 else math.nan
    return (f"twin ended after {result.wall_time_s:.1f} s: {result.cycles} cycles ({rate:.0f} Hz), "
            f"{result.commands} twists received, {result.late_cycles} cycles late; {result.out / 'twin.npz'}")
