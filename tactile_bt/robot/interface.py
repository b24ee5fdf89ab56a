"""What a mission needs of an arm: the :class:`Robot` protocol, and its simulated side.

A live mission closes the loop on whatever carries the pad through four calls::

    robot.pad_pose()          -> StampedPose(T_gs, stamp_s)   where the pad is, and when
    robot.send_twist(twist_g)                                 move like this until told otherwise
    robot.stop()                                              zero twist (idempotent)
    robot.joint_state()       -> JointState | None            joints and limits, where known

``T_gs`` is the pad's (sensor frame O_s) pose in the base frame O_g, a 4x4 homogeneous matrix in
metres; ``twist_g`` is the spatial twist ``V_g = Ad(T_gs) V_s`` of paper Eq. 4,
``[vx, vy, vz, wx, wy, wz]`` in m/s and rad/s, base frame (:mod:`tactile_bt.control.spatial`).
A twist is a velocity command: the robot keeps moving by the last twist it received until the
next one (a hardware backend adds its own watchdog). Stamps are seconds on the robot's clock:
mission time for a simulated mount, the message stamps of a hardware backend.

The simulated mounts (:mod:`tactile_bt.robot.mounts`) satisfy the protocol through
:class:`SimulatedRobot`: the twist sent is held, :meth:`SimulatedRobot.step` moves the mount by
it for ``dt`` seconds of simulated time (the mount's own ``move``, unchanged) and advances the
mount's clock. So one loop and one supervisor serve simulation and hardware.

Layer: robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Robot", "StampedPose", "JointState", "SimulatedRobot", "as_twist"]


@dataclass(frozen=True)
class StampedPose:
    """The pad's pose and the time it was measured.

    Attributes
    ----------
    T_gs : (4, 4) ndarray
        Sensor frame O_s in the base frame O_g (rotation, translation in m).
    stamp_s : float
        When the pose was measured (s, the robot's clock).
    """

    T_gs: np.ndarray
    stamp_s: float


@dataclass(frozen=True)
class JointState:
    """The arm's joints, for saturation warnings.

    Attributes
    ----------
    positions_rad : (n,) ndarray
        Measured joint angles (rad).
    lower_rad, upper_rad : (n,) ndarray
        Joint position limits (rad).
    stamp_s : float
        When the joints were measured (s, the robot's clock).
    saturated : (n,) bool ndarray or None
        Joints the robot's own controller held on a limit in its last step, where it says so.
    """

    positions_rad: np.ndarray
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    stamp_s: float
    saturated: np.ndarray | None = None

    def near_limit(self, margin_rad: float) -> np.ndarray:
        """(n,) bool: joints within ``margin_rad`` (rad) of a position limit, or held on one."""
        q = np.asarray(self.positions_rad, dtype=float)
        near = (q - self.lower_rad <= margin_rad) | (self.upper_rad - q <= margin_rad)
        return near if self.saturated is None else near | np.asarray(self.saturated, dtype=bool)


@runtime_checkable
class Robot(Protocol):
    """What a mission needs of the arm that carries the pad (module docstring)."""

    def pad_pose(self) -> StampedPose:
        """The pad's pose ``T_gs`` (base frame, m) and its stamp (s)."""
        ...

    def send_twist(self, twist_g: np.ndarray) -> None:
        """Command the spatial twist ``twist_g`` ([v; ω], m/s, rad/s, base frame) until the next."""
        ...

    def stop(self) -> None:
        """Command a zero twist; calling it again changes nothing."""
        ...

    def joint_state(self) -> JointState | None:
        """Joint angles and limits, or None where the robot does not tell them."""
        ...


_ZERO_TWIST = np.zeros(6)
_ZERO_TWIST.setflags(write=False)


def as_twist(twist_g, name: str = "twist_g") -> np.ndarray:
    """``twist_g`` as a new (6,) float array; ValueError naming ``name`` unless it is 6 finite numbers."""
    try:
        v = np.array(twist_g, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 6 finite numbers [vx, vy, vz, wx, wy, wz], got {twist_g!r}") from None
    if v.shape != (6,) or not math.isfinite(v.dot(v)):  # dot: a third of the time of @ on 6 numbers
        raise ValueError(f"{name} must be 6 finite numbers [vx, vy, vz, wx, wy, wz], got {twist_g!r}")
    return v


class SimulatedRobot:
    """The :class:`Robot` protocol for a simulated mount (a mix-in).

    The host class provides ``pose`` (the pad's 4x4 ``T_gs``) and ``move(twist_g, dt)``; this
    adds the held twist and the mount's clock (s of simulated time, 0 at the start). Nothing
    here changes how a mount moves: :meth:`step` is ``move(held twist, dt)``.
    """

    _held_twist_g: np.ndarray = _ZERO_TWIST
    _clock_s: float = 0.0

    def pad_pose(self) -> StampedPose:
        """The pad's pose now, stamped with the mount's clock (s)."""
        return StampedPose(np.array(self.pose, dtype=float), self._clock_s)

    def send_twist(self, twist_g: np.ndarray) -> None:
        """Hold ``twist_g`` (m/s, rad/s, base frame) for the following steps."""
        self._held_twist_g = as_twist(twist_g)

    def stop(self) -> None:
        """Hold a zero twist."""
        self._held_twist_g = _ZERO_TWIST

    @property
    def held_twist(self) -> np.ndarray:
        """The twist the next :meth:`step` moves by (m/s, rad/s, base frame; a copy)."""
        return self._held_twist_g.copy()

    def step(self, dt: float) -> None:
        """Move by the held twist for ``dt`` seconds (the mount's ``move``) and advance the clock."""
        self.move(self._held_twist_g, dt)
        self._clock_s += float(dt)

    def joint_state(self) -> JointState | None:
        """None: a mount without joints."""
        return None
