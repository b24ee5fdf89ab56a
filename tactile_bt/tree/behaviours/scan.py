"""Leaves for surface scans (paper Sec. V-E): a world-frame guidance direction for stripes, and
the conditions that end a stripe or a whole scan.

``scan_direction`` writes the guidance twist to a blackboard key for ``guided_slide`` (with
``twist_key``) to add: the world direction of the stripe, projected onto the pad's tangent plane
and expressed in the sensor frame, so stripes stay straight in the world however the pad rolls
or turns. ``stripe_end`` succeeds (or fails, for the steps between stripes) when a stripe has
reached the end of the surface: the contact point stalls or jumps, the contact shrinks at an
edge, the pad tilts past a limit or turns over an edge. ``coverage_stalled`` succeeds when the
contact cloud has stopped growing. All of them read the mission clock, never wall time.

Layer: tree.
"""

from __future__ import annotations

import collections
import math
from typing import Literal, Sequence

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.tree.behaviours.base import TactileBehaviour, norm
from tactile_bt.tree.blackboard import FEATURES_RAW, POSE, TIME, read, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between, normalise_key

__all__ = ["ScanDirection", "StripeEnd", "CoverageStalled", "tangent_guidance"]

#: A stripe that starts beyond the tilt limit ends once it has tilted this much (rad) beyond the
#: least tilt it had.
_TILT_MARGIN_RAD = math.radians(5.0)


def _unit(name: str, value, what: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v) > 0:
        raise ValueError(f"{name}: {what} must be a non-zero [x, y, z], got {value!r}")
    return v / np.linalg.norm(v)


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
            self.direction = _unit(self.name, self.direction, "direction")
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


class StripeEnd(TactileBehaviour):
    """SUCCESS (or FAILURE, with ``result: failure``) when a stripe has come to the end of the
    surface: the contact point stalls or jumps, the contact shrinks at an edge, the pad tilts
    past a limit or turns over an edge; RUNNING before.

    The end is one of: the contact point (``T_gs · cop``) has moved less than ``min_travel_m``
    in the last ``window_s`` of mission time (the pad is stuck at an edge or against a wall);
    the contact area has stayed below ``min_area_ratio`` times the largest area of this stripe
    for ``window_s / 5`` (the pad has run half over an edge, so its imprint reaches the edge
    while it still lies flat); the pad's outward normal (−z of the sensor frame) is more than
    ``max_tilt_rad`` away from ``up`` (it has rolled over the part of the object the scan is
    for, and it tilts further: a stripe that starts beyond the limit, on the object's side after
    the previous stripe, ends once it has tilted 5° more than the least tilt it has had, or if it
    has not come back within the limit after ``window_s``); the pad normal has turned more than
    ``max_turn_rad`` since the stripe started (it has rolled over an edge); within ``window_s``
    the pad normal has turned more than ``edge_turn_rad``, tilting away from ``up``, while the
    contact point moved, in the direction of the turn, less than ``edge_radius_m`` times the
    angle (it rolls over an edge: on a surface curved with radius R the contact moves R·θ as the
    pad turns by θ);
    the contact point has travelled ``max_travel_m``; the contact point has jumped more than
    ``max_jump_m`` from one cycle to the next (the largest contact region is now another object,
    such as the table under a tilted pad). The feedback message says which.
    """

    uses = frozenset({"cop"})
    window_s = Parameter(1.0, bound=NON_NEGATIVE, doc="Time window of the stall test (s; 0 = no stall test).")
    min_travel_m = Parameter(0.004, bound=NON_NEGATIVE, doc="Least travel of the contact point within ``window_s`` (m).")
    max_tilt_rad = Parameter(0.0, bound=between(0, math.pi),
                             doc="Largest angle between the outward normal and ``up`` (rad; 0 = no tilt test).")
    up = Parameter((0.0, 0.0, 1.0), type=Sequence[float], unit=None,
                   doc="World direction the tilt is measured from (default: up, +z).")
    max_travel_m = Parameter(0.0, bound=NON_NEGATIVE,
                             doc="Travel of the contact point after which the stripe ends (m; 0 = unlimited).")
    min_area_ratio = Parameter(0.0, bound=between(0, 1, high_open=True), unit=None,
                               doc="Contact area, as a fraction of the stripe's largest, below which the stripe ends "
                                   "(0 = no area test).")
    max_jump_m = Parameter(0.0, bound=NON_NEGATIVE,
                           doc="Largest move of the contact point from one cycle to the next (m; 0 = no jump test).")
    max_turn_rad = Parameter(0.0, bound=between(0, math.pi),
                             doc="Largest turn of the pad normal from its direction at the start of the stripe (rad; "
                                 "0 = no turn test): a short step that rolls the pad over an edge ends here.")
    edge_turn_rad = Parameter(0.0, bound=between(0, math.pi),
                              doc="Least turn of the pad normal within ``window_s`` that the edge test judges (rad; "
                                  "0 = no edge test).")
    edge_radius_m = Parameter(0.01, bound=NON_NEGATIVE, doc="A turn at a radius of curvature below this is an edge (m).")
    result = Parameter("success", type=Literal["success", "failure"], fixed=True,
                       doc="Status at the end of the surface: ``success`` ends the stripe; ``failure`` fails it, so "
                           "that a step between stripes which finds no more surface stops a ``repeat`` of stripes "
                           "(catch it with a ``selector``).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self._max_area = 0
        self._small_since: float | None = None
        self._min_cos = -2.0
        self._normal0: np.ndarray | None = None
        self._history: collections.deque = collections.deque()
        self._start = 0.0
        self.travelled = 0.0
        self._last: np.ndarray | None = None
        #: What ended the stripe: "stall", "jump", "shrink", "tilt", "turn", "edge" or "travel"
        #: ("" while it runs).
        self.cause = ""

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if "up" in changed:
            self.up = _unit(self.name, self.up, "up")
        if "result" in changed:
            self._end = Status.SUCCESS if self.result == "success" else Status.FAILURE
        self._cos_tilt = math.cos(self.max_tilt_rad) if self.max_tilt_rad > 0 else -2.0
        self._cos_turn = math.cos(self.max_turn_rad)
        self._cos_edge = math.cos(self.edge_turn_rad)

    def initialise(self) -> None:
        self.cause = ""
        self._history.clear()
        self._start = self.now
        self.travelled = 0.0
        self._last = None
        self._max_area = 0
        self._small_since = None
        self._min_cos = -2.0  # cosine of the least tilt of this stripe
        self._normal0 = None  # pad normal at the start

    def update(self) -> Status:
        T = read(POSE)
        now = read(TIME)
        normal = T[:3, 2]
        if self.max_tilt_rad > 0:
            cos_tilt = -float(normal @ self.up)
            if cos_tilt > self._min_cos:
                self._min_cos = cos_tilt
            if cos_tilt < self._cos_tilt:
                tilt = math.acos(max(-1.0, min(1.0, cos_tilt)))
                limit = f"(limit {math.degrees(self.max_tilt_rad):.0f}°)"
                if tilt > math.acos(min(1.0, self._min_cos)) + _TILT_MARGIN_RAD:
                    self.feedback_message = f"tilted {math.degrees(tilt):.0f}° {limit}"
                    self.cause = "tilt"
                    return self._end
                if self._min_cos < self._cos_tilt and 0 < self.window_s <= now - self._start:
                    self.feedback_message = f"stayed beyond the tilt limit for {self.window_s:g} s {limit}"
                    self.cause = "tilt"
                    return self._end
        if self.max_turn_rad > 0:
            if self._normal0 is None:
                self._normal0 = normal.copy()
            elif float(normal @ self._normal0) < self._cos_turn:
                turn = math.degrees(math.acos(max(-1.0, min(1.0, float(normal @ self._normal0)))))
                self.feedback_message = f"turned {turn:.0f}° over an edge (limit {math.degrees(self.max_turn_rad):.0f}°)"
                self.cause = "turn"
                return self._end
        f = read(FEATURES_RAW)
        if f.in_contact:
            x, y = f.cop_xy
            (r00, r01, _, t0), (r10, r11, _, t1), (r20, r21, _, t2) = T[:3].tolist()
            point = np.array((r00 * x + r01 * y + t0, r10 * x + r11 * y + t1, r20 * x + r21 * y + t2))
            if self._last is not None:
                step = norm(point - self._last)
                if 0 < self.max_jump_m < step:
                    self.feedback_message = (f"contact jumped {step * 1e3:.0f} mm after "
                                             f"{self.travelled * 1e3:.0f} mm")
                    self.cause = "jump"
                    return self._end
                self.travelled += step
            self._last = point
            self._history.append((now, point, normal.copy()))
            if self.edge_turn_rad > 0:
                edge = self._edge(point, normal)
                if edge:
                    self.feedback_message = edge
                    self.cause = "edge"
                    return self._end
            if self.min_area_ratio > 0:
                area = f.area
                if area > self._max_area:
                    self._max_area = area
                if area < self.min_area_ratio * self._max_area:
                    if self._small_since is None:
                        self._small_since = now
                    elif now - self._small_since >= 0.2 * self.window_s:
                        self.feedback_message = (f"contact shrank to {area} of {self._max_area} tactels "
                                                 f"after {self.travelled * 1e3:.0f} mm")
                        self.cause = "shrink"
                        return self._end
                else:
                    self._small_since = None
        if self.max_travel_m > 0 and self.travelled >= self.max_travel_m:
            self.feedback_message = f"travelled {self.travelled * 1e3:.0f} mm"
            self.cause = "travel"
            return self._end
        if self.window_s > 0:
            history = self._history
            while len(history) > 1 and history[1][0] <= now - self.window_s:
                history.popleft()
            if history and now - self._start >= self.window_s and history[0][0] <= now - self.window_s + 1e-9:
                moved = norm(history[-1][1] - history[0][1])
                if moved < self.min_travel_m:
                    self.feedback_message = (f"stalled: {moved * 1e3:.1f} mm in {self.window_s:g} s "
                                             f"after {self.travelled * 1e3:.0f} mm")
                    self.cause = "stall"
                    return self._end
        self._feedback = None
        return Status.RUNNING

    def describe(self) -> str:
        """Travel of the contact point so far."""
        return f"{self.travelled * 1e3:.0f} mm"

    def _edge(self, point: np.ndarray, normal: np.ndarray) -> str:
        """Why the pad is rolling over an edge, judged against a few earlier samples of the
        window (the oldest, the middle one, the one at three quarters), or ""."""
        history = self._history
        n = len(history)
        for i in {0, n // 2, (3 * n) // 4}:
            _, p0, n0 = history[i]
            cos_turn = float(normal @ n0)
            if cos_turn >= self._cos_edge:
                continue
            turn = math.acos(max(-1.0, min(1.0, cos_turn)))
            # only a turn away from ``up``: rolling back from an edge onto the face is no end
            up = self.up
            if math.acos(max(-1.0, min(1.0, -float(normal @ up)))) - math.acos(max(-1.0, min(1.0, -float(n0 @ up)))) \
                    < 0.5 * turn:
                continue
            # the way the normal turned is the way the contact moves on a curved surface
            d = normal - n0
            across = abs(float((point - p0) @ d)) / float(np.linalg.norm(d))
            if across < self.edge_radius_m * turn:
                return (f"rolling over an edge: turned {math.degrees(turn):.0f}° while the contact moved "
                        f"{across * 1e3:.1f} mm that way, after {self.travelled * 1e3:.0f} mm")
        return ""


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
    #: Its SUCCESS ends a scan: the mission reports its message as the reason.
    reports_success = True
    _start = 0.0
    _size = 0

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
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
                self.feedback_message = f"coverage stalled: {grown} new samples in {self.window_s:g} s ({size} in all)"
                return Status.SUCCESS
        self._size = size
        self._feedback = None
        return Status.RUNNING

    def describe(self) -> str:
        """Samples in the cloud at the last tick."""
        return f"{self._size} samples"
