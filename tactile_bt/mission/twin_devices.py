"""The twin's devices: its arm's ROS 2 driver and its pad's serial stream, in a process of their own.

A real sensor streams and a real arm's driver publishes whatever the arm's physics does. So does
the twin: the simulator steps in the twin's main process, and this process serves what it shows
through a block of shared memory (:class:`SharedTwinState`): the pad's newest raw frame streams
through the device emulator on a pseudo-terminal, the pad's pose and the joints go out as ROS 2
messages at the control rate, and every twist that comes in is written back with the time it
came. A hard contact step of the simulator (tens of ms, now and then) then delays neither a frame
nor a pose, as it would not on hardware.

Layer: mission.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from multiprocessing import shared_memory

import numpy as np

__all__ = ["SharedTwinState", "serve_devices", "raise_priority"]

#: Niceness a live loop and the twin's devices ask for: ahead of batch work on the same machine.
PRIORITY_NICE = -10


def raise_priority() -> bool:
    """Run this process ahead of batch work (``nice`` :data:`PRIORITY_NICE`), as a control loop
    should; False where the system does not allow it (not root, no CAP_SYS_NICE): then it runs at
    the usual priority."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, min(os.getpriority(os.PRIO_PROCESS, 0), PRIORITY_NICE))
    except (OSError, AttributeError):
        return False
    return True


class SharedTwinState:
    """The twin's state in shared memory, each part behind a sequence counter (odd while written).

    Parts: ``pose`` (4x4, m), ``joints`` (n, rad), ``frame`` (rows x cols raw counts), ``twist``
    (the newest twist received, 6 floats, and when: ``twist_time``, monotonic s, and ``twists``,
    how many), ``flags`` (``stall``: the sensor falls silent; ``stop``).
    """

    def __init__(self, rows: int, cols: int, n_joints: int, name: str | None = None) -> None:
        self.rows, self.cols, self.n_joints = rows, cols, n_joints
        n_float = 16 + n_joints + 8
        size = 32 + 8 * n_float + 32 + 2 * rows * cols  # seq, floats, flags, frame
        self._shm = shared_memory.SharedMemory(name=name, create=name is None, size=size)
        self.name = self._shm.name
        buf = self._shm.buf
        self.seq = np.ndarray((4,), dtype=np.int64, buffer=buf)  # pose+joints, frame, twist, flags
        floats = np.ndarray((n_float,), dtype=np.float64, buffer=buf, offset=32)
        self.pose = floats[:16].reshape(4, 4)
        self.joints = floats[16:16 + n_joints]
        self.twist = floats[16 + n_joints:22 + n_joints]
        self.twist_time = floats[22 + n_joints:23 + n_joints]
        self.twists = floats[23 + n_joints:24 + n_joints]
        self.flags = np.ndarray((4,), dtype=np.int64, buffer=buf, offset=32 + 8 * n_float)
        self.frame = np.ndarray((rows, cols), dtype=np.uint16, buffer=buf, offset=32 + 8 * n_float + 32)
        if name is None:
            self.seq[:] = 0
            self.flags[:] = 0
            self.twists[0] = 0.0

    # -- writers (one each) --------------------------------------------------------------------
    def _write(self, index: int, write) -> None:
        self.seq[index] += 1
        write()
        self.seq[index] += 1

    def _read(self, index: int, read):
        while True:
            before = int(self.seq[index])
            value = read()
            if before % 2 == 0 and int(self.seq[index]) == before:
                return value
            time.sleep(0)

    def put_pose(self, T: np.ndarray, joints: np.ndarray | None) -> None:
        def write():
            self.pose[:] = T
            if joints is not None:
                self.joints[:] = joints
        self._write(0, write)

    def get_pose(self) -> tuple[np.ndarray, np.ndarray]:
        return self._read(0, lambda: (self.pose.copy(), self.joints.copy()))

    def put_frame(self, raw: np.ndarray) -> None:
        self._write(1, lambda: np.copyto(self.frame, raw, casting="unsafe"))

    def get_frame(self) -> np.ndarray:
        return self._read(1, self.frame.copy)

    def put_twist(self, twist: np.ndarray, when: float) -> None:
        def write():
            self.twist[:] = twist
            self.twist_time[0] = when
            self.twists[0] += 1
        self._write(2, write)

    def get_twist(self) -> tuple[np.ndarray, float, int]:
        return self._read(2, lambda: (self.twist.copy(), float(self.twist_time[0]), int(self.twists[0])))

    def close(self, unlink: bool = False) -> None:
        for name in ("seq", "pose", "joints", "twist", "twist_time", "twists", "flags", "frame"):
            setattr(self, name, None)
        self._shm.close()
        if unlink:
            self._shm.unlink()


def serve_devices(name: str, rows: int, cols: int, n_joints: int, rate_hz: float, module: str | None,
                  network: bool, pose_topic: str, joint_topic: str, twist_topic: str, base_frame: str, conn) -> None:
    """The devices process: serve the shared state until the main process says stop (or goes).

    Sends the emulator's port on ``conn`` once both devices are up, then, when told to stop,
    the twists it received: ``(times (N,), twists (N, 6))``.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the main process decides
    from geometry_msgs.msg import PoseStamped, TwistStamped

    from tactile_bt.robot.ros2 import RosNode, fill_pose_message, twist_from_message
    from tactile_bt.sense.hardware.emulator import DeviceEmulator

    sys.setswitchinterval(5e-4)
    raise_priority()  # a sensor streams and an arm's driver publishes whatever else the host does
    state = SharedTwinState(rows, cols, n_joints, name=name)
    times: list[float] = []
    twists: list[np.ndarray] = []

    def receive(msg) -> None:
        now = time.monotonic()
        twist = twist_from_message(msg.twist)
        times.append(now)
        twists.append(twist)
        state.put_twist(twist, now)

    def frames() -> np.ndarray:
        while state.flags[0] and not state.flags[1]:  # stalled: a sensor that fell silent
            time.sleep(0.005)
        return state.get_frame()

    ros = RosNode("tactile_bt_twin", network)
    emulator = None
    stop = threading.Event()
    try:
        node = ros.node
        node.create_subscription(TwistStamped, twist_topic, receive, 10)
        pose_pub = node.create_publisher(PoseStamped, pose_topic, 10)
        joint_pub = None
        if n_joints:
            from sensor_msgs.msg import JointState

            joint_pub = node.create_publisher(JointState, joint_topic, 10)
            joint_msg = JointState()
            joint_msg.name = [f"joint_{i + 1}" for i in range(n_joints)]
        emulator = DeviceEmulator(frames, rate_hz=rate_hz, rows=rows, cols=cols, module=module, keep_log=False)
        conn.send(emulator.port)
        watcher = threading.Thread(target=lambda: (conn.poll(None), stop.set()), daemon=True)
        watcher.start()
        msg = PoseStamped()
        msg.header.frame_id = base_frame
        period, next_due = 1.0 / rate_hz, time.monotonic()
        while not stop.is_set():  # the arm's driver: pose and joints at the control rate
            T, q = state.get_pose()
            stamp = node.get_clock().now().to_msg()
            msg.header.stamp = stamp
            fill_pose_message(msg.pose, T)
            pose_pub.publish(msg)
            if joint_pub is not None:
                joint_msg.header.stamp = stamp
                joint_msg.position = [float(x) for x in q]
                joint_pub.publish(joint_msg)
            next_due += period
            stop.wait(max(0.0, next_due - time.monotonic()))
    finally:
        state.flags[1] = 1
        if emulator is not None:
            emulator.close()
        ros.close()
        try:
            conn.send((np.asarray(times, dtype=float), np.asarray(twists, dtype=float).reshape(-1, 6)))
        except (BrokenPipeError, OSError):
            pass
        state.close()
