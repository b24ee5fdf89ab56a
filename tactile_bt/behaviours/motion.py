"""Leaves that move the pad without closing a tactile loop: ``approach`` and ``guided_slide``."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from py_trees.common import Access, Status

from tactile_bt import defaults
from tactile_bt.behaviours.base import TactileBehaviour

__all__ = ["Approach", "GuidedSlide"]


class Approach(TactileBehaviour):
    """Move along the pad normal (+z of the sensor frame) until the contact pressure passes
    ``pressure_pa``; SUCCESS then. FAILURE after ``timeout_s`` of mission time or ``max_travel_m``
    of travel without reaching it.

    Parameters
    ----------
    speed_mps : float
        Approach speed along +z_s (m/s).
    pressure_pa : float
        Pressure (Pa, smoothed feature) that counts as contact established.
    timeout_s : float
        Mission-clock time allowed (s).
    max_travel_m : float
        Largest distance travelled along the normal (m).
    """

    uses = frozenset({"pressure"})

    def __init__(
        self,
        name: str = "approach",
        speed_mps: float = defaults.APPROACH_SPEED_MPS,
        pressure_pa: float = defaults.APPROACH_PRESSURE_PA,
        timeout_s: float = 10.0,
        max_travel_m: float = 0.1,
    ) -> None:
        super().__init__(name)
        if speed_mps <= 0:
            raise ValueError(f"{name}: speed_mps must be positive, got {speed_mps}")
        self.speed_mps = float(speed_mps)
        self.pressure_pa = float(pressure_pa)
        self.timeout_s = float(timeout_s)
        self.max_travel_m = float(max_travel_m)
        self._start = 0.0
        self.travelled = 0.0

    def initialise(self) -> None:
        self._start = self.now
        self.travelled = 0.0

    def update(self) -> Status:
        f = self.features
        if f.in_contact and f.pressure >= self.pressure_pa:
            self.feedback_message = f"contact at {f.pressure:.0f} Pa after {self.travelled * 1e3:.1f} mm"
            return Status.SUCCESS
        elapsed = self.now - self._start
        if elapsed > self.timeout_s:
            self.feedback_message = f"no contact within {self.timeout_s:g} s"
            return Status.FAILURE
        if self.travelled >= self.max_travel_m:
            self.feedback_message = f"no contact within {self.max_travel_m * 1e3:g} mm"
            return Status.FAILURE
        self.command.add(self.name, np.array((0.0, 0.0, self.speed_mps, 0.0, 0.0, 0.0)))
        self.travelled += self.speed_mps * self.dt
        self.feedback_message = f"approaching, {self.travelled * 1e3:.1f} mm"
        return Status.RUNNING


class GuidedSlide(TactileBehaviour):
    """Add the external guidance twist ``V_ext`` (sensor frame) of the paper's Eq. 3.

    The twist is constant (``twist``) or read each cycle from the blackboard key ``twist_key``
    (absolute key, e.g. ``/planner/twist``). With ``require_contact`` the pad only slides while in
    contact. SUCCESS after ``distance_m`` of travel or ``duration_s`` of mission time when given
    (0 = unlimited), otherwise RUNNING.

    Parameters
    ----------
    twist : list of 6 float
        ``[vx, vy, vz, wx, wy, wz]`` in m/s and rad/s, sensor frame.
    """

    def __init__(
        self,
        name: str = "guided_slide",
        twist: Sequence[float] = (0.0, defaults.SLIDE_SPEED_MPS, 0.0, 0.0, 0.0, 0.0),
        twist_key: str = "",
        require_contact: bool = True,
        distance_m: float = 0.0,
        duration_s: float = 0.0,
    ) -> None:
        super().__init__(name)
        twist = np.asarray(twist, dtype=float)
        if twist.shape != (6,) or not np.all(np.isfinite(twist)):
            raise ValueError(f"{name}: twist must be 6 finite numbers, got {list(twist)!r}")
        self.twist = twist
        self._speed = float(np.linalg.norm(twist[:3]))
        self.twist_key = twist_key
        if twist_key:
            self._external = self.attach_blackboard_client(name=f"{name}/external")
            self._external.register_key(key=twist_key, access=Access.READ)
        self.require_contact = bool(require_contact)
        self.distance_m = float(distance_m)
        self.duration_s = float(duration_s)
        self.travelled = 0.0
        self._start = 0.0

    def initialise(self) -> None:
        self.travelled = 0.0
        self._start = self.now

    def current_twist(self) -> np.ndarray:
        if self.twist_key:
            return np.asarray(self._external.get(self.twist_key), dtype=float)
        return self.twist

    def update(self) -> Status:
        if self.distance_m > 0 and self.travelled >= self.distance_m:
            self.feedback_message = f"slid {self.travelled * 1e3:.0f} mm"
            return Status.SUCCESS
        if self.duration_s > 0 and self.now - self._start >= self.duration_s:
            self.feedback_message = f"slid for {self.duration_s:g} s"
            return Status.SUCCESS
        if self.require_contact and not self.features.in_contact:
            self.feedback_message = "waiting for contact"
            return Status.RUNNING
        if self.twist_key:
            twist = self.current_twist()
            speed = float(np.linalg.norm(twist[:3]))
        else:
            twist, speed = self.twist, self._speed
        self.command.add(self.name, twist)
        self.travelled += speed * self.dt
        self.feedback_message = "sliding"
        return Status.RUNNING
