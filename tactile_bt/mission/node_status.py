"""The status of every node of a tree, per tick, as small integers: what ``tree.png`` draws and
``log.npz`` keeps (``node_names``, ``node_depth``, ``node_status``).

Recording must cost next to nothing: a mission ticks its tree 250 times per mission second and
runs 25-50x faster than real time. :meth:`NodeStatusLog.record` therefore reads every node's
``status`` into a tuple and compares it with the last tick's (py_trees' statuses are enum
singletons: the comparison is by identity); only a tick that changed something is coded into
the preallocated ``uint8`` rows, and :meth:`NodeStatusLog.arrays` fills the other ticks forward.

Layer: mission.
"""

from __future__ import annotations

from operator import attrgetter

import numpy as np
import py_trees
from py_trees.common import Status

__all__ = ["STATUS_NAMES", "STATUS_CODES", "NodeStatusLog", "tree_nodes", "status_changes"]

#: The code of each status in ``node_status``: its index here.
STATUS_NAMES = ("invalid", "running", "success", "failure")
#: py_trees status → code.
STATUS_CODES = {Status.INVALID: 0, Status.RUNNING: 1, Status.SUCCESS: 2, Status.FAILURE: 3}

_status = attrgetter("status")


def tree_nodes(root: py_trees.behaviour.Behaviour) -> list[tuple[py_trees.behaviour.Behaviour, str, int]]:
    """Every node under ``root`` in tree order (depth first, parents before their children):
    ``(node, path, depth)``; ``path`` joins the names from the root with ``/``, the root has
    depth 0."""
    out = []

    def walk(node, prefix: str, depth: int) -> None:
        path = f"{prefix}/{node.name}" if prefix else node.name
        out.append((node, path, depth))
        for child in node.children:
            walk(child, path, depth + 1)

    walk(root, "", 0)
    return out


class NodeStatusLog:
    """Per-tick status codes of every node of a tree (:data:`STATUS_NAMES`), preallocated for
    ``n`` ticks.

    Parameters
    ----------
    root : py_trees.behaviour.Behaviour
        The tree's root; its nodes are walked once, here (a tree does not change shape while
        it runs).
    n : int
        Ticks to hold.

    Attributes
    ----------
    names : tuple of str
        Path of every node, in tree order (:func:`tree_nodes`).
    depths : numpy.ndarray
        Depth of every node (root 0).
    changed : bool
        Whether the last :meth:`record` saw a status change (for loggers that show changes).
    """

    def __init__(self, root: py_trees.behaviour.Behaviour, n: int) -> None:
        nodes = tree_nodes(root)
        self._nodes = tuple(node for node, _, _ in nodes)
        self.names = tuple(path for _, path, _ in nodes)
        self.depths = np.array([depth for _, _, depth in nodes], dtype=np.int16)
        self._rows = np.zeros((n, len(self._nodes)), dtype=np.uint8)
        self._changed_at = np.zeros(n, dtype=bool)
        self._last: tuple | None = None
        self._last_change = 0
        self.changed = False
        self.n = 0

    def record(self, k: int) -> bool:
        """Record the statuses the nodes have now as tick ``k``; returns whether any changed
        since the last tick recorded."""
        statuses = tuple(map(_status, self._nodes))
        changed = statuses != self._last
        if changed:
            self._last = statuses
            self._rows[k] = [STATUS_CODES[s] for s in statuses]
            self._changed_at[k] = True
            self._last_change = k
        self.changed = changed
        self.n = k + 1
        return changed

    @property
    def current(self) -> np.ndarray:
        """The status codes of the last tick recorded, one per node (a view: copy to keep)."""
        return self._rows[self._last_change]

    def arrays(self) -> dict[str, np.ndarray]:
        """``node_names`` (str, nodes), ``node_depth`` (int16, nodes) and ``node_status``
        (uint8, ticks × nodes) of the ticks recorded so far."""
        n = self.n
        index = np.where(self._changed_at[:n], np.arange(n), 0)
        np.maximum.accumulate(index, out=index)
        return {"node_names": np.array(self.names, dtype=str), "node_depth": self.depths.copy(),
                "node_status": self._rows[index]}


def status_changes(previous: np.ndarray | None, current: np.ndarray, names) -> list[str]:
    """Lines ``"path: old → new"`` for every node whose code differs between two rows (all
    nodes, from ``invalid``, when ``previous`` is None)."""
    if previous is None:
        previous = np.zeros_like(current)
    return [f"{names[i]}: {STATUS_NAMES[previous[i]]} → {STATUS_NAMES[current[i]]}"
            for i in np.flatnonzero(previous != current)]
