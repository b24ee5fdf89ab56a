"""Guards: fail a branch on a condition, judged on the mission clock (never wall time).

py_trees' own ``Timeout`` decorator reads wall time, which would make simulated missions depend
on the speed of the machine; :class:`MissionTimeout` reads the ``/tactile/time`` key instead.

Layer: tree.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Access, Status

from tactile_bt.tree.behaviours.base import LazyFeedback, TactileBehaviour, TactileDecorator
from tactile_bt.tree.blackboard import NAMESPACE, TIME, read
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE
from tactile_bt.tree.ticking import DirectDecorator

__all__ = ["MissionTimeout", "ContactLost", "ForceLimit"]


class MissionTimeout(LazyFeedback, DirectDecorator, TactileDecorator, py_trees.decorators.Decorator):
    """Run ``child`` for at most ``duration_s`` seconds of mission time, then FAILURE
    (or SUCCESS with ``succeed=True``, for phases that simply last a while). A child that
    finishes in time passes its status through. The clock restarts whenever the decorator
    starts again.
    """

    duration_s = Parameter(10.0, bound=POSITIVE, doc="Mission time allowed to the child (s, > 0).")
    succeed = Parameter(False, doc="SUCCESS instead of FAILURE when the time is up.")
    _start = 0.0
    _elapsed = 0.0

    def __init__(self, child: py_trees.behaviour.Behaviour, name: str | None = None, *args, **parameters) -> None:
        super().__init__(child, name, *args, **parameters)
        # The key is registered so that py_trees shows who reads it; the per-tick read goes
        # straight to the storage (the client's bookkeeping costs several µs per read).
        self.bb = self.attach_blackboard_client(name=self.name, namespace=NAMESPACE)
        self.bb.register_key(key="time", access=Access.READ)

    def describe(self) -> str:
        """Mission time used so far and allowed."""
        return f"{self._elapsed:.2f} / {self.duration_s:g} s"

    def initialise(self) -> None:
        self._start = float(read(TIME))
        self._elapsed = 0.0

    def update(self) -> Status:
        status = self.decorated.status
        if status == Status.SUCCESS or status == Status.FAILURE:
            return status
        elapsed = self._elapsed = read(TIME) - self._start
        if elapsed >= self.duration_s:
            self.feedback_message = f"timed out after {self.duration_s:g} s of mission time"
            if status == Status.RUNNING:
                self.decorated.stop(Status.INVALID)
            return Status.SUCCESS if self.succeed else Status.FAILURE
        self._feedback = None
        return status


class ContactLost(TactileBehaviour):
    """RUNNING while in contact; FAILURE once contact has been absent for ``grace_s`` seconds
    of mission time. Put it in parallel with servo leaves to end a branch when the object is
    lost.
    """

    uses = frozenset({"pressure"})
    grace_s = Parameter(0.2, bound=NON_NEGATIVE, doc="Time without contact tolerated before failing (s).")
    _lost_since: float | None = None

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
    """RUNNING while the contact force stays at or below ``limit_n``; FAILURE above it. Judged
    on the unsmoothed force, so a spike the moving average would hide still trips it.
    """

    uses = frozenset({"pressure"})
    limit_n = Parameter(10.0, bound=POSITIVE, doc="Largest contact force (N, the sum over the contact region).")
    _force = 0.0

    def describe(self) -> str:
        """The unsmoothed force of the last tick."""
        return f"force {self._force:.2f} N"

    def update(self) -> Status:
        force = self._force = self.features_raw.force
        if force > self.limit_n:
            self.feedback_message = f"force {force:.2f} N above the limit {self.limit_n:g} N"
            return Status.FAILURE
        self._feedback = None
        return Status.RUNNING
