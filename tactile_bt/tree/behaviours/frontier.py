"""Exploration by touch: choose where to slide next from what has been touched (frontiers).

The ``frontier_guidance`` leaf keeps a coarse map of the touched surface
(:class:`tactile_bt.contacts.frontier_map.FrontierMap`): an occupancy grid in the table plane
(world x, y; ``cell_m`` cells) filled from the mission's contact cloud (``/tactile/contacts``,
read by duck typing: ``.points`` and ``.normals``). The *frontier* is the
set of touched cells next to untouched ones: an open boundary of the covered area. A frontier
cell is *reachable* while the surface touched there is tilted less than the pad's tilt limit
(minus a margin) and no attempt to cross it has failed. The leaf slides the pad towards the
nearest reachable frontier cell, writing the guidance twist to ``key`` every cycle (the world
direction projected onto the pad's tangent plane, sensor frame, as ``scan_direction``) for
``guided_slide: {twist_key: ...}``, while the servo leaves keep the pad on the surface.

An attempt ends at the end of the surface: one of the condition leaves of
:mod:`tactile_bt.tree.behaviours.surface_end` the tree runs beside the planner (with ``end_key``:
the contact stalls or jumps, shrinks at an edge, the pad rolls over an edge or tilts past its
limit) writes the end to ``end_key``, and the leaves start over with each attempt, whose number
the planner writes to ``attempt_key``. The planner itself ends an attempt on a sign of the
set-up: the pad's lowest corner coming within ``table_clearance_m`` of the table
(``/setup/table_z_m``, see :mod:`tactile_bt.tree.behaviours.table`) while moving towards it. The
frontier cells under the pad whose open side faces the way the pad was going are then *blocked*
for that direction, and the next target is chosen away from it. A recovering ``table_clearance``
guard's alarm (``alarm_key``: the pad's corner has come too close to the table after all) ends
an attempt the same way, the frontier towards the corner blocked as the table's, and the pad
backs off away from the corner. So does an intervention of the supervisor
(``/supervisor/retreating``: a force or pressure limit passed), the frontier blocked for
"pressure", which explains nothing: the pad does not press on where it was just pulled back.

When no reachable frontier is left, the leaf sums the frontier left by reason
(:meth:`FrontierGuidance.frontier_left`, also on ``/scan/frontier_left`` for the report and for
``coverage_stalled``): the object's foot at the table and a surface steeper than the tilt limit
explain it; an edge, a stall, a jump, a lost contact or a target not reached in time do not
(the surface beyond may go on), except at the rim of a hollow in the touched area narrower
than the pad (a valley it bridges), and except that a stall, a lost contact or a target not reached
while the arm held a joint at its position limit (within the last second, from
``/robot/joints_held``, :data:`tactile_bt.tree.blackboard.JOINTS_HELD`) is the arm's reach,
which does. It succeeds only when at most ``max_unexplained_m`` is left
unexplained, and fails otherwise, its message naming what is left. Before it re-approaches, and
before it ends while the band the table left at the foot of plane faces is large, it asks for a
border sweep (``max_sweeps``, :mod:`tactile_bt.tree.behaviours.border_sweep`) of that foot or of
the sides of a hollow in the touched area the same way. It knows nothing of the
object's size, pose or shape beyond what the pad has touched.

The ends of attempts, the blocks and the backing off are the mixin of
:mod:`tactile_bt.tree.behaviours.frontier_ends`; the frontier left and the estimated coverage that
of :mod:`tactile_bt.tree.behaviours.frontier_left`; the re-approaches, sweeps and probes that of
:mod:`tactile_bt.tree.behaviours.frontier_jobs`.

Layer: tree.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.contacts.frontier_map import FrontierMap, describe_left
from tactile_bt.contacts.reapproach_plan import ReapproachPlan
from tactile_bt.control.spatial import pad_point
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.frontier_ends import FrontierEnds
from tactile_bt.tree.behaviours.frontier_jobs import FrontierJobs
from tactile_bt.tree.behaviours.frontier_left import FRONTIER_LEFT_KEY
from tactile_bt.tree.behaviours.scan import tangent_guidance
from tactile_bt.tree.behaviours.surface_end import ATTEMPT_END_KEY, ATTEMPT_KEY
from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, table_height
from tactile_bt.tree.blackboard import joints_held, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between, normalise_key

__all__ = ["FrontierGuidance", "FRONTIER_LEFT_KEY"]

#: Backing off ends once the pad is at most about 5° more tilted than at the attempt's start.
_LEVEL_MARGIN_COS = 0.02
_ZERO_TWIST = np.zeros(6)
#: Time constant (s) of the low-pass filter on the contact point the planner steers from.
_POINT_FILTER_S = 0.1
#: The guidance slows down linearly from full speed with the contact this far (m) from the
#: pad's border to ``_SLOWEST`` of it at ``_BORDER_STOP_M``.
_BORDER_SLOW_M = 0.012
_BORDER_STOP_M = 0.004
_SLOWEST = 0.1


class FrontierGuidance(FrontierEnds, FrontierJobs, TactileBehaviour):
    """Slide towards the nearest reachable frontier of the touched surface; SUCCESS when none is
    left (see the module docstring). Writes the guidance twist (sensor frame, m/s) to ``key``
    every tick, zero while it chooses or out of contact; put it in parallel with
    ``guided_slide: {twist_key: key}``, the servo leaves and ``record_contacts``.

    The map and its blocked directions outlive a restart of the leaf (a ``retry`` after a lost
    contact): they belong to the mission's contact cloud, and start again with a new cloud.
    """

    uses = frozenset({"cop"})
    #: Its SUCCESS ends a scan: the mission reports its message as the reason.
    reports_success = True

    key = Parameter("/scan/guidance", fixed=True, doc="Blackboard key the guidance twist is written to.")
    speed_mps = Parameter(0.02, bound=POSITIVE, doc="Sliding speed towards the frontier (m/s).")
    cell_m = Parameter(0.002, bound=POSITIVE, fixed=True, doc="Edge of the map's cells in the table plane (m).")
    extent_m = Parameter(0.3, bound=POSITIVE, fixed=True, doc="Half-size of the mapped square around the first contact (m).")
    max_tilt_rad = Parameter(math.radians(70.0), bound=between(0, math.pi / 2, low_open=True),
                             doc="The pad's tilt limit from the vertical (rad): an attempt ends beyond it, and a "
                                 "frontier whose touched surface is tilted more than ``max_tilt_rad - "
                                 "tilt_margin_rad`` is out of reach.")
    tilt_margin_rad = Parameter(math.radians(5.0), bound=between(0, math.pi / 2), doc="See ``max_tilt_rad``.")
    table_clearance_m = Parameter(0.003, bound=NON_NEGATIVE,
                                  doc="An attempt ends when the pad's lowest corner comes this close to the table "
                                      "while moving towards it, and the pad then backs off until it is twice as high "
                                      "(m; needs the table's height on ``table_key``). Frontier cells this close to "
                                      "the table are the table's edge.")
    corner_margin_m = Parameter(0.0, bound=NON_NEGATIVE,
                                doc="Width of the pad's frame around the sensing area, for the corners (m).")
    table_key = Parameter(TABLE_Z_KEY, fixed=True,
                          doc="Blackboard key of the table's height (m, world z; absent or NaN: no table).")
    end_key = Parameter(ATTEMPT_END_KEY, fixed=True,
                        doc="Blackboard key where the end-of-surface leaves (:mod:`~tactile_bt.tree.behaviours."
                            "surface_end`, with ``end_key``) write the end of an attempt.")
    attempt_key = Parameter(ATTEMPT_KEY, fixed=True,
                            doc="Blackboard key the attempt number is written to, so that those leaves start over "
                                "with each attempt.")
    replan_s = Parameter(0.2, bound=POSITIVE, doc="Time between map updates and target choices (s).")
    attempt_s = Parameter(4.0, bound=POSITIVE,
                          doc="Time allowed to reach a target beyond the travel time at ``speed_mps``, and to back "
                              "off (s).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.key = normalise_key(self.key)
        self.table_key = normalise_key(self.table_key)
        self._writer = self.attach_blackboard_client(name=f"{self.name}/guidance")
        self._writer.register_key(key=self.key, access=Access.WRITE)
        self._writer.register_key(key=FRONTIER_LEFT_KEY, access=Access.WRITE)
        self.end_key = normalise_key(self.end_key)
        self.attempt_key = normalise_key(self.attempt_key)
        self._writer.register_key(key=self.attempt_key, access=Access.WRITE)
        self._setup = self.attach_blackboard_client(name=f"{self.name}/setup")
        self._setup.register_key(key=self.table_key, access=Access.READ)
        self._listen_for_alarms(self._setup)
        self._setup.register_key(key=self.end_key, access=Access.READ)
        if self.reapproach_key:
            self.reapproach_key = normalise_key(self.reapproach_key)
            self._writer.register_key(key=self.reapproach_key, access=Access.WRITE)
        #: The map of the touched surface (None before the first contact sample).
        self.map: FrontierMap | None = None
        self._map_cloud = None  # the cloud the map was filled from
        self._seen = 0  # samples of that cloud in the map
        self.table_z_m = math.nan
        #: (row, column) of the frontier cell the pad is sliding to, or None.
        self.target: tuple[int, int] | None = None
        #: World xy direction of the current (or last) attempt.
        self.direction = np.zeros(2)
        #: Targets chosen, attempts ended at the end of the surface, reachable frontier cells at
        #: the last choice, and why the last attempt ended.
        self.attempts = 0
        self.blocks = 0
        self.candidates = 0
        self.last_end = ""
        #: Ends of attempts by cause ("table", "tilt", "edge", "stall", "time", ...): what
        #: explains the frontier left open.
        self.ends: Counter = Counter()
        #: Length (m) of the frontier by reason at the last choice (see :meth:`frontier_left`).
        self.left: dict[str, float] = {}
        self.coverage = 0.0
        self.below_m2 = 0.0
        self.face_xy = np.zeros((0, 2))  # the frontier on plane faces near the table (world xy, m)
        self.face_z = np.zeros(0)
        #: The re-approaches of the map (see :mod:`tactile_bt.contacts.reapproach_plan`).
        self.plan = ReapproachPlan(self.probe_beyond_m, self.probe_beyond_m)
        self._probed = []  # the valleys probed with the pad's corner (see FrontierJobs._probed)
        self._state = "waiting for contact"
        self._reset_motion()

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        self._cloud = self.bb.contacts
        table_height(self._setup, self.table_key)  # a bad value fails before the mission runs
        # nothing of an earlier scan on the same blackboard: its guidance, the end of its last
        # attempt (whose number a new scan reaches too), its frontier, its re-approach or verdict
        write(self.key, _ZERO_TWIST)
        write(self.attempt_key, 0)
        write(self.end_key, None)
        write(FRONTIER_LEFT_KEY, None)
        if self.reapproach_key:
            write(self.reapproach_key, None)

    def describe(self) -> str:
        """State, targets tried, frontier cells and blocked ends."""
        return f"{self._state}: target {self.attempts}, {self.candidates} frontier cells, {self.blocks} ends"

    def explained(self) -> str:
        """The ends of attempts by cause, most frequent first ("3 table, 2 tilt")."""
        return ", ".join(f"{n} {cause}" for cause, n in self.ends.most_common())

    # -- the map -----------------------------------------------------------------------------
    def _update_map(self, point: np.ndarray) -> None:
        cloud = self._cloud
        if cloud is not self._map_cloud:  # another mission's cloud: start again
            self.map, self._map_cloud, self._seen = None, cloud, 0
            self.plan = ReapproachPlan(self.probe_beyond_m, self.probe_beyond_m)
            self.sweeps = None
            self._probed = []
        n = len(cloud)
        if n > self._seen:
            if self.map is None:
                self.map = FrontierMap(point[:2], self.cell_m, self.extent_m)
            self.map.add(cloud.points[self._seen:n], cloud.normals[self._seen:n])
            self._seen = n

    # -- the pad -----------------------------------------------------------------------------
    def _contact_point(self) -> np.ndarray | None:
        """Where the pad touches (world), low-passed over ``_POINT_FILTER_S``: on a soft or
        lumpy object the largest contact region, and with it the centre of pressure, may jump
        between parts of the imprint from one cycle to the next; None out of contact."""
        f = self.features_raw
        if not f.in_contact:
            self._point = None
            return None
        point = pad_point(self.pose, *f.cop_xy)
        if self._point is None:
            self._point = point
        else:
            self._point = self._point + (point - self._point) * min(1.0, self.dt / _POINT_FILTER_S)
        return self._point

    def _guide(self, world: np.ndarray | None) -> None:
        """Write the guidance along the world direction ``world`` (zero when None), slower as
        the contact nears the pad's border: sliding drags the contact towards the trailing
        side, and off the pad when it sits near the border already (see ``table_offset``). A
        pad bridging a hollow (:meth:`_resting_on_two`) rests on both: the border distance is
        then that of the centre of the whole load."""
        norm = 0.0 if world is None else float(np.linalg.norm(world))
        if norm < 1e-12:
            write(self.key, _ZERO_TWIST)
            return
        speed = self.speed_mps
        f = self.features_raw
        if f.in_contact:
            w, h = self.pad.size_m
            x, y = f.load_cop_xy if self._resting_on_two() else f.cop_xy
            margin = min(0.5 * w - abs(x), 0.5 * h - abs(y))
            speed *= min(1.0, max(_SLOWEST, (margin - _BORDER_STOP_M) / (_BORDER_SLOW_M - _BORDER_STOP_M)))
        write(self.key, tangent_guidance(self.pose, world / norm, speed))

    # -- attempts ----------------------------------------------------------------------------
    def _reset_motion(self) -> None:
        self.target = None
        self._next_plan = -math.inf
        self._avoid: np.ndarray | None = None  # the way the last attempt ended
        self._retreat: tuple | None = None
        self._last_point: np.ndarray | None = None
        self._point: np.ndarray | None = None  # the low-passed contact point
        self._held: tuple = ((), -math.inf)  # the joints last held at a limit, and when
        self._start_tilt_cos = -2.0
        self._cause = ""
        self._bridge_since: float | None = None  # since when the pad has rested on both sides of a hollow
        self._bridge_last = -math.inf

    def _choose(self, point: np.ndarray) -> bool:
        """Choose the next target from ``point`` (world), or start backing off from the table
        when every reachable frontier lies downhill of the pad's lowest corner; False when no
        reachable frontier is left."""
        rows, cols, out = self._candidates()
        self.candidates = len(rows)
        if not len(rows):
            return False
        self._start_tilt_cos = self._tilt_cos() - _LEVEL_MARGIN_COS
        centres = self.map.centre_of(rows, cols)
        delta = centres - point[:2]
        dist = np.linalg.norm(delta, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            heading = np.where(dist[:, None] > 1e-9, delta / dist[:, None], out)
        cost = dist.copy()
        if np.any(self.direction):  # keep going the same way when it is about as near
            cost *= 1.0 + 0.5 * (1.0 - heading @ self.direction)
        if self._avoid is not None:  # just ended that way: another way if there is one
            away = heading @ self._avoid < 0.5
            if np.any(away):
                cost = np.where(away, cost, np.inf)
            self._avoid = None
        clearance, corner = self._clearance()
        if clearance < 2 * self.table_clearance_m:  # near the table: not towards the lowest corner
            low = corner[:2] - self.pose[:2, 3]
            low = low / max(float(np.linalg.norm(low)), 1e-9)
            up = heading @ low < 0.3
            if not np.any(up):  # every way left leads down: first gain height, then see
                self._start_retreat(point, "near the table", -low)
                return True
            cost = np.where(up, cost, np.inf)
        k = int(np.argmin(cost))
        self.target = (int(rows[k]), int(cols[k]))
        self._target_out = out[k]
        self._target_xy = centres[k]
        self._target_z = float(self.map.z_max[self.target])
        self._deadline = self.now + dist[k] / self.speed_mps + self.attempt_s
        self._clearance_start = clearance
        self.attempts += 1
        write(self.attempt_key, self.attempts)  # the end-of-surface leaves start over
        self._steer(point)
        return True

    def _steer(self, point: np.ndarray) -> np.ndarray:
        """Set :attr:`direction` (world xy) towards the target and return the world direction
        the pad slides along: towards the highest sample of the target cell, or once there,
        outwards across it."""
        delta = self._target_xy - point[:2]
        dist = float(np.linalg.norm(delta))
        if dist > self.cell_m:
            self.direction = delta / dist
            return np.array([delta[0], delta[1], self._target_z - point[2]])
        self.direction = self._target_out
        return np.array([self.direction[0], self.direction[1], 0.0])

    # -- the life cycle ----------------------------------------------------------------------
    def initialise(self) -> None:
        self.table_z_m = table_height(self._setup, self.table_key)
        self._reset_motion()
        self._guide(None)

    def update(self) -> Status:
        self._feedback = None
        held = joints_held()
        if held:
            self._held = (held, self.now)
        point = self._contact_point()
        if point is None:  # no contact: hold still, the guards decide
            if self.target is not None and self._last_point is not None:
                self._block(self._last_point, "contact lost", cause="contact lost")  # that way is out of reach from here
            self._retreat = None
            self._guide(None)
            self._state = "waiting for contact"
            return Status.RUNNING
        self._watch_bridge()
        self._last_point = point
        now = self.now
        if self._table_alarm(point) or self._supervisor_alarm(point):
            self._next_plan = now
        if self._retreat is not None and self._retreating(point):
            return Status.RUNNING
        if self.target is not None:
            why, at_edge = self._attempt_end(point)
            if why:
                self._block(point, why, at_edge, self._cause)
                self._start_retreat(point, why)
                self._next_plan = now
                if self._retreating(point):
                    return Status.RUNNING
        if now >= self._next_plan:
            self._next_plan = now + self.replan_s
            self._update_map(point)
            self._reapproached()
            if self.map is None:  # nothing recorded yet
                self._guide(None)
                self._state = "waiting for the first contacts"
                return Status.RUNNING
            if self.target is not None:  # covered meanwhile (or blocked): choose again
                rows, cols, _ = self._candidates()
                if not np.any((rows == self.target[0]) & (cols == self.target[1])):
                    self.target = None
            if self.target is None:
                if not self._choose(point):
                    self._guide(None)
                    explained = f": {self.explained()}" if self.ends else ""
                    counts = f"{self.attempts} targets, {self.blocks} ends of the surface{explained}"
                    left = describe_left(self.frontier_left())
                    if self.coverage < self.min_coverage and self.unexplained_m() <= self.max_unexplained_m:
                        untouched = self.untouched_where()
                        # a valley the touched area encloses is probed first: found open (a ring's
                        # hole), it leaves the estimate but for the 4 mm band along its rim (less
                        # where the corner showed the rim falling away steeper than the pad may
                        # lie), and the sides are swept only while that band keeps the scan from
                        # its coverage (taken on trust: see docs/scanning.md); then the sides of
                        # valleys (a channel's, one found touched), then probes of the others, then
                        # what lies beyond the wrist's stops: turned back, the pad may reach on there
                        if self._asked_probe(point, f"{untouched}) ({counts})", enclosed=True) \
                                or self._asked_sweep(point, f"{untouched}) ({counts})") \
                                or self._asked_probe(point, f"{untouched}) ({counts})") \
                                or self._asked_unwind(point, f"{untouched}) ({counts})"):
                            return Status.FAILURE
                        self.feedback_message = f"no reachable frontier left, but {untouched}; {left}) ({counts})"
                        return self._verdict()
                    if self.unexplained_m() > self.max_unexplained_m:
                        # a hole wider than the pad first: found open, it explains the stalls round its
                        # rim, which a border cannot reach under (a ring's); found touched, it is probed
                        # again once sliding has shrunk it; then the sides of the valleys, but not the
                        # band along a hole found open (what faces it is explained)
                        if self._asked_probe(point, f"{left} ({counts})", wide=True) \
                                or self._asked_sweep(point, f"{left} ({counts})", open_rims=False):
                            return Status.FAILURE
                        job = self._reapproach(point)
                        if job is not None:
                            x, y = job["frontier_xy"] * 1e3
                            what = "probing beyond" if job.get("far") else "re-approaching"
                            self.feedback_message = (f"{what} the frontier at ({x:.0f}, {y:.0f}) mm: {left} "
                                                     f"({counts})")
                            return Status.FAILURE
                        self.feedback_message = f"no reachable frontier left, but {left} ({counts})"
                        return self._verdict()
                    # enough, but a band at the foot worth a sweep is still left: sweep it while sweeps last
                    if self.band_worth_sweeping() and self._asked_sweep(point, f"{left} ({counts})"):
                        return Status.FAILURE
                    self.feedback_message = f"no reachable frontier left ({counts}); frontier left: {left}"
                    return Status.SUCCESS
                if self._retreat is not None and self._retreating(point):
                    return Status.RUNNING
        if self.target is None:
            self._guide(None)
            return Status.RUNNING
        self._guide(self._steer(point))
        self._state = "sliding to the frontier"
        return Status.RUNNING
