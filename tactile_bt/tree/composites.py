"""The composites of the YAML trees: py_trees' :class:`~py_trees.composites.Sequence`,
:class:`~py_trees.composites.Selector` and :class:`~py_trees.composites.Parallel` with leaner
ticks.

A servo tree runs its leaves side by side under a parallel (the paper's superimposed
projections, Eq. 3), under sequences and selectors, and every one of them ticks every control
cycle. py_trees' own ``tick`` formats a debug message and walks its children with generator
expressions each time, and passes every node its children yield on to its parent; that costs
about as much as a servo leaf's control law per level. These classes tick the same way — same
calls on the children in the same order, same policies, same status and ``current_child`` —
without the formatting, and have a direct tick without generators
(:mod:`tactile_bt.tree.ticking`); with py_trees' debug log switched on they run py_trees' own
``tick``. Each one's logic is written once, as a walk (:meth:`_Walked._walk`) that names the
children to tick in turn and sees their statuses after each. ``tests/tree/test_composites.py`` checks
them against py_trees' classes on random trees.

Layer: tree.
"""

from __future__ import annotations

from py_trees import composites
from py_trees.common import ParallelPolicy, Status

from tactile_bt.tree.ticking import debug_logging, tick_node

__all__ = ["Parallel", "Sequence", "Selector"]

_RUNNING, _SUCCESS, _FAILURE, _INVALID = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID


class _Walked:
    """Both ticks of a composite from one walk over its children: ``_walk()`` yields each child
    to tick and, when resumed, finds it ticked."""

    def tick(self):
        if debug_logging():
            yield from super().tick()
            return
        for child in self._walk():
            yield from child.tick()
        yield self

    def tick_direct(self) -> None:
        for child in self._walk():
            tick_node(child)


class Parallel(_Walked, composites.Parallel):
    """py_trees' parallel composite (same arguments, same behaviour), ticked without per-tick
    debug formatting and generator expressions."""

    def _walk(self):
        self.validate_policy_configuration()
        children = self.children
        if self.status != _RUNNING:
            for child in children:
                # reset the children, so that old SUCCESS/FAILURE flags don't break synchronisation
                if child.status != _INVALID:
                    child.stop(_INVALID)
            self.current_child = None
            self.initialise()
        if not children:
            self.current_child = None
            self.stop(_SUCCESS)
            return
        policy = self.policy
        synchronise = policy.synchronise
        for child in children:
            if synchronise and child.status == _SUCCESS:
                continue
            yield child
        new_status = _RUNNING
        self.current_child = children[-1]
        failed = None
        for child in children:
            if child.status == _FAILURE:
                failed = child
                break
        if failed is not None:
            self.current_child = failed
            new_status = _FAILURE
        elif isinstance(policy, ParallelPolicy.SuccessOnAll):
            for child in children:
                if child.status != _SUCCESS:
                    break
            else:
                new_status = _SUCCESS
                self.current_child = children[-1]
        elif isinstance(policy, ParallelPolicy.SuccessOnOne):
            for child in reversed(children):
                if child.status == _SUCCESS:
                    new_status = _SUCCESS
                    self.current_child = child
                    break
        elif isinstance(policy, ParallelPolicy.SuccessOnSelected):
            for child in policy.children:
                if child.status != _SUCCESS:
                    break
            else:
                new_status = _SUCCESS
                self.current_child = policy.children[-1]
        else:
            raise RuntimeError(f"this parallel has been configured with an unrecognised policy [{type(policy)}]")
        # a parallel that has ended stops its children that are still running
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status


class Sequence(_Walked, composites.Sequence):
    """py_trees' sequence (same arguments, same behaviour), ticked without per-tick debug
    formatting and without passing on every node its children yield one level at a time."""

    def _walk(self):
        children = self.children
        index = 0
        if self.status != _RUNNING:
            self.current_child = children[0] if children else None
            for child in children:
                if child.status != _INVALID:
                    child.stop(_INVALID)
            self.initialise()  # user specific initialisation
        elif self.memory and self.current_child is not None:
            index = children.index(self.current_child)
        else:
            self.current_child = children[0] if children else None
        if not children:
            self.current_child = None
            self.stop(_SUCCESS)
            return
        for at in range(index, len(children)):
            child = children[at]
            yield child
            if child.status != _SUCCESS:
                if not self.memory:
                    # invalidate the remainder of the sequence, i.e. kill dangling runners
                    for later in children[at + 1:]:
                        if later.status != _INVALID:
                            later.stop(_INVALID)
                # stop the sequence if a terminal (non-success) state was reached
                if child.status != _RUNNING:
                    self.stop(child.status)
                else:
                    self.status = child.status
                return
            if at + 1 < len(children):  # advance to the next sibling, if any
                self.current_child = children[at + 1]
        self.stop(_SUCCESS)


class Selector(_Walked, composites.Selector):
    """py_trees' selector (same arguments, same behaviour), ticked without per-tick debug
    formatting and without passing on every node its children yield one level at a time."""

    def _walk(self):
        children = self.children
        if self.status != _RUNNING:
            self.current_child = children[0] if children else None
            self.initialise()  # user specific initialisation
        if not children:
            self.current_child = None
            self.stop(_FAILURE)
            return
        index = 0
        if self.memory:
            index = children.index(self.current_child)
            # clear out preceding statuses
            for child in children[:index]:
                if child.status != _INVALID:
                    child.stop(_INVALID)
        previous = self.current_child
        for child in children[index:]:
            yield child
            if child.status == _RUNNING or child.status == _SUCCESS:
                self.current_child = child
                if previous is None or previous != child:
                    # we interrupted: invalidate everything at a lower priority
                    passed = False
                    for other in children:
                        if passed and other.status != _INVALID:
                            other.stop(_INVALID)
                        passed = True if other == child else passed
                # terminate the selector if a terminal state was reached
                if child.status == _SUCCESS:
                    self.stop(child.status)
                else:
                    self.status = child.status
                return
        # all children failed: so does the selector, its current child the last one
        self.stop(_FAILURE)
        self.current_child = children[-1] if children else None
