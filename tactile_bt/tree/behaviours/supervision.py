"""What the tree learns from the supervisor: the ``/supervisor`` blackboard keys and a guard
that fails a branch while the supervisor retreats.

The supervisor (:mod:`tactile_bt.mission.supervisor`) sits between the controller and the
mount, outside the tree; it writes these keys and reads nothing from the blackboard, so no tree
can switch it off. A tree reads them to back off and go on elsewhere.

==================  ===============================================================
key                 content
==================  ===============================================================
``retreating``      bool: an intervention is under way (a limit was exceeded less than
                    the supervisor's ``clear_s`` ago); the pad is being pulled back
``reason``          str: the limit of the intervention (value, limit, mission time);
                    ``""`` while none is under way
==================  ===============================================================

Layer: tree.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Access, Status

from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.blackboard import read_or

__all__ = ["SUPERVISOR_NAMESPACE", "RETREATING", "REASON", "publish_supervision", "SupervisorRetreat"]

SUPERVISOR_NAMESPACE = "/supervisor"
RETREATING = f"{SUPERVISOR_NAMESPACE}/retreating"
REASON = f"{SUPERVISOR_NAMESPACE}/reason"
_STORAGE = py_trees.blackboard.Blackboard.storage


def publish_supervision(retreating: bool, reason: str) -> None:
    """Write the supervisor's state (:data:`RETREATING`, :data:`REASON`) for the tree."""
    _STORAGE[RETREATING] = bool(retreating)
    _STORAGE[REASON] = str(reason)


class SupervisorRetreat(TactileBehaviour):
    """RUNNING while the supervisor lets the tree's twist through; FAILURE, with the
    supervisor's reason, while it retreats from a force or pressure limit. Put it in parallel
    with servo leaves so that a selector backs off and tries another branch; the supervisor
    retreats and ends the mission whether or not a tree has this guard.
    """

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.supervisor = self.attach_blackboard_client(name=f"{self.name}/supervisor", namespace=SUPERVISOR_NAMESPACE)
        for key in ("retreating", "reason"):
            self.supervisor.register_key(key=key, access=Access.READ)

    def update(self) -> Status:
        if read_or(RETREATING, False):
            self.feedback_message = f"the supervisor retreats: {read_or(REASON, '')}"
            return Status.FAILURE
        self.feedback_message = "within the supervisor's limits"
        return Status.RUNNING
