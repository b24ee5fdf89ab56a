"""The ROS 2 backend of the :class:`~tactile_bt.robot.interface.Robot` protocol.

A live mission sends its twist as ``geometry_msgs/TwistStamped`` in the base frame, the form
MoveIt Servo (``/servo_node/delta_twist_cmds``) and Cartesian twist controllers take: the linear
velocity of the commanded frame's origin and the angular velocity, both in the base frame. It
reads the pad's pose from a ``geometry_msgs/PoseStamped`` topic, either of the pad itself or of
the flange (the servo's end-effector frame) with a fixed flange → pad transform, and the arm's
``sensor_msgs/JointState`` where a topic is given.

ROS 2 stays on this host unless the robot file opts in to the network: before rclpy initialises,
:func:`keep_local` sets localhost-only discovery (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) and
Fast DDS's shared-memory transport (``FASTDDS_BUILTIN_TRANSPORTS=SHM``).

rclpy is imported by this module only, when a node is made (the ``ros2`` extra installs it; a
lab's own ROS 2 installation works too).

Layer: robot.
"""

from __future__ import annotations

import math
import os
import threading
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import spatial_to_point
from tactile_bt.errors import RobotConnectionError
from tactile_bt.robot.interface import JointState, StampedPose, as_twist

__all__ = ["LOCAL_ONLY", "Ros2Settings", "Ros2Robot", "RosNode", "keep_local", "pose_from_message",
           "fill_pose_message", "twist_from_message"]

#: The environment that keeps ROS 2 on this host: localhost discovery, shared-memory transport.
LOCAL_ONLY = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "FASTDDS_BUILTIN_TRANSPORTS": "SHM"}
#: MoveIt Servo's twist command topic.
SERVO_TWIST_TOPIC = "/servo_node/delta_twist_cmds"


def keep_local(network: bool = False) -> None:
    """Keep ROS 2 on this host (unless ``network``): call before rclpy initialises."""
    if not network:
        os.environ.update(LOCAL_ONLY)


@dataclass(frozen=True)
class Ros2Settings:
    """The ``ros2`` section of a robot file (:mod:`tactile_bt.robot.setup`).

    Attributes
    ----------
    twist_topic : str
        Where the twists go (``geometry_msgs/TwistStamped``).
    base_frame : str
        ``header.frame_id`` of the twists: the frame the pad's pose is given in.
    pose_topic : str
        ``geometry_msgs/PoseStamped`` of the pad, or of the flange with ``flange_to_pad``.
    flange_to_pad : (4, 4) ndarray or None
        The pad's pose in the flange frame (m) when ``pose_topic`` gives the flange; the twist
        then commands the flange's origin (the servo's end-effector frame).
    joint_state_topic : str or None
        ``sensor_msgs/JointState`` of the arm, for joint-limit warnings.
    joint_lower_rad, joint_upper_rad : tuple of float
        The joints' limits in the order of the joint state (rad); empty when unknown.
    node_name : str
    network : bool
        Discover ROS 2 peers on the network (a robot on another host); default: this host only.
    """

    twist_topic: str = SERVO_TWIST_TOPIC
    base_frame: str = "base_link"
    pose_topic: str = "/tactile_bt/pad_pose"
    flange_to_pad: np.ndarray | None = None
    joint_state_topic: str | None = None
    joint_lower_rad: tuple[float, ...] = ()
    joint_upper_rad: tuple[float, ...] = ()
    node_name: str = "tactile_bt_live"
    network: bool = False


def pose_from_message(pose) -> np.ndarray:
    """``geometry_msgs/Pose`` → 4x4 homogeneous matrix (m)."""
    q = pose.orientation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    T[:3, 3] = (pose.position.x, pose.position.y, pose.position.z)
    return T


def fill_pose_message(pose, T: np.ndarray) -> None:
    """Write the 4x4 matrix ``T`` into a ``geometry_msgs/Pose``."""
    x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat()
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = float(x), float(y), float(z), float(w)
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in T[:3, 3])


def twist_from_message(twist) -> np.ndarray:
    """``geometry_msgs/Twist`` → ``[vx, vy, vz, wx, wy, wz]``."""
    return np.array([twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.x, twist.angular.y,
                     twist.angular.z], dtype=float)


class RosNode:
    """An rclpy node in a context of its own, spun by a daemon thread.

    Parameters
    ----------
    name : str
        The node's name.
    network : bool
        Discover peers on the network; default: this host only (:func:`keep_local`).
    """

    def __init__(self, name: str, network: bool = False) -> None:
        keep_local(network)
        try:
            import rclpy
            from rclpy.executors import SingleThreadedExecutor
        except ImportError as exc:
            raise RobotConnectionError(f"ROS 2 is not installed ({exc}): pip install 'tactile_bt[ros2]', or "
                                       "source a ROS 2 installation") from None
        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        try:
            self.node = rclpy.create_node(name, context=self.context)
            self._executor = SingleThreadedExecutor(context=self.context)
            self._executor.add_node(self.node)
        except BaseException:
            rclpy.shutdown(context=self.context)
            raise
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._spin, name=f"ros2 {name}", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._closed.is_set() and self.context.ok():
            try:
                self._executor.spin_once(timeout_sec=0.02)
            except Exception:  # noqa: BLE001 - shutting down under the spinner
                if self._closed.is_set() or not self.context.ok():
                    return
                raise

    def close(self) -> None:
        """Stop spinning, destroy the node, shut the context down (idempotent)."""
        if self._closed.is_set():
            return
        self._closed.set()
        self._thread.join(timeout=1.0)
        try:
            self._executor.shutdown(timeout_sec=0.5)
            self.node.destroy_node()
        finally:
            if self.context.ok():
                self._rclpy.shutdown(context=self.context)


class Ros2Robot:
    """A robot reached over ROS 2: it satisfies :class:`~tactile_bt.robot.interface.Robot`.

    The pose's stamp (:attr:`StampedPose.stamp_s`) is when this process received it
    (``time.monotonic()``, s), so that a live loop can tell a stale pose whatever the robot's
    clock; the message's own stamp is kept in :attr:`last_message_stamp_s`.
    """

    def __init__(self, settings: Ros2Settings) -> None:
        from geometry_msgs.msg import PoseStamped, TwistStamped

        self.settings = settings
        self._ros = RosNode(settings.node_name, settings.network)
        self._lock = threading.Condition()
        self._pose: StampedPose | None = None
        self._command_point = np.zeros(3)
        self._joints: JointState | None = None
        self.last_message_stamp_s = math.nan
        self._twist_type = TwistStamped
        node = self._ros.node
        self._publisher = node.create_publisher(TwistStamped, settings.twist_topic, 10)
        self._subscriptions = [node.create_subscription(PoseStamped, settings.pose_topic, self._on_pose, 10)]
        if settings.joint_state_topic:
            from sensor_msgs.msg import JointState as JointStateMessage

            self._subscriptions.append(node.create_subscription(JointStateMessage, settings.joint_state_topic,
                                                                self._on_joints, 10))

    # -- inputs ---------------------------------------------------------------------------------
    def _on_pose(self, msg) -> None:
        T = pose_from_message(msg.pose)
        point = T[:3, 3].copy()  # the commanded frame's origin: the flange with flange_to_pad, else the pad
        if self.settings.flange_to_pad is not None:
            T = T @ self.settings.flange_to_pad
        with self._lock:
            self._pose = StampedPose(T, time.monotonic())
            self._command_point = point
            self.last_message_stamp_s = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
            self._lock.notify_all()

    def _on_joints(self, msg) -> None:
        q = np.asarray(msg.position, dtype=float)
        lower = np.asarray(self.settings.joint_lower_rad, dtype=float)
        upper = np.asarray(self.settings.joint_upper_rad, dtype=float)
        if lower.shape != q.shape:
            lower, upper = np.full(q.shape, -np.inf), np.full(q.shape, np.inf)
        with self._lock:
            self._joints = JointState(q, lower, upper, time.monotonic())

    def wait_for_pose(self, timeout_s: float) -> StampedPose:
        """Block until the first pose has come; :class:`RobotConnectionError` after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        with self._lock:
            while self._pose is None:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise RobotConnectionError(f"no pose on {self.settings.pose_topic} within {timeout_s:g} s: is the "
                                               "robot's driver running (and on this host, or network: true in the "
                                               "robot file)?")
                self._lock.wait(remaining)
            return self._pose

    # -- the Robot protocol ----------------------------------------------------------------------
    def pad_pose(self) -> StampedPose:
        with self._lock:
            if self._pose is None:
                raise RobotConnectionError(f"no pose received on {self.settings.pose_topic} yet")
            return self._pose

    def send_twist(self, twist_g) -> None:
        v = as_twist(twist_g)
        with self._lock:
            point = self._command_point
        self._publish(spatial_to_point(v, point))

    def stop(self) -> None:
        self._publish(np.zeros(6))

    def joint_state(self) -> JointState | None:
        with self._lock:
            return self._joints

    def _publish(self, twist: np.ndarray) -> None:
        msg = self._twist_type()
        msg.header.frame_id = self.settings.base_frame
        msg.header.stamp = self._ros.node.get_clock().now().to_msg()
        t = msg.twist
        t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z = (float(x) for x in twist)
        self._publisher.publish(msg)

    def close(self) -> None:
        """A last zero twist, then the node goes (idempotent)."""
        if self._ros._closed.is_set():
            return
        try:
            self.stop()
        finally:
            self._ros.close()

    def __enter__(self) -> "Ros2Robot":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
