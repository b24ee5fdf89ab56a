"""What the tests of the scan's planner and its end-of-surface leaves share: a touched disc of
contact points, and ticking a leaf until it finishes."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from tactile_bt.testing import make_features


def disc(radius: float, centre=(0.0, 0.0), z: float = 0.05, step: float = 0.001, normal=(0.0, 0.0, 1.0)):
    """Contact points (m) on a grid of ``step`` filling a disc of ``radius`` at height ``z``, and
    their normals (all ``normal``, made unit)."""
    g = np.arange(-radius, radius + 1e-9, step)
    X, Y = np.meshgrid(g, g)
    keep = X**2 + Y**2 <= radius**2
    pts = np.column_stack((X[keep] + centre[0], Y[keep] + centre[1], np.full(keep.sum(), z)))
    return pts, np.tile(np.asarray(normal, float) / np.linalg.norm(normal), (len(pts), 1))


def ticks_until_done(h, n, **features):
    """Tick the harness ``h`` up to ``n`` times with ``make_features(**features)``; the number of
    ticks until the leaf finished and its status (``(n, RUNNING)`` when it did not)."""
    for k in range(1, n + 1):
        status = h.tick(make_features(**features))
        if status != Status.RUNNING:
            return k, status
    return n, Status.RUNNING
