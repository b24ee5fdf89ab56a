"""Leaves for surface scans (paper Sec. V-E): a world-frame guidance direction for stripes, and
the condition that ends a whole scan.

``scan_direction`` writes the guidance twist to a blackboard key for ``guided_slide`` (with
``twist_key``) to add: the world direction of the stripe, projected onto the pad's tangent plane
and expressed in the sensor frame, so stripes stay straight in the world however the pad rolls
or turns. ``coverage_stalled`` succeeds when the contact cloud has stopped growing (or fails,
when a frontier planner has left frontier it cannot explain; it waits while the planner has a
border sweep due). The end of a stripe is told by
the condition leaves of :mod:`tactile_bt.tree.behaviours.surface_end`. All of them read the
mission clock, never wall time.

Layer: tree.
"""

from __future__ import annotations

import collections
import math
from typing import Sequence

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.contacts.frontier_map import describe_left
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.surface_end import unit_vector
from tactile_bt.tree.blackboard import POSE, read, read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between, normalise_key

__all__ = ["ScanDirection", "CoverageStalled", "tangent_guidance"]

def tangent_guidance(pose: np.ndarray, direction: np.ndarray, speed_mps: float) -> np.ndarray:
    """The sensor-frame guidance twist ``[vx, vy, 0, 0, 0, 0]`` (m/s) that slides the pad at
    ``pose`` (``T_gs``) along the world ``direction`` (unit vector): the direction projected onto
    the pad's tangent plane, at ``speed_mps``; zero when the direction is along the pad normal."""
    R = pose[:3, :3]
    x, y, _ = (R.T @ direction).tolist()  # the direction in the sensor frame
    tangential = math.hypot(x, y)
    if tangential > 1e-3:  # not along the pad normal
        return np.array((speed_mps * x / tangential, speed_mps * y / tangential, 0.0, 0.0, 0.0, 0.0))
    return np.zeros(6)


class ScanDirection(TactileBehaviour):
    """Write the guidance twist that slides the pad along a world direction to ``key``, every
    tick, for ``guided_slide: {twist_key: ...}``. The direction is projected onto the pad's
    tangent plane (the plane of the sensor's x and y axes) and expressed in the sensor frame:
    ``V_ext = [vx, vy, 0, 0, 0, 0]`` with speed ``speed_mps``. RUNNING; it never finishes.
    """

    direction = Parameter((1.0, 0.0, 0.0), type=Sequence[float], unit=None,
                          doc="World direction ``[x, y, z]`` of the stripe (any length; normalised).")
    speed_mps = Parameter(0.02, bound=POSITIVE, doc="Sliding speed (m/s, > 0).")
    key = Parameter("/scan/guidance", fixed=True,
                    doc="Blackboard key the twist is written to (m/s and rad/s, sensor frame).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self._writer = self.attach_blackboard_client(name=f"{self.name}/guidance")
        self._writer.register_key(key=self.key, access=Access.WRITE)
        self.twist = np.zeros(6)

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if "direction" in changed:
            self.direction = unit_vector(self.name, self.direction, "direction")
        if "key" in changed:
            self.key = normalise_key(self.key)

    def guidance(self, pose: np.ndarray) -> np.ndarray:
        """The sensor-frame twist (m/s) for the pad at ``pose`` (``T_gs``)."""
        return tangent_guidance(pose, self.direction, self.speed_mps)

    def initialise(self) -> None:
        write(self.key, self.guidance(read(POSE)))

    def update(self) -> Status:
        self.twist = self.guidance(read(POSE))
        write(self.key, self.twist)
        return Status.RUNNING


class CoverageStalled(TactileBehaviour):
    """SUCCESS once the mission's contact cloud has stopped growing: fewer than ``min_growth``
    times its size in new samples within the last ``window_s`` of mission time; RUNNING before.
    With voxel thinning (``record_contacts: {voxel_m: ...}``) the cloud's size is a measure of
    the area covered, so this ends a scan that only passes over places it has already touched.
    """

    window_s = Parameter(10.0, bound=POSITIVE,
                         doc="Time window (s, > 0); the leaf cannot succeed before it has run this long.")
    min_growth = Parameter(0.02, bound=NON_NEGATIVE, unit=None,
                           doc="Least relative growth of the cloud within the window (0.02 = 2 %).")
    min_samples = Parameter(100, bound=NON_NEGATIVE, unit=None,
                            doc="The cloud must hold at least this many samples before the test applies.")
    frontier_key = Parameter("", fixed=True,
                             doc="Blackboard key of a frontier planner's frontier left (``frontier_guidance`` writes "
                                 "``/scan/frontier_left``: lengths in m by reason, ``explained`` and ``unexplained``). "
                                 "With it, a stalled coverage that leaves more than ``max_unexplained_m`` of the "
                                 "frontier unexplained is a FAILURE that names it, not a SUCCESS; and while the "
                                 "planner has a border sweep due before the scan may end (``sweep_due``: the band the "
                                 "table left at the foot of plane faces is worth sweeping), the leaf stays RUNNING "
                                 "instead of succeeding. Empty: no such test.")
    max_unexplained_m = Parameter(0.01, bound=NON_NEGATIVE, doc="See ``frontier_key`` (m).")
    min_coverage = Parameter(0.0, bound=between(0, 1), unit=None,
                             doc="With ``frontier_key``, a stalled coverage whose planner estimates a lower "
                                 "coverage (``estimated_coverage``) is a FAILURE too (0 = no such test).")
    #: Its SUCCESS ends a scan: the mission reports its message as the reason.
    reports_success = True
    _start = 0.0
    _size = 0

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        if self.frontier_key:
            self.frontier_key = normalise_key(self.frontier_key)
            self._frontier = self.attach_blackboard_client(name=f"{self.name}/frontier")
            self._frontier.register_key(key=self.frontier_key, access=Access.READ)
        self._history: collections.deque = collections.deque()

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        self.contacts = self.bb.contacts

    def initialise(self) -> None:
        self._history.clear()
        self._start = self.now

    def update(self) -> Status:
        now, size = self.now, len(self.contacts)
        history = self._history
        history.append((now, size))
        while len(history) > 1 and history[1][0] <= now - self.window_s:
            history.popleft()
        if now - self._start >= self.window_s and size >= self.min_samples:
            grown = size - history[0][1]
            if grown < self.min_growth * size:
                stalled = f"coverage stalled: {grown} new samples in {self.window_s:g} s ({size} in all)"
                left = read_or(self.frontier_key) if self.frontier_key else None
                if left is not None:
                    if (sum(left.get("unexplained", {}).values()) > self.max_unexplained_m
                            or left.get("estimated_coverage", 1.0) < self.min_coverage):
                        self.feedback_message = f"{stalled}, with {describe_left(left)}"
                        return Status.FAILURE
                    if left.get("sweep_due"):  # the planner sweeps the foot before it would end the scan
                        self.feedback_message = f"{stalled}, but a border sweep is due first"
                        self._size = size
                        return Status.RUNNING
                    stalled = f"{stalled}; frontier left: {describe_left(left)}"
                self.feedback_message = stalled
                return Status.SUCCESS
        self._size = size
        self._feedback = None
        return Status.RUNNING

    def describe(self) -> str:
        """Samples in the cloud at the last tick."""
        return f"{self._size} samples"
