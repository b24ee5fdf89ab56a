"""Leaves that move the pad without closing a tactile loop: ``approach`` and ``guided_slide``.

Layer: tree.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from py_trees.common import Access, Status

from tactile_bt import defaults
from tactile_bt.perception.features import wrap_half_pi
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.blackboard import read
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between, normalise_key
from tactile_bt.errors import BlackboardReferenceError
from tactile_bt.units import TWIST


__all__ = ["Approach", "GuidedSlide"]


class Approach(TactileBehaviour):
    """Move along the pad normal (+z of the sensor frame) until the contact pressure passes
    ``pressure_pa``; SUCCESS then. FAILURE after ``timeout_s`` of mission time or ``max_travel_m``
    of travel without reaching it. This is the start of every experiment of the paper (Sec. V).

    The feedback message tells the distance travelled, the pressure reached, or why it failed.
    """

    uses = frozenset({"pressure"})
    #: A faster approach would be capped by the cycle's twist limit and its ``travelled`` would
    #: count distance the pad never moved: it is refused instead.
    speed_mps = Parameter(defaults.APPROACH_SPEED_MPS,
                          bound=between(0.0, defaults.TWIST_LINEAR_LIMIT_MPS, low_open=True,
                                        note=f"the pad moves at most {defaults.TWIST_LINEAR_LIMIT_MPS:g} m/s "
                                             "(write e.g. '10 mm/s' for millimetres per second)"),
                          doc="Approach speed along +z_s, towards the object (m/s; at most the cycle's linear twist "
                              "limit).")
    pressure_pa = Parameter(defaults.APPROACH_PRESSURE_PA, bound=POSITIVE,
                            doc="Smoothed contact pressure that counts as contact established (Pa).")
    timeout_s = Parameter(10.0, bound=POSITIVE, doc="Mission-clock time allowed from the start of the leaf (s).")
    max_travel_m = Parameter(0.1, bound=POSITIVE, doc="Largest distance travelled along the normal (m).")
    _start = 0.0
    travelled = 0.0

    def initialise(self) -> None:
        self._start = self.now
        self.travelled = 0.0

    def describe(self) -> str:
        """Travel so far while approaching."""
        return f"approaching, {self.travelled * 1e3:.1f} mm"

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
        self.command.add(self.name, (0.0, 0.0, self.speed_mps, 0.0, 0.0, 0.0))
        self.travelled += self.speed_mps * self.dt
        self._feedback = None
        return Status.RUNNING


class GuidedSlide(TactileBehaviour):
    """Add the external guidance twist ``V_ext`` (sensor frame) of the paper's Eq. 3.

    The twist is constant (``twist``) or read each cycle from the blackboard key ``twist_key``
    (e.g. ``/planner/twist``, written by a planner; a missing key is an error when the leaf
    starts). A ``twist`` given as a blackboard reference (``"@/key"``) is instead read once,
    when the leaf starts. With ``require_contact`` the pad only slides while in contact.
    SUCCESS after ``distance_m`` of travel or ``duration_s`` of mission time when given
    (0 = unlimited), otherwise RUNNING.

    **Guidance scaling.** With ``slow_turn_rad`` or ``slow_offset_m`` set, the twist is scaled
    each cycle by ``1 / (1 + (e_a / slow_turn_rad)² + (e_l / slow_offset_m)²)``, bounded below by
    ``min_scale``: ``e_a`` is the angle between the contact's major axis and the direction of
    travel (the twist's linear part in the pad plane; modulo pi), ``e_l`` the centre of
    pressure's distance from the pad centre across the travel (both from the smoothed
    features). Where a followed line turns in the pad or bends, the pad slows and the aligning
    servos keep up; on straight parts, with errors well below those scales, it slides at nearly
    the full twist again, speeding up by at most ``speedup_per_s`` of the full twist per second.
    A contact without a defined axis slides at ``min_scale``.
    """

    twist = Parameter((0.0, defaults.SLIDE_SPEED_MPS, 0.0, 0.0, 0.0, 0.0), type=Sequence[float], unit=TWIST,
                      doc="``[vx, vy, vz, wx, wy, wz]`` in m/s and rad/s, sensor frame; elements may carry units "
                          "(``[0, 30 mm/s, 0, 0, 0, 10 deg/s]``); signed (its sign is the direction).")
    twist_key = Parameter("", fixed=True, doc="Blackboard key to read the twist from on every tick instead (\"\" = "
                                              "use ``twist``).")
    require_contact = Parameter(True, doc="Slide only while in contact (otherwise wait, RUNNING).")
    distance_m = Parameter(0.0, bound=NON_NEGATIVE, doc="Succeed after this linear travel (m; 0 = unlimited).")
    duration_s = Parameter(0.0, bound=NON_NEGATIVE, doc="Succeed after this mission time (s; 0 = unlimited).")
    slow_turn_rad = Parameter(0.0, bound=NON_NEGATIVE, fixed=True,
                              doc="Angle of the contact's axis to the travel at which the guidance halves (rad; 0 = "
                                  "the angle does not slow it).")
    slow_offset_m = Parameter(0.0, bound=NON_NEGATIVE, fixed=True,
                              doc="Distance of the centre of pressure from the pad centre, across the travel, at "
                                  "which the guidance halves (m; 0 = the offset does not slow it).")
    min_scale = Parameter(0.25, bound=between(0.0, 1.0, low_open=True), unit=None,
                          doc="Lowest share of the twist the guidance scaling leaves.")
    speedup_per_s = Parameter(1.0, bound=POSITIVE, unit="1/s",
                              doc="Largest growth of the guidance scale per second of mission time (1/s).")
    #: The key named by ``twist_key`` holds a value like ``twist`` (checked by ``--blackboard``).
    key_parameters = {"twist_key": "twist"}
    travelled = 0.0
    _start = 0.0
    #: The share of the twist added this cycle (guidance scaling).
    scale = 1.0

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        if self.slow_turn_rad > 0 or self.slow_offset_m > 0:
            self.uses = frozenset({"orientation", "cop"})
        if self.twist_key:
            self._key = normalise_key(self.twist_key)
            self._external = self.attach_blackboard_client(name=f"{self.name}/external")
            self._external.register_key(key=self._key, access=Access.READ)

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if "twist" in changed:
            twist = np.asarray(self.twist, dtype=float)
            if twist.shape != (6,) or not np.all(np.isfinite(twist)):
                raise ValueError(f"{self.name}: twist must be 6 finite numbers, got {list(np.ravel(twist))!r}")
            self.twist = twist
            self._twist = tuple(float(v) for v in twist)
            self._speed = float(np.linalg.norm(twist[:3]))

    def initialise(self) -> None:
        self.travelled = 0.0
        self._start = self.now
        self.scale = 1.0
        if self.twist_key and not self._external.exists(self._key):
            raise BlackboardReferenceError(f"{self.name}: blackboard key {self._key!r} (twist_key) is not set; "
                           "write the twist there before the leaf starts")

    def current_twist(self) -> np.ndarray:
        """The twist the leaf adds this cycle (m/s, rad/s, sensor frame)."""
        if self.twist_key:
            return np.asarray(read(self._key), dtype=float)
        return self.twist

    def describe(self) -> str:
        """Travel so far while sliding."""
        if self.uses:
            return f"sliding, {self.travelled * 1e3:.1f} mm, at {self.scale:.0%} of the guidance"
        return f"sliding, {self.travelled * 1e3:.1f} mm"

    def _guidance_scale(self, twist) -> float:
        """The scale of this cycle (see the class docstring); updates :attr:`scale`."""
        f = self.features
        travel = math.atan2(twist[1], twist[0])
        angle = f.orientation
        if angle != angle:
            target = self.min_scale
        else:
            slowing = 0.0
            if self.slow_turn_rad > 0:
                slowing += (wrap_half_pi(angle - travel) / self.slow_turn_rad) ** 2
            if self.slow_offset_m > 0:
                x, y = f.cop_xy
                slowing += ((y * math.cos(travel) - x * math.sin(travel)) / self.slow_offset_m) ** 2
            target = max(self.min_scale, 1.0 / (1.0 + slowing))
        self.scale = min(target, self.scale + self.speedup_per_s * self.dt)
        return self.scale

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
            # Straight from the storage (the key is registered above): no per-tick bookkeeping.
            value = read(self._key)
            twist = value.tolist() if isinstance(value, np.ndarray) else list(value)
            if len(twist) != 6:
                raise ValueError(f"{self.name}: blackboard key {self._key!r} must hold 6 numbers, got {value!r}")
            speed = math.sqrt(twist[0] * twist[0] + twist[1] * twist[1] + twist[2] * twist[2])
        else:
            twist, speed = self._twist, self._speed
        if self.uses:
            scale = self._guidance_scale(twist)
            twist = [v * scale for v in twist]
            speed *= scale
        self.command.add(self.name, twist)
        self.travelled += speed * self.dt
        self._feedback = None
        return Status.RUNNING
