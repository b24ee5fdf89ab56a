"""py_trees decorators with typed, defaulted parameters, for YAML and Python alike.

They are py_trees' own :mod:`py_trees.decorators` (``Retry``, ``Repeat``, ``Inverter``,
``OneShot``) with the child first and keyword parameters that carry types and defaults, so the
loader can check them like the leaves. None of them reads wall time; for a time limit use
:class:`~tactile_bt.tree.behaviours.guards.MissionTimeout` (mission clock). They tick as
py_trees' decorators do, without a debug message formatted every tick and with a direct tick
(:mod:`tactile_bt.tree.ticking`); ``repeat``, ``retry`` and ``inverter`` format their message
of a running child only when it is read.

Layer: tree.
"""

from __future__ import annotations

from typing import Literal

import py_trees
from py_trees.common import OneShotPolicy, Status

from tactile_bt.tree.behaviours.base import LazyFeedback, TactileDecorator
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import Bound
from tactile_bt.tree.ticking import DirectDecorator, debug_logging

__all__ = ["Retry", "Repeat", "Inverter", "OneShot", "ONESHOT_POLICIES"]

#: YAML spelling of the oneshot policies.
ONESHOT_POLICIES = {
    "on_completion": OneShotPolicy.ON_COMPLETION,
    "on_successful_completion": OneShotPolicy.ON_SUCCESSFUL_COMPLETION,
}


class Retry(LazyFeedback, DirectDecorator, TactileDecorator, py_trees.decorators.Retry):
    """Restart a failing child: a child FAILURE becomes RUNNING (and the child starts again on
    the next tick) until it has failed ``num_failures`` times; then FAILURE. SUCCESS passes.
    """

    num_failures = Parameter(3, bound=Bound(1), unit=None,
                             doc="Failures allowed, the last one included (>= 1; 1 = no retry).")
    failures = 0  # py_trees' count, reset when the decorator starts

    def update(self) -> Status:
        if self.decorated.status == Status.RUNNING:
            self._feedback = None  # described when read
            return Status.RUNNING
        return super().update()

    def describe(self) -> str:
        """py_trees' message of a running child."""
        return f"running [status: {self.failures} failure from {self.num_failures}]"


class Repeat(LazyFeedback, DirectDecorator, TactileDecorator, py_trees.decorators.Repeat):
    """Run a child again after each SUCCESS until it has succeeded ``num_success`` times; then
    SUCCESS. A child FAILURE is FAILURE at once.
    """

    num_success = Parameter(2, bound=Bound(1, also=(-1,)), unit=None,
                            doc="Successes needed (>= 1), or -1 to repeat forever.")
    success = 0  # py_trees' count, reset when the decorator starts

    def update(self) -> Status:
        status = self.decorated.status
        if status != Status.FAILURE and status != Status.SUCCESS:
            self._feedback = None  # described when read
            return Status.RUNNING
        return super().update()

    def describe(self) -> str:
        """py_trees' message of a running child."""
        return f"running [status: {self.success} success from {self.num_success}]"


class Inverter(LazyFeedback, DirectDecorator, TactileDecorator, py_trees.decorators.Inverter):
    """Swap the child's SUCCESS and FAILURE; RUNNING passes through."""

    def update(self) -> Status:
        status = self.decorated.status
        if status == Status.SUCCESS or status == Status.FAILURE:
            return super().update()
        self._feedback = None  # the child's message, when read
        return status

    def describe(self) -> str:
        """The message of a running child: its own."""
        return self.decorated.feedback_message


class OneShot(DirectDecorator, TactileDecorator, py_trees.decorators.OneShot):
    """Run the child to completion once; afterwards return that final status without ticking
    the child again (e.g. a calibration touch at the start of a mission that may be re-entered).
    """

    default_name = "oneshot"
    #: Held as ``policy_name``: py_trees' ``policy`` is the OneShotPolicy it stands for.
    policy = Parameter("on_successful_completion", type=Literal["on_completion", "on_successful_completion"],
                       fixed=True, attribute="policy_name",
                       doc="``on_completion``: done after the first SUCCESS or FAILURE. ``on_successful_completion``: "
                           "done after the first SUCCESS; a failure may be tried again.")
    final_status: Status | None = None  # py_trees' status once done

    def parameters_changed(self, changed: frozenset[str]) -> None:
        self.policy = ONESHOT_POLICIES[self.policy_name]

    def tick(self):
        if debug_logging():
            yield from super().tick()
        elif self.final_status:
            self._tick_alone()
            yield self
        else:
            yield from DirectDecorator.tick(self)

    def tick_direct(self) -> None:
        if self.final_status:
            self._tick_alone()
        else:
            DirectDecorator.tick_direct(self)

    def _tick_alone(self) -> None:
        """Once done, py_trees ticks the oneshot as a leaf: its child is left alone."""
        if self.status != Status.RUNNING:
            self.initialise()
        self._conclude()
