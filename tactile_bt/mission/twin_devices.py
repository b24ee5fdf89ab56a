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


class _Slot:
    """One value in shared memory, double-buffered: the one writer fills the buffer readers are not
    told to read, then points them to it. A reader never waits for the writer (a writer that the
    system preempts halfway would stall it); it copies again only when two whole writes passed
    during its copy."""

    def __init__(self, header: np.ndarray, buffers: np.ndarray) -> None:
        self._header = header  # [index of the buffer to read, writes so far]
        self._buffers = buffers  # (2, *shape)

    def put(self, value) -> None:
        spare = 1 - int(self._header[0])
        self._buffers[spare] = value
        self._header[1] += 1
        self._header[0] = spare

    def get(self) -> np.ndarray:
        while True:
            writes, current = int(self._header[1]), int(self._header[0])
            value = self._buffers[current].copy()
            if int(self._header[1]) - writes < 2:  # the buffer it copied was not written meanwhile
                return value
            time.sleep(0)


class SharedTwinState:
    """The twin's state in shared memory, each part a double-buffered :class:`_Slot`.

    Parts: the pose (4x4, m) and the joints (n, rad); the frame (rows x cols raw counts); the
    newest twist received (6 floats), when it came (monotonic s) and how many came; ``flags``
    (``[0]`` stall: the sensor falls silent; ``[1]`` stop).
    """

    def __init__(self, rows: int, cols: int, n_joints: int, name: str | None = None) -> None:
        self.rows, self.cols, self.n_joints = rows, cols, n_joints
        n_pose, n_twist = 16 + n_joints, 8
        layout = [("headers", np.int64, (3, 2)), ("flags", np.int64, (4,)), ("pose", np.float64, (2, n_pose)),
                  ("twist", np.float64, (2, n_twist)), ("frame", np.uint16, (2, rows, cols))]
        sizes = [int(np.dtype(dtype).itemsize * np.prod(shape)) for _, dtype, shape in layout]
        self._shm = shared_memory.SharedMemory(name=name, create=name is None, size=sum(sizes))
        self.name = self._shm.name
        views, offset = {}, 0
        for (key, dtype, shape), size in zip(layout, sizes):
            views[key] = np.ndarray(shape, dtype=dtype, buffer=self._shm.buf, offset=offset)
            offset += size
        if name is None:
            for view in views.values():
                view[...] = 0
        self.flags = views["flags"]
        self._pose = _Slot(views["headers"][0], views["pose"])
        self._twist = _Slot(views["headers"][1], views["twist"])
        self._frame = _Slot(views["headers"][2], views["frame"])
        self._views = views

    def put_pose(self, T: np.ndarray, joints: np.ndarray | None) -> None:
        self._pose.put(np.concatenate([np.ravel(T), np.zeros(self.n_joints) if joints is None else joints]))

    def get_pose(self) -> tuple[np.ndarray, np.ndarray]:
        v = self._pose.get()
        return v[:16].reshape(4, 4), v[16:]

    def put_frame(self, raw: np.ndarray) -> None:
        self._frame.put(raw)

    def get_frame(self) -> np.ndarray:
        return self._frame.get()

    def put_twist(self, twist: np.ndarray, when: float) -> None:
        count = self._twist.get()[7] + 1
        self._twist.put(np.concatenate([twist, [when, count]]))

    def get_twist(self) -> tuple[np.ndarray, float, int]:
        v = self._twist.get()
        return v[:6], float(v[6]), int(v[7])

    def close(self, unlink: bool = False) -> None:
        self._pose = self._twist = self._frame = self.flags = self._views = None
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
