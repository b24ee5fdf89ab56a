"""Guards: fail a branch on a condition, judged on the mission clock (never wall time).

py_trees' own ``Timeout`` decorator reads wall time, which would make simulated missions depend
on the speed of the machine; :class:`MissionTimeout` reads the ``/tactile/time`` key instead.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Access, Status

from tactile_bt.behaviours.base import NAMESPACE, TactileBehaviour

__all__ = ["MissionTimeout", "ContactLost", "ForceLimit"]


class MissionTimeout(py_trees.decorators.Decorator):
    """Run ``child`` for at most ``duration_s`` seconds of mission time, then FAILURE
    (or SUCCESS with ``succeed=True``, for phases that simply last a while)."""

    def __init__(self, child: py_trees.behaviour.Behaviour, name: str = "mission_timeout", duration_s: float = 10.0,
                 succeed: bool = False) -> None:
        super().__init__(name=name, child=child)
        if duration_s <= 0:
            raise ValueError(f"{name}: duration_s must be positive, got {duration_s}")
        self.duration_s = float(duration_s)
        self.succeed = bool(succeed)
        self.bb = self.attach_blackboard_client(name=name, namespace=NAMESPACE)
        self.bb.register_key(key="time", access=Access.READ)
        self._start = 0.0

    def initialise(self) -> None:
        self._start = float(self.bb.time)

    def update(self) -> Status:
        elapsed = float(self.bb.time) - self._start
        if self.decorated.status in (Status.SUCCESS, Status.FAILURE):
            return self.decorated.status
        if elapsed >= self.duration_s:
            self.feedback_message = f"timed out after {self.duration_s:g} s of mission time"
            if self.decorated.status == Status.RUNNING:
                self.decorated.stop(Status.INVALID)
            return Status.SUCCESS if self.succeed else Status.FAILURE
        self.feedback_message = f"{elapsed:.2f} / {self.duration_s:g} s"
        return self.decorated.status


class ContactLost(TactileBehaviour):
    """RUNNING while in contact; FAILURE once contact has been absent for ``grace_s`` seconds.

    Put it in parallel with servo leaves to end a branch when the object is lost.
    """

    uses = frozenset({"pressure"})

    def __init__(self, name: str = "contact_lost", grace_s: float = 0.2) -> None:
        super().__init__(name)
        self.grace_s = float(grace_s)
        self._lost_since: float | None = None

    def initialise(self) -> None:
        self._lost_since = None

    def update(self) -> Status:
        if self.features.in_contact:
            self._lost_since = None
            self.feedback_message = "in contact"
            return Status.RUNNING
        if self._lost_since is None:
            self._lost_since = self.now
        lost_for = self.now - self._lost_since
        if lost_for >= self.grace_s:
            self.feedback_message = f"contact lost for {lost_for:.2f} s"
            return Status.FAILURE
        self.feedback_message = f"no contact for {lost_for:.2f} s"
        return Status.RUNNING


class ForceLimit(TactileBehaviour):
    """RUNNING while the contact force stays below ``limit_n`` (N, unsmoothed); FAILURE above it."""

    uses = frozenset({"pressure"})

    def __init__(self, name: str = "force_limit", limit_n: float = 10.0) -> None:
        super().__init__(name)
        self.limit_n = float(limit_n)

    def update(self) -> Status:
        force = self.features_raw.force
        if force > self.limit_n:
            self.feedback_message = f"force {force:.2f} N above the limit {self.limit_n:g} N"
            return Status.FAILURE
        self.feedback_message = f"force {force:.2f} N"
        return Status.RUNNING
