"""Condition leaves for the end of the surface under a sliding pad, one sign each.

A stripe of a scan (paper Sec. V-E), or an attempt of the frontier planner to reach a frontier,
ends at the end of the surface. Each leaf here tests one sign of it and SUCCEEDS (or FAILS, with
``result: failure``) when it holds, RUNNING before; a tree composes the signs it wants, e.g. in
a ``parallel`` with ``policy: success_on_one`` (the ``stripe_end`` subtree of
trees/surface_scan_stripes.yaml):

- ``tilt_limit``: the pad is tilted more than ``max_tilt_rad`` from ``up`` and tilting further;
- ``pad_turned``: the pad normal has turned ``max_turn_rad`` since the start;
- ``contact_jumped``: the contact point jumped more than ``max_jump_m`` in one cycle (onto the
  table under a tilted pad);
- ``rolling_over_edge``: the pad turned at a radius of curvature below ``edge_radius_m``;
- ``contact_shrank``: the contact area fell below ``min_area_ratio`` of its largest (the pad has
  run half over an edge);
- ``travelled``: the contact point has travelled ``max_travel_m``;
- ``contact_stalled``: the contact point moved less than ``min_travel_m`` in ``window_s``;
- ``contact_bridged``: the pad has borne two contacts apart for ``window_s`` (a flat pad bridging
  a hollow narrower than itself).

With ``end_key`` set, a leaf serves a planner instead of a composite: when its sign holds it
writes ``{"attempt", "cause", "message", "point"}`` and what else it learnt
(:meth:`SurfaceEnd.evidence`) to that key (unless an end of the same attempt is there already)
and stays RUNNING, and it starts over whenever the attempt number on ``attempt_key`` changes
(``frontier_guidance`` writes it). Every leaf keeps its ``cause`` ("tilt", "turn", "jump",
"edge", "shrink", "travel", "stall", "bridge"): the planner's bookkeeping of the frontier left. All of them read the mission clock, never wall time.

Layer: tree.
"""

from __future__ import annotations

import collections
import math
from typing import Literal, Sequence

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.control.spatial import pad_point
from tactile_bt.tree.behaviours.base import TactileBehaviour, norm
from tactile_bt.tree.behaviours.table import table_height
from tactile_bt.tree.blackboard import FEATURES_RAW, POSE, TIME, read, read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between, normalise_key

__all__ = ["bridge_ends", "SurfaceEnd", "TiltLimit", "PadTurned", "ContactJumped", "RollingOverEdge", "ContactShrank", "Travelled",
           "ContactStalled", "ContactBridged", "ATTEMPT_KEY", "ATTEMPT_END_KEY", "unit_vector"]

#: Blackboard key of the planner's attempt number, and of the end of its current attempt.
ATTEMPT_KEY = "/scan/attempt"
ATTEMPT_END_KEY = "/scan/attempt_end"
#: A stripe that starts beyond the tilt limit ends once it has tilted this much (rad) beyond the
#: least tilt it had.
_TILT_MARGIN_RAD = math.radians(5.0)


def unit_vector(name: str, value, what: str) -> np.ndarray:
    """``value`` as a unit 3-vector; ValueError naming ``name`` and ``what`` if it is none."""
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v) > 0:
        raise ValueError(f"{name}: {what} must be a non-zero [x, y, z], got {value!r}")
    return v / np.linalg.norm(v)


def _angle(cos: float) -> float:
    return math.acos(max(-1.0, min(1.0, cos)))


class SurfaceEnd(TactileBehaviour):
    """Base of the end-of-surface conditions: the pad's pose and the contact point (world,
    ``T_gs · cop``) every tick, the contact's travel and a ``window_s`` history of
    ``(time, point, normal)``; :meth:`check` says whether the sign holds. See the module
    docstring for ``end_key`` and ``attempt_key``."""

    uses = frozenset({"cop"})
    #: What the end is called in the planner's bookkeeping.
    cause = ""
    #: Length (s) of the history kept (0: none).
    history_s = 0.0
    up = Parameter((0.0, 0.0, 1.0), type=Sequence[float], unit=None,
                   doc="World direction the tilt is measured from (default: up, +z).")
    result = Parameter("success", type=Literal["success", "failure"], fixed=True,
                       doc="Status at the end of the surface: ``success`` ends the stripe; ``failure`` fails it, so "
                           "that a step between stripes which finds no more surface stops a ``repeat`` of stripes "
                           "(catch it with a ``selector``).")
    end_key = Parameter("", fixed=True,
                        doc="Blackboard key the end is written to, for a planner; the leaf then stays RUNNING "
                            "(empty: the leaf ends instead).")
    attempt_key = Parameter(ATTEMPT_KEY, fixed=True,
                            doc="With ``end_key``: blackboard key of the planner's attempt number; the leaf starts "
                                "over when it changes.")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self._history: collections.deque = collections.deque()
        self._start = 0.0
        self.travelled = 0.0
        self._last: np.ndarray | None = None
        self._attempt = None
        if self.end_key:
            self.end_key = normalise_key(self.end_key)
            self.attempt_key = normalise_key(self.attempt_key)
            self._planner = self.attach_blackboard_client(name=f"{self.name}/planner")
            self._planner.register_key(key=self.end_key, access=Access.WRITE)
            self._planner.register_key(key=self.attempt_key, access=Access.READ)

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if "up" in changed:
            self.up = unit_vector(self.name, self.up, "up")
        if "result" in changed:
            self._end = Status.SUCCESS if self.result == "success" else Status.FAILURE

    def initialise(self) -> None:
        self._history.clear()
        self._start = self.now
        self.travelled = 0.0
        self._last = None
        self.restart()

    def restart(self) -> None:
        """Start the sign's own state over (with the common state of :meth:`initialise`)."""

    def update(self) -> Status:
        if self.end_key:
            attempt = read_or(self.attempt_key)
            if attempt != self._attempt:
                self._attempt = attempt
                self.initialise()
        T = read(POSE)
        now = read(TIME)
        normal = T[:3, 2]
        f = read(FEATURES_RAW)
        point = None
        if f.in_contact:
            point = pad_point(T, *f.cop_xy)
        why = self.check(now, normal, point, f)
        if point is not None and not why:
            if self._last is not None:
                self.travelled += norm(point - self._last)
            self._last = point
            if self.history_s > 0:
                history = self._history
                history.append((now, point, normal.copy()))
                while len(history) > 1 and history[1][0] <= now - self.history_s:
                    history.popleft()
        if not why:
            self._feedback = None
            return Status.RUNNING
        self.feedback_message = why
        if not self.end_key:
            return self._end
        end = read_or(self.end_key)
        if end is None or end.get("attempt") != self._attempt:
            write(self.end_key, {"attempt": self._attempt, "cause": self.cause, "message": why, "point": point,
                                 **self.evidence(T, f)})
        return Status.RUNNING

    def evidence(self, pose: np.ndarray, features) -> dict:
        """What the planner may learn from this end besides its cause, written with it (a
        dict; none by default)."""
        return {}

    def check(self, now: float, normal: np.ndarray, point: np.ndarray | None, features) -> str:
        """Why the surface ends here ("" while it goes on): ``now`` (s), the pad normal (world,
        +z of the sensor frame), the contact point (world, m; None out of contact) and the raw
        features of this cycle."""
        raise NotImplementedError

    def describe(self) -> str:
        """Travel of the contact point so far."""
        return f"{self.travelled * 1e3:.0f} mm"


class TiltLimit(SurfaceEnd):
    """The pad's outward normal (−z of the sensor frame) is more than ``max_tilt_rad`` away from
    ``up``, and tilting further: a pad that starts beyond the limit (on the object's side after
    the previous stripe) ends once it has tilted 5° more than the least tilt it has had, or if it
    has not come back within the limit after ``window_s``."""

    cause = "tilt"
    max_tilt_rad = Parameter(math.radians(70.0), bound=between(0, math.pi),
                             doc="Largest angle between the outward normal and ``up`` (rad; 0 = no limit).")
    window_s = Parameter(1.0, bound=NON_NEGATIVE,
                         doc="Time a pad that starts beyond the limit has to come back within it (s; 0 = any).")

    def restart(self) -> None:
        self._min_cos = -2.0  # cosine of the least tilt since the start

    def check(self, now, normal, point, features) -> str:
        if not self.max_tilt_rad > 0:
            return ""
        cos_tilt = -float(normal @ self.up)
        self._min_cos = max(self._min_cos, cos_tilt)
        if cos_tilt >= math.cos(self.max_tilt_rad):
            return ""
        tilt = _angle(cos_tilt)
        limit = f"(limit {math.degrees(self.max_tilt_rad):.0f}°)"
        if tilt > _angle(self._min_cos) + _TILT_MARGIN_RAD:
            return f"tilted {math.degrees(tilt):.0f}° {limit}"
        if self._min_cos < math.cos(self.max_tilt_rad) and 0 < self.window_s <= now - self._start:
            return f"stayed beyond the tilt limit for {self.window_s:g} s {limit}"
        return ""


class PadTurned(SurfaceEnd):
    """The pad normal has turned more than ``max_turn_rad`` since the start (a short step has
    rolled the pad over an edge)."""

    cause = "turn"
    max_turn_rad = Parameter(math.radians(45.0), bound=between(0, math.pi),
                             doc="Largest turn of the pad normal from its direction at the start (rad; 0 = no limit).")

    def restart(self) -> None:
        self._normal0: np.ndarray | None = None

    def check(self, now, normal, point, features) -> str:
        if not self.max_turn_rad > 0:
            return ""
        if self._normal0 is None:
            self._normal0 = normal.copy()
            return ""
        cos_turn = float(normal @ self._normal0)
        if cos_turn >= math.cos(self.max_turn_rad):
            return ""
        return (f"turned {math.degrees(_angle(cos_turn)):.0f}° over an edge "
                f"(limit {math.degrees(self.max_turn_rad):.0f}°)")


class ContactJumped(SurfaceEnd):
    """The contact point has jumped more than ``max_jump_m`` from one cycle to the next: the
    largest contact region is now another object, such as the table under a tilted pad. With
    the table's height known (``table_key``), only a jump to within ``table_clearance_m`` of the
    table counts: a soft, lumpy object's contact may jump between its parts."""

    cause = "jump"
    max_jump_m = Parameter(0.01, bound=NON_NEGATIVE, doc="Largest move of the contact point in one cycle (m).")
    table_key = Parameter("", fixed=True,
                          doc="Blackboard key of the table's height (m, world z; ``/setup/table_z_m`` as the mission "
                              "writes it; empty, absent or NaN: every jump counts).")
    table_clearance_m = Parameter(0.003, bound=NON_NEGATIVE,
                                  doc="With the table known, a jump to a point higher than this above it is no end "
                                      "(m).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self._table_z = math.nan
        if self.table_key:
            self.table_key = normalise_key(self.table_key)
            self._setup = self.attach_blackboard_client(name=f"{self.name}/setup")
            self._setup.register_key(key=self.table_key, access=Access.READ)

    def restart(self) -> None:
        if self.table_key:
            self._table_z = table_height(self._setup, self.table_key)

    def check(self, now, normal, point, features) -> str:
        if point is None or self._last is None:
            return ""
        step = norm(point - self._last)
        if not 0 < self.max_jump_m < step:
            return ""
        if math.isfinite(self._table_z) and point[2] > self._table_z + self.table_clearance_m:
            return ""  # not onto the table: another part of the same contact
        return f"contact jumped {step * 1e3:.0f} mm after {self.travelled * 1e3:.0f} mm"


class RollingOverEdge(SurfaceEnd):
    """Within ``window_s`` the pad normal has turned more than ``edge_turn_rad``, tilting away
    from ``up``, while the contact point moved, in the direction of the turn, less than
    ``edge_radius_m`` times the angle: it rolls over an edge (on a surface curved with radius R
    the contact moves R·θ as the pad turns by θ)."""

    cause = "edge"
    edge_turn_rad = Parameter(math.radians(10.0), bound=between(0, math.pi),
                              doc="Least turn of the pad normal within ``window_s`` that the test judges (rad; 0 = "
                                  "no edge test).")
    edge_radius_m = Parameter(0.01, bound=NON_NEGATIVE, doc="A turn at a radius of curvature below this is an edge (m).")
    window_s = Parameter(1.0, bound=NON_NEGATIVE, doc="Time window of the turn (s).")

    def parameters_changed(self, changed: frozenset[str]) -> None:
        super().parameters_changed(changed)
        self.history_s = self.window_s

    def check(self, now, normal, point, features) -> str:
        """Judged against a few earlier samples of the window (the oldest, the middle one, the
        one at three quarters)."""
        history = self._history
        n = len(history)
        if point is None or not n or not self.edge_turn_rad > 0:
            return ""
        for i in {0, n // 2, (3 * n) // 4}:
            _, p0, n0 = history[i]
            cos_turn = float(normal @ n0)
            if cos_turn >= math.cos(self.edge_turn_rad):
                continue
            turn = _angle(cos_turn)
            # only a turn away from ``up``: rolling back from an edge onto the face is no end
            if _angle(-float(normal @ self.up)) - _angle(-float(n0 @ self.up)) < 0.5 * turn:
                continue
            # the way the normal turned is the way the contact moves on a curved surface
            d = normal - n0
            across = abs(float((point - p0) @ d)) / float(np.linalg.norm(d))
            if across < self.edge_radius_m * turn:
                return (f"rolling over an edge: turned {math.degrees(turn):.0f}° while the contact moved "
                        f"{across * 1e3:.1f} mm that way, after {self.travelled * 1e3:.0f} mm")
        return ""


class ContactShrank(SurfaceEnd):
    """The contact area has stayed below ``min_area_ratio`` times its largest since the start
    for ``window_s / 5``: the pad has run half over an edge, so its imprint reaches the edge
    while it still lies flat."""

    cause = "shrink"
    min_area_ratio = Parameter(0.5, bound=between(0, 1, high_open=True), unit=None,
                               doc="Fraction of the largest contact area below which the contact has shrunk (0 = "
                                   "no area test).")
    window_s = Parameter(1.0, bound=NON_NEGATIVE, doc="Five times the time the contact must stay small (s).")

    def restart(self) -> None:
        self._max_area = 0
        self._small_since: float | None = None

    def check(self, now, normal, point, features) -> str:
        if point is None or not self.min_area_ratio > 0:
            return ""
        area = features.area
        self._max_area = max(self._max_area, area)
        if area >= self.min_area_ratio * self._max_area:
            self._small_since = None
            return ""
        if self._small_since is None:
            self._small_since = now
        elif now - self._small_since >= 0.2 * self.window_s:
            return f"contact shrank to {area} of {self._max_area} tactels after {self.travelled * 1e3:.0f} mm"
        return ""


class Travelled(SurfaceEnd):
    """The contact point has travelled ``max_travel_m`` since the start."""

    cause = "travel"
    max_travel_m = Parameter(0.05, bound=NON_NEGATIVE,
                             doc="Travel of the contact point after which the surface ends (m; 0 = unlimited).")

    def check(self, now, normal, point, features) -> str:
        if self.max_travel_m > 0 and point is not None and self._last is not None and self.travelled + norm(point - self._last) >= self.max_travel_m:
            return f"travelled {(self.travelled + norm(point - self._last)) * 1e3:.0f} mm"
        return ""


class ContactStalled(SurfaceEnd):
    """The contact point has moved less than ``min_travel_m`` in the last ``window_s`` of
    mission time (the pad is stuck at an edge or against a wall) while the pad has not turned
    more than ``rolling_turn_rad`` tilting away from ``up`` (rolling over an edge, it goes on
    until the tilt limit or the surface beyond ends it)."""

    cause = "stall"
    window_s = Parameter(1.0, bound=POSITIVE, doc="Time window of the stall test (s).")
    min_travel_m = Parameter(0.004, bound=NON_NEGATIVE, doc="Least travel of the contact point within ``window_s`` (m).")
    rolling_turn_rad = Parameter(0.0, bound=between(0, math.pi),
                                 doc="No stall while the pad normal has turned more than this within ``window_s``, "
                                     "tilting away from ``up`` (rad; 0 = off).")

    def parameters_changed(self, changed: frozenset[str]) -> None:
        super().parameters_changed(changed)
        self.history_s = self.window_s

    def check(self, now, normal, point, features) -> str:
        history = self._history
        if point is None or not history or now - self._start < self.window_s:
            return ""
        # the window's oldest sample, as of this cycle's
        k = 0
        while k + 1 < len(history) and history[k + 1][0] <= now - self.window_s:
            k += 1
        t0, p0, n0 = history[k]
        if t0 > now - self.window_s + 1e-9:
            return ""
        moved = norm(point - p0)
        if moved >= self.min_travel_m or self._rolling(n0, normal):
            return ""
        return f"stalled: {moved * 1e3:.1f} mm in {self.window_s:g} s after {self.travelled * 1e3:.0f} mm"

    def _rolling(self, before: np.ndarray, normal: np.ndarray) -> bool:
        if not self.rolling_turn_rad > 0:
            return False
        turn = _angle(float(normal @ before))
        return turn > self.rolling_turn_rad and -float(normal @ self.up) < -float(before @ self.up)


class ContactBridged(SurfaceEnd):
    """The pad has borne two separate contacts, the smaller carrying at least ``min_share`` of
    the load, for ``window_s`` (gaps in it up to ``gap_s`` do not count): a flat pad bridging a
    hollow narrower than itself (a groove, the hole of a ring) rests on its rims and cannot lie
    on what lies between them. Sliding on, it rocks from one rim to the other while the largest
    region changes sides, so that its centre of pressure seems to travel and it never stalls."""

    cause = "bridge"
    window_s = Parameter(1.5, bound=POSITIVE, doc="Time the pad must have borne two contacts (s).")
    min_share = Parameter(0.2, bound=between(0, 0.5, low_open=True), unit=None,
                          doc="Least share of the load on the smaller of the two contacts.")
    gap_s = Parameter(0.25, bound=NON_NEGATIVE, doc="Longest break in the bridging that does not start it over (s).")

    def restart(self) -> None:
        self._since: float | None = None
        self._last_bridged = -math.inf

    def check(self, now, normal, point, features) -> str:
        share = features.lesser_share if point is not None else 0.0
        if share < self.min_share:
            if now - self._last_bridged > self.gap_s:
                self._since = None
            return ""
        self._last_bridged = now
        if self._since is None:
            self._since = now
        if now - self._since < self.window_s:
            return ""
        apart = features.pad.pitch * math.dist(features.cop_px.tolist(), features.others_cop_px)
        return (f"bridging two contacts {apart * 1e3:.0f} mm apart for {self.window_s:g} s after "
                f"{self.travelled * 1e3:.0f} mm")

    def evidence(self, pose: np.ndarray, features) -> dict:
        """``{"bridge": (a, b)}``: the two contacts' centres (world, m), where the pad rests on
        either side of the hollow."""
        if not features.others_tactels > 0:
            return {}
        return {"bridge": bridge_ends(pose, features)}


def bridge_ends(pose: np.ndarray, features) -> tuple[np.ndarray, np.ndarray]:
    """The centres (world, m) of a pad's two contacts while it has more than one region: the
    largest region's centre of pressure and the other regions', for the pad at ``pose``."""
    return (pad_point(pose, *features.cop_xy),
            pad_point(pose, *features.pad.xy_px_to_m(*features.others_cop_px)))
