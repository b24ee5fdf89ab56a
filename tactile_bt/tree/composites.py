"""The ``parallel`` composite of the YAML trees: py_trees' :class:`~py_trees.composites.Parallel`
with a leaner tick.

A servo tree runs its leaves side by side under a parallel (the paper's superimposed
projections, Eq. 3), and the parallel ticks every control cycle. py_trees' own ``tick`` formats a
debug message and walks its children with generator expressions each time; that costs about as
much as a servo leaf's control law. :class:`Parallel` ticks the same way — same calls on the
children in the same order, same policies, same status and ``current_child`` — without that
overhead; with py_trees' debug log switched on it runs py_trees' own ``tick``.
``tests/test_composites.py`` checks it against py_trees' class on random trees.

Layer: tree.
"""

from __future__ import annotations

import py_trees
from py_trees.common import ParallelPolicy, Status
from py_trees.logging import Level

__all__ = ["Parallel"]

_RUNNING, _SUCCESS, _FAILURE, _INVALID = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID


class Parallel(py_trees.composites.Parallel):
    """py_trees' parallel composite (same arguments, same behaviour), ticked without per-tick
    debug formatting and generator expressions."""

    def tick(self):
        if py_trees.logging.level < Level.INFO:
            yield from super().tick()
            return
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
            yield self
            return
        policy = self.policy
        synchronise = policy.synchronise
        for child in children:
            if synchronise and child.status == _SUCCESS:
                continue
            yield from child.tick()
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
        yield self
