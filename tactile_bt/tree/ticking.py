"""Direct ticks: one tick of a tree without a generator per node.

py_trees ticks a tree through generators: every node's ``tick()`` yields itself after its work,
and every composite passes on what its children yield, so that ``BehaviourTree.tick()`` can show
each node to its visitors right after it ticked. A mission with no visitors only drains that
iterator, and on a deep tree (the stripe scan: nine levels) the yields through every ancestor
cost more than most leaves' work.

The nodes of this package therefore have a second entry, ``tick_direct()``: the same calls in
the same order with the same effects as draining their ``tick()``, children ticked through
:func:`tick_node`. Their ``tick()`` stays a generator (for visitors, ``tick_once`` and py_trees'
debug log, which it still writes when switched on). :func:`tick_node` falls back to draining
``tick()`` for any other node, so trees may mix in py_trees' own behaviours.
``tests/tree/test_composites.py`` checks both entries against py_trees' classes on random trees.

Layer: tree.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Status
from py_trees.logging import Level

from tactile_bt.tree.parameters import resolve_references

__all__ = ["tick_node", "debug_logging", "checked", "DirectDecorator", "STATUSES"]

#: The statuses a node may return (py_trees builds this list on every tick).
STATUSES = tuple(Status)
_RUNNING, _INVALID = Status.RUNNING, Status.INVALID


def debug_logging() -> bool:
    """Whether py_trees' debug log is on: then the nodes tick through py_trees' own code, which
    writes it."""
    return py_trees.logging.level < Level.INFO


def tick_node(node: py_trees.behaviour.Behaviour) -> None:
    """Tick ``node`` and its subtree once, with the effects of draining ``node.tick()``: through
    ``node.tick_direct()`` where it has one, else through its generator."""
    direct = getattr(node, "tick_direct", None)
    if direct is not None:
        direct()
    else:
        for _ in node.tick():
            pass


def checked(node: py_trees.behaviour.Behaviour, status) -> Status:
    """``status`` when it is a :class:`~py_trees.common.Status`, else INVALID with py_trees' error
    message."""
    if status in STATUSES:
        return status
    node.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{status}][{node.name}]")
    return _INVALID


class DirectDecorator:
    """Mixin for subclasses of :class:`py_trees.decorators.Decorator`: its ``tick()`` without a
    debug message formatted every tick while py_trees' debug log is off, and ``tick_direct()``."""

    def tick(self):
        if self.status != _RUNNING:
            resolve_references(self)
        if debug_logging():
            yield from super().tick()
            return
        if self.status != _RUNNING:
            self.initialise()
        yield from self.decorated.tick()
        self._conclude()
        yield self

    def tick_direct(self) -> None:
        if self.status != _RUNNING:
            resolve_references(self)
            self.initialise()
        tick_node(self.decorated)
        self._conclude()

    def _conclude(self) -> None:
        """The end of a decorator's tick, after its child's: update, stop when done."""
        new_status = checked(self, self.update())
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
