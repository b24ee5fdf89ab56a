"""A live mission: the same tree, control loop and supervisor on a real sensor and a real arm.

```
sensor (serial) ─newest frame→ ControlLoop ─→ Supervisor ─→ Ad(T_gs) ─→ Robot.send_twist(V_g)
Robot.pad_pose() (T_gs, stamped) ──────────────↗
```

The loop is paced by the sensor's frames in wall-clock time: each cycle waits for the newest
frame, reads the pad's pose, runs one :class:`~tactile_bt.mission.loop.ControlLoop` cycle, lets
the :class:`~tactile_bt.mission.supervisor.Supervisor` check it (with the hardware's own faults: a
silent sensor, a stale pose, a pose outside the workspace) and sends the twist. On every way out
(the tree ends, a fault, an error, Ctrl-C, SIGTERM) the last command the robot gets is a zero
twist, and the outputs of every cycle so far are written, as ``run`` writes them, plus the
real-time figures under ``realtime`` in the report and ``realtime.png``.

Layer: mission.
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tactile_bt import defaults
from tactile_bt.contacts.cloud import ContactCloud
from tactile_bt.control.spatial import body_to_spatial
from tactile_bt.mission.robot_file import RobotFile, load_robot_file
from tactile_bt.mission.twin_devices import raise_priority

#: A joint this close to a position limit (rad) counts as held there, for the tree
#: (``/robot/joints_held``): the measured angle of a joint resting on its stop.
JOINT_HELD_MARGIN_RAD = math.radians(0.5)

__all__ = ["RealtimeLog", "run_live", "realtime_summary", "plot_realtime"]

#: How long to wait for the robot's first pose (s).
FIRST_POSE_TIMEOUT_S = 5.0
#: How long to wait for the sensor's first frame (s).
FIRST_FRAME_TIMEOUT_S = 5.0


@dataclass
class RealtimeLog:
    """Per cycle, on the host's monotonic clock (s): when the frame arrived, when the cycle had
    it, and when the twist was sent."""

    arrival: list = field(default_factory=list)
    start: list = field(default_factory=list)
    sent: list = field(default_factory=list)

    def add(self, arrival: float, start: float, sent: float) -> None:
        self.arrival.append(arrival)
        self.start.append(start)
        self.sent.append(sent)

    def arrays(self) -> dict[str, np.ndarray]:
        a, s, d = (np.asarray(x, dtype=float) for x in (self.arrival, self.start, self.sent))
        return {"latency_s": d - a, "period_s": np.diff(s), "compute_s": d - s, "t_s": s - s[0] if len(s) else s}


def _percentiles(x: np.ndarray, scale: float = 1e3) -> dict:
    if x.size == 0:
        return {"p50": math.nan, "p90": math.nan, "p99": math.nan, "max": math.nan}
    p50, p90, p99 = np.percentile(x, [50, 90, 99])
    return {"p50": float(p50 * scale), "p90": float(p90 * scale), "p99": float(p99 * scale),
            "max": float(x.max() * scale)}


def realtime_summary(log: RealtimeLog, dt: float) -> dict:
    """The report's ``realtime``: latency (frame arrival to twist sent), cycle period, its jitter
    (|period − dt|) and the cycles whose work took longer than the period, as percentiles in ms."""
    r = log.arrays()
    period = r["period_s"]
    return {
        "cycles": int(len(log.sent)),
        "rate_hz": 1.0 / dt,
        "latency_ms": _percentiles(r["latency_s"]),
        "period_ms": _percentiles(period),
        "jitter_ms": _percentiles(np.abs(period - dt)),
        "compute_ms": _percentiles(r["compute_s"]),
        "over_budget": int(np.count_nonzero(r["compute_s"] > dt)),
    }


def plot_realtime(log: RealtimeLog, dt: float, path: str | Path) -> Path:
    """``realtime.png``: latency and cycle period against mission time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = log.arrays()
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 4.5), sharex=True, constrained_layout=True)
    ax1.plot(r["t_s"], r["latency_s"] * 1e3, lw=0.7, color="C0")
    ax1.set_ylabel("latency (ms)")
    ax1.set_title("frame arrival to twist sent, and the cycle period", fontsize=10)
    ax2.plot(r["t_s"][1:], r["period_s"] * 1e3, lw=0.7, color="C1")
    ax2.axhline(dt * 1e3, color="k", lw=0.8, ls="--", label=f"{1 / dt:g} Hz")
    ax2.set_ylabel("period (ms)")
    ax2.set_xlabel("mission time (s)")
    ax2.legend(loc="upper right", fontsize=8)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)


def run_live(tree, sensor: str, robot: str | Path | RobotFile, *, duration: float | None = None,
             out: str | Path | None = None, truth=None, record: str | Path | None = None,
             module: str | None = None, orientation_method: str = "moments", robot_backend=None,
             progress=None, watchers=()):
    """Run ``tree`` on a real sensor and arm; returns a :class:`~tactile_bt.mission.result.MissionResult`.

    Parameters
    ----------
    tree : BehaviourTree or path to a YAML tree
    sensor : str
        The sensor's serial port (a device, a pty, a pyserial URL).
    robot : path or RobotFile
        The robot file (:mod:`tactile_bt.mission.robot_file`).
    duration : float, optional
        Mission time budget (s); default: until the tree ends (or Ctrl-C).
    out : path, optional
        Output directory (report.json, log.npz, errors.png, realtime.png, contacts.ply).
    truth : Scene or path, optional
        A scene whose ground truth scores the contacts (path error, reconstruction accuracy),
        for runs against the twin; it never reaches the tree.
    record : path, optional
        Record every frame and pose (chunked) for ``tactile-bt replay``.
    module : str, optional
        The sensor module (cell order), overriding the robot file's.
    robot_backend : Robot, optional
        A robot that satisfies :class:`~tactile_bt.robot.interface.Robot` to use instead of the
        one the robot file describes (tests, other backends).
    progress : callable(t, duration), optional
    watchers : sequence of MissionWatcher
        Shown every cycle (e.g. the ``--rerun`` recording, :mod:`tactile_bt.mission.watch`).
    """
    import contextlib

    from tactile_bt.mission.log import MissionLog
    from tactile_bt.mission.loop import ControlLoop, root_outcome
    from tactile_bt.mission.result import finish_mission
    from tactile_bt.mission.run import MAX_CYCLES, calibration_path
    from tactile_bt.mission.supervisor import Supervisor, SupervisorLimits
    from tactile_bt.mission.watch import finish_watchers, start_watchers
    from tactile_bt.sim import warmup
    from tactile_bt.sense.calibration import TactelCalibration
    from tactile_bt.sense.geometry import PadGeometry
    from tactile_bt.sense.hardware.driver import SerialTactileSensor
    from tactile_bt.sim.scene import Scene, load_scene
    from tactile_bt.tree.behaviours.table import write_table_height
    from tactile_bt.tree.blackboard import write_joints_held, write_turn_room
    from tactile_bt.tree.loader import load_tree

    warmup.start()  # on a cold kernel cache, compile now: never in the first cycles on the arm
    setup = robot if isinstance(robot, RobotFile) else load_robot_file(robot)
    dt = 1.0 / setup.rate_hz
    if out is not None:
        from tactile_bt.mission.outputs import prepare_output_dir

        prepare_output_dir(out)
    scene = None if truth is None else (truth if isinstance(truth, Scene) else load_scene(truth))
    pad = PadGeometry() if scene is None else scene.sensor.geometry
    if not hasattr(tree, "root"):
        tree = load_tree(tree, pad=pad)
    notes = []
    if setup.calibration is not None:
        calibration = TactelCalibration.load(setup.calibration)
    else:
        notes.append(f"{setup.file}: no sensor.calibration: using the nominal tactel characteristic")
        calibration = TactelCalibration.nominal(pad=pad)
    write_table_height(setup.table_z_m)
    write_joints_held(None)  # nothing held yet (nor left from an earlier mission in this process)
    write_turn_room(None)  # a robot file does not say which joint turns the pad about its normal
    limits = SupervisorLimits.for_tree(tree, {"sensor_silence_s": defaults.LIVE_SENSOR_SILENCE_PERIODS * dt,
                                              **setup.supervisor})
    n_cycles = MAX_CYCLES if duration is None else int(round(duration * setup.rate_hz))
    log = MissionLog(n_cycles)
    log.track_nodes(tree.root)
    realtime = RealtimeLog()
    warmup.finish()
    _warm_perception(calibration, pad, orientation_method)
    stack = contextlib.ExitStack()
    status, reason, t = "completed", "", 0.0
    supervisor = robot_obj = loop = None
    switch = sys.getswitchinterval()
    sys.setswitchinterval(5e-4)  # the sensor's reader and ROS get their turn within a frame
    prioritised = raise_priority()
    wall_start = time.perf_counter()
    try:
        link = stack.enter_context(SerialTactileSensor(sensor, rows=pad.rows, cols=pad.cols,
                                                       module=module or setup.module, timeout=FIRST_FRAME_TIMEOUT_S))
        if robot_backend is None:
            from tactile_bt.robot.ros2 import Ros2Robot

            robot_obj = Ros2Robot(setup.ros2)
            robot_obj.wait_for_pose(FIRST_POSE_TIMEOUT_S)
        else:
            robot_obj = robot_backend
        recorder = None
        if record is not None:
            from tactile_bt.sense.hardware.recording import Recorder

            calibration.save(calibration_path(record))
            recorder = stack.enter_context(Recorder(record, pad.rows, pad.cols, metadata={
                "robot": setup.file, "rate_hz": setup.rate_hz, "pitch_m": pad.pitch,
                "table_z_m": None if math.isnan(setup.table_z_m) else setup.table_z_m}))
        loop = ControlLoop(tree, calibration, dt, orientation_method, pad=pad)
        supervisor = Supervisor(limits)
        watchers = start_watchers(watchers, loop, log, scene)
        frame = link.read(FIRST_FRAME_TIMEOUT_S)
        t_start = frame.timestamp
        pose = robot_obj.pad_pose()
        joints = getattr(robot_obj, "joint_state", lambda: None)()
        if joints is not None:
            log.track_joints(len(joints.positions_rad), (joints.lower_rad, joints.upper_rad))
        progress_every = max(1, int(setup.rate_hz / 20))
        for k in range(n_cycles):
            if k:
                try:
                    frame = link.read(limits.sensor_silence_s)
                except TimeoutError:
                    silent = time.monotonic() - t_start
                    supervisor.check(loop.features, pose.T_gs, np.zeros(6), silent, frame_time=t, pose_time=None)
                    break
            started = time.monotonic()
            t = frame.timestamp - t_start
            pose = robot_obj.pad_pose()
            if recorder is not None:
                recorder.write(frame.values, pose.T_gs, timestamp=t)
            twist_s = loop.cycle(frame.values, pose.T_gs, t)
            # On the frame's clock: a frame that waited for a busy loop is late, not a silent sensor
            # (the read's timeout above tells silence); the pose's age is taken against the frame.
            twist_s = supervisor.check(loop.features, pose.T_gs, twist_s, t, frame_time=t,
                                       pose_time=pose.stamp_s - t_start)
            if supervisor.outcome is not None:
                break
            robot_obj.send_twist(body_to_spatial(pose.T_gs, twist_s))
            realtime.add(frame.timestamp, started, time.monotonic())
            log.write(k, t, loop, twist_s, pose.T_gs)
            for watcher in watchers:
                watcher.cycle(k, t, loop, log)
            if joints is not None:
                state = robot_obj.joint_state()
                if state is not None:
                    log.write_joints(k, state.positions_rad)
                    write_joints_held(state.near_limit(JOINT_HELD_MARGIN_RAD))  # seen by the next tick
            if progress is not None and k % progress_every == 0:
                progress(t, duration or 0.0)
            outcome = root_outcome(tree.root)
            if outcome is not None:
                status, reason = outcome
                break
        if supervisor.outcome is not None:
            status, reason = supervisor.outcome
    except KeyboardInterrupt:
        status, reason = "interrupted", f"interrupted at {t:.2f} s of mission time"
    except Exception as exc:
        status, reason = "error", f"{type(exc).__name__}: {exc}"
        raise
    finally:
        sys.setswitchinterval(switch)
        try:
            if robot_obj is not None:
                robot_obj.stop()  # the robot's last command: a zero twist, however the mission ends
        finally:
            tree.interrupt()
            stack.close()
            if robot_obj is not None and robot_backend is None:
                robot_obj.close()
            result = finish_mission(tree, log, loop.contacts if loop is not None else ContactCloud(),
                                    status, reason, wall_start, t, scene=scene,
                                    warnings=notes, supervision=None if supervisor is None else supervisor.summary())
            result.summary.realtime = realtime_summary(realtime, dt) if realtime.sent else None
            if result.summary.realtime is not None:
                result.summary.realtime["raised_priority"] = prioritised
            if realtime.sent:
                arrays = realtime.arrays()
                n = len(result.log["t"])
                result.log["latency_s"] = arrays["latency_s"][:n]
                result.log["compute_s"] = arrays["compute_s"][:n]
            if out is not None:
                result.save(out)
                if realtime.sent:
                    plot_realtime(realtime, dt, Path(out) / "realtime.png")
            finish_watchers(watchers if isinstance(watchers, tuple) else (), result)
    for note in notes:
        warnings.warn(note, stacklevel=2)
    return result


def _warm_perception(calibration, pad, orientation_method: str) -> None:
    """Run perception once on an empty and on a pressed frame, so that its kernels are loaded
    before the first cycle on the arm (a first call costs tens of ms)."""
    from tactile_bt.perception.features import extract

    for image in (np.zeros(pad.shape), np.pad(np.full((3, 8), 0.05), ((6, 7), (4, 4)))):
        for method in (None, orientation_method):
            extract(image, defaults.CONTACT_THRESHOLD_N, method, pad=pad)
    calibration.force_from_raw(np.zeros(pad.shape, dtype=np.uint16))
