"""Re-approach a frontier that sliding cannot reach: lift off, move clear, approach it anew.

Across a sharp ridge, into a valley or round the far side of a ring a sliding pad stalls: the
frontier planner (``frontier_guidance`` with ``reapproach_key``) then writes a re-approach to
the blackboard, ``{"probe": (point, normal), "home": (point, normal), "top_z": z}`` (world, m):
the point beyond the frontier to touch and the estimated outward normal there (from the contact
cloud), a touched point to come back to, and the highest touched height. The ``reapproach`` leaf
carries it out: it lifts the pad off along its normal by ``lift_m``, rises to a safe height
above everything touched, moves over to ``standoff_m`` above the probe point along its normal,
turning the pad to face it (and a quarter turn about its normal where the arm's wrist is wound
near its limit, ``/robot/turn_room``), and approaches along the normal until the pressure passes
``pressure_pa``, for at most ``approach_m`` beyond the standoff (or the job's ``"approach_m"``: a
far probe is lowered down to the table). It writes where it touched under ``"touched"`` (world,
m) and what it found under ``"result"``:

- ``surface``: the pad touches the object there; SUCCESS, the exploration goes on from there;
- ``table``: it touched the table (within ``table_clearance_m`` of ``/setup/table_z_m``), or the
  pad's lowest corner would come that close to it at the probe: the object ends before;
- ``reach``: the arm did not get the pad to a waypoint within ``move_s``, or came no nearer to
  it for 1 s (its joints at their limits);
- ``nothing``: no contact within ``approach_m`` beyond the standoff.

After anything but ``surface`` it approaches the home point the same way, and succeeds once in
contact there. Without a pending re-approach it succeeds at once. When the planner has found the
scan unfinished with nothing left to re-approach, it writes ``{"verdict": message}`` instead: the
leaf then fails at once with that message, so that a ``retry`` around it ends the scan without
touching again. Out of contact nothing else
moves the pad, so the leaf belongs before ``touch`` in a sequence, not beside the servo leaves.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Access, Status
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.control.spatial import pad_point
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, lowest_corner, table_height
from tactile_bt.tree.blackboard import read_or, turn_room, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, normalise_key

__all__ = ["Reapproach", "ReturnToSurface", "REAPPROACH_KEY", "HOLD_GAIN", "STUCK_S", "facing"]

#: Blackboard key of the pending re-approach.
REAPPROACH_KEY = "/scan/reapproach"
#: A waypoint is reached within this distance (m) and angle (rad).
_AT_M = 0.002
_AT_RAD = math.radians(2.0)
#: Proportional gains of the move to a waypoint (1/s).
_K_LINEAR = 3.0
_K_ANGULAR = 3.0
#: Gains (1/s) of the place and the orientation a subclass holds while it sweeps or lowers the pad
#: (``border_sweep``, ``hole_probe``).
HOLD_GAIN = 5.0
_K_TURN = 3.0
#: A move that has come no nearer (by ``_AT_M``, turns counted ``_M_PER_RAD`` m per rad) for
#: this long (s) is out of the arm's reach: its joints are at their limits.
STUCK_S = 1.0
_M_PER_RAD = 0.03
#: A move over everything touched that the arm cannot finish at its height (a point near the
#: arm's base, high up, is out of its reach where lower down it is not) goes on down from where
#: it stopped when that lies within this distance (m) across of the point it moves over to,
#: turned as planned, with the pad's lowest corner clear of everything touched.
_OVER_NEAR_M = 0.01
#: A probe point near the table stays this far (m) inside the sensing area.
_INSIDE_M = 0.01
#: A re-approach turns the pad a quarter turn about its normal where the wrist would otherwise
#: leave it less room than this (rad) to turn it the tighter way (:meth:`Reapproach._unwound`).
_UNWIND_BELOW_RAD = math.radians(45.0)


def facing(normal: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """The rotation (world, 3×3) of a pad whose sensor z points along ``-normal`` (into the
    surface), its x axis as near ``x_hint`` as that allows."""
    z = -np.asarray(normal, dtype=float)
    z = z / np.linalg.norm(z)
    x = np.asarray(x_hint, dtype=float) - (np.asarray(x_hint, dtype=float) @ z) * z
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.cross(z, [1.0, 0.0, 0.0])
    x = x / np.linalg.norm(x)
    return np.column_stack((x, np.cross(z, x), z))


class Reapproach(TactileBehaviour):
    """Carry out the re-approach pending on ``key``, if any (see the module docstring)."""

    key = Parameter(REAPPROACH_KEY, fixed=True, doc="Blackboard key of the pending re-approach (a dict).")
    speed_mps = Parameter(0.04, bound=POSITIVE, doc="Largest speed of the moves between waypoints (m/s).")
    turn_rps = Parameter(0.6, bound=POSITIVE, doc="Largest turn rate of the moves (rad/s).")
    approach_speed_mps = Parameter(0.01, bound=POSITIVE, doc="Speed of the final approach along the normal (m/s).")
    pressure_pa = Parameter(defaults.APPROACH_PRESSURE_PA, bound=POSITIVE,
                            doc="Smoothed contact pressure that counts as contact (Pa).")
    lift_m = Parameter(0.01, bound=NON_NEGATIVE, doc="Lift-off along the pad normal before moving (m).")
    clearance_m = Parameter(0.02, bound=NON_NEGATIVE,
                            doc="Height of the pad's lowest corner above the highest touched point while it moves "
                                "over (m).")
    standoff_m = Parameter(0.015, bound=POSITIVE, doc="Start of the approach above the probe point, along its normal (m).")
    approach_m = Parameter(0.04, bound=POSITIVE, doc="Largest approach beyond the standoff (m).")
    move_s = Parameter(10.0, bound=POSITIVE, doc="Time allowed to reach each waypoint (s).")
    table_key = Parameter(TABLE_Z_KEY, fixed=True,
                          doc="Blackboard key of the table's height (m, world z; absent or NaN: no table).")
    table_clearance_m = Parameter(0.003, bound=NON_NEGATIVE,
                                  doc="A contact this close to the table is the table's; the pad's lowest corner must "
                                      "stay this far above it at the probe (m).")
    corner_margin_m = Parameter(0.0, bound=NON_NEGATIVE,
                                doc="Width of the pad's frame around the sensing area, for the corners (m).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.key = normalise_key(self.key)
        self._verdict: str | None = None  # the planner's final word, when it has one
        self.table_key = normalise_key(self.table_key)
        self._bb = self.attach_blackboard_client(name=f"{self.name}/reapproach")
        self._bb.register_key(key=self.key, access=Access.WRITE)
        self._bb.register_key(key=self.table_key, access=Access.READ)
        self._job: dict | None = None
        self._waypoints: list = []
        self._phase = ""
        self._going_home = False
        self._progress = (math.inf, 0.0)  # the least error of the current move, and when

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        table_height(self._bb, self.table_key)  # a bad value fails before the mission runs

    def describe(self) -> str:
        """The phase of the re-approach."""
        return self._phase or "nothing to re-approach"

    # -- the plan -------------------------------------------------------------------------------
    def _plan(self, point: np.ndarray, normal: np.ndarray, top_z: float) -> bool:
        """Waypoints from the pad's pose to the standoff above ``point`` along ``normal``; False
        when the pad's lowest corner would come within ``table_clearance_m`` of the table at
        the point."""
        T = self.pose
        R = self._unwound(facing(normal, T[:3, 0]))
        point = self._clear_of_the_table(point, normal, R)
        if point is None:
            return False
        self._route(point + normal * self.standoff_m, R, top_z)
        return True

    def _unwound(self, R: np.ndarray) -> np.ndarray:
        """``R`` (world), or ``R`` turned a quarter turn about the pad normal either way, which
        the square pad senses the same: the one that leaves the wrist the most room to turn
        the pad (:class:`~tactile_bt.tree.blackboard.TurnRoom`), where ``R`` would leave it less
        than ``_UNWIND_BELOW_RAD`` the tighter way; ``R`` when the arm does not say, or the pad
        is not square."""
        room = turn_room(self.pad)
        if room is None:
            return R
        T = self.pose

        def left(Rk: np.ndarray) -> float:  # the room after the turn from here about the pad normal
            return room.after(float(Rotation.from_matrix(T[:3, :3].T @ Rk).as_rotvec()[2]))

        if left(R) >= _UNWIND_BELOW_RAD:
            return R
        quarter = Rotation.from_rotvec([[0.0, 0.0, math.pi / 2], [0.0, 0.0, -math.pi / 2]]).as_matrix()
        return max([R, R @ quarter[0], R @ quarter[1]], key=left)

    def _route(self, standoff: np.ndarray, R: np.ndarray, top_z: float) -> None:
        """Waypoints from the pad's pose to the pose ``(standoff, R)`` (world): lift off along
        the normal (when in contact), rise to ``clearance_m`` above ``top_z`` (the highest touched point) unless
        its lowest corner is that high already, move over, turning, and lower."""
        T = self.pose
        self._top_z = top_z
        half_diagonal = self.pad.half_diagonal_m + self.corner_margin_m
        # lift off a contact; a pad in the air (a move cut short at the arm's reach) rises at once
        lifted = T[:3, 3] + self._lift_direction() * self.lift_m if self.features.in_contact else T[:3, 3].copy()
        tilt_now = math.sqrt(max(0.0, 1.0 - T[2, 2] ** 2))
        tilt_new = math.sqrt(max(0.0, 1.0 - R[2, 2] ** 2))
        safe = top_z + self.clearance_m + half_diagonal * max(tilt_now, tilt_new)
        # a pad in the air already clear of everything touched moves over at once: rising from
        # a move the arm could not finish may be out of its reach too
        above = lowest_corner(T, self.pad, self.corner_margin_m)[2] >= top_z + self.clearance_m
        risen = lifted if above else np.array([lifted[0], lifted[1], max(safe, lifted[2])])
        self._waypoints = [(lifted, T[:3, :3].copy(), "lifting off"),
                           (risen, T[:3, :3].copy(), "rising"),
                           (np.array([standoff[0], standoff[1], max(safe, standoff[2])]), R, "moving over"),
                           (standoff, R, "lowering to the standoff")]
        self._deadline = self.now + self.move_s
        self._progress = (math.inf, self.now)
        self._approached = 0.0

    def _lift_direction(self) -> np.ndarray:
        """World direction (unit) the pad lifts off a contact in: back along its normal."""
        return -self.pose[:3, 2]

    def _clear_of_the_table(self, point: np.ndarray, normal: np.ndarray, R: np.ndarray) -> np.ndarray | None:
        """Where to centre the pad (world) to touch ``point``: the point itself, or, where the
        pad's lowest corner would come within ``table_clearance_m`` of the table, uphill along
        the surface as far as that needs, the point staying 10 mm inside the sensing area (as
        ``table_offset`` puts the contact near the downhill border); None when that is not
        enough."""
        if not math.isfinite(self._table_z):
            return point
        land = np.eye(4)
        land[:3, :3], land[:3, 3] = R, point
        short = self._table_z + self.table_clearance_m + _AT_M - lowest_corner(land, self.pad, self.corner_margin_m)[2]
        if short <= 0:
            return point
        downhill = np.array([0.0, 0.0, -1.0]) + normal[2] * normal  # down the tangent plane
        sin_tilt = float(np.linalg.norm(downhill))
        shift = short / max(sin_tilt, 1e-9)
        if sin_tilt < 1e-3 or shift > self.pad.half_width_m - _INSIDE_M:
            return None
        return point - downhill / sin_tilt * shift

    def _start(self, target: tuple, home: bool) -> None:
        point, normal = (np.asarray(v, dtype=float) for v in target)
        self._going_home = home
        if not self._plan(point, normal / np.linalg.norm(normal), float(self._job.get("top_z", point[2]))):
            if home:  # no way back: approach from where the pad is
                self._waypoints = []
                self._approached = 0.0
            else:
                self._finish("table")

    def _finish(self, result: str) -> None:
        """Record the probe's ``result`` and head home unless it found the surface."""
        if not self._going_home:
            self._job["result"] = result
        if result != "surface" and not self._going_home:
            self._start(self._job["home"], home=True)
        else:
            self._waypoints = []
            self._done = True

    # -- the life cycle -------------------------------------------------------------------------
    def initialise(self) -> None:
        self._table_z = table_height(self._bb, self.table_key)
        job = read_or(self.key)
        self._verdict = job.get("verdict") if isinstance(job, dict) else None
        self._job = job if isinstance(job, dict) and "probe" in job and "result" not in job else None
        self._done = False
        self._phase = ""
        if self._job is not None:
            self._start(self._job["probe"], home=False)

    def update(self) -> Status:
        if self._verdict:  # the planner has found the scan unfinished for good: nothing to touch again
            self.feedback_message = self._verdict
            return Status.FAILURE
        if self._job is None:
            self.feedback_message = "nothing to re-approach"
            return Status.SUCCESS
        f = self.features
        touching = f.in_contact and f.pressure >= self.pressure_pa
        if self._waypoints:
            self._next_waypoint(touching, "surface")  # touched on the way: the surface is here
        elif not self._done:
            self._phase = "approaching home" if self._going_home else "approaching"
            if touching:
                point = self._note_touch()
                on_table = math.isfinite(self._table_z) and point[2] < self._table_z + self.table_clearance_m
                self._finish("table" if on_table else "surface")
            elif self._corner_at_table():
                self._finish("table")
            elif self._approached > self.standoff_m + float(self._job.get("approach_m", self.approach_m)):
                self._finish("nothing")
            else:
                self.command.add(self.name, (0.0, 0.0, self.approach_speed_mps, 0.0, 0.0, 0.0))
                self._approached += self.approach_speed_mps * self.dt
        if self._done:
            self.feedback_message = f"re-approach: {self._job.get('result', '')}"
            return Status.SUCCESS
        self._feedback = None
        return Status.RUNNING

    def _note_touch(self) -> np.ndarray:
        """Note where the pad touches (world, m; the centre of pressure) in the job as
        ``"touched"`` while it probes, and return it."""
        point = pad_point(self.pose, *self.features_raw.cop_xy)
        if not self._going_home:
            self._job["touched"] = point
        return point

    def _corner_at_table(self) -> bool:
        """Whether the pad's lowest corner has come within ``table_clearance_m`` of the table."""
        if not math.isfinite(self._table_z):
            return False
        return lowest_corner(self.pose, self.pad, self.corner_margin_m)[2] < self._table_z + self.table_clearance_m

    def _next_waypoint(self, touching: bool, touched: str) -> None:
        """Move on towards the first waypoint: the result ``touched`` when the pad touches on
        the way (lifting off aside), ``reach`` when the arm does not get it there."""
        position, R, phase = self._waypoints[0]
        self._phase = phase
        if touching and phase != "lifting off":
            self._note_touch()
            self._finish(touched)
        elif self._move(position, R):
            self._next_move()
        elif self._out_of_reach():
            if self._over_near(position, R, phase):  # on down from here, where the arm reaches
                self._next_move()
            else:
                self._finish("reach")

    def _next_move(self) -> None:
        """Drop the waypoint reached (or given up as near enough) and time the next move."""
        self._waypoints.pop(0)
        self._deadline = self.now + self.move_s
        self._progress = (math.inf, self.now)

    def _over_near(self, position: np.ndarray, R: np.ndarray, phase: str) -> bool:
        """Whether a move over that the arm cannot finish may go on down from where it stopped:
        within ``_OVER_NEAR_M`` across of ``position``, turned to ``R`` and clear of everything
        touched (see :data:`_OVER_NEAR_M`)."""
        if phase != "moving over" or len(self._waypoints) < 2:
            return False
        T = self.pose
        across = float(np.linalg.norm(position[:2] - T[:2, 3]))
        turned = float(np.linalg.norm(Rotation.from_matrix(R @ T[:3, :3].T).as_rotvec())) < _AT_RAD
        corner = lowest_corner(T, self.pad, self.corner_margin_m)[2]
        return across <= _OVER_NEAR_M and turned and corner >= self._top_z + self.clearance_m

    def _out_of_reach(self) -> bool:
        """Whether the current move has run out of time or come no nearer for ``STUCK_S``."""
        return self.now > self._deadline or self.now - self._progress[1] > STUCK_S

    def _move(self, position: np.ndarray, R: np.ndarray) -> bool:
        """Command the twist towards the pose ``(position, R)`` (world); True once there."""
        T = self.pose
        e_p = position - T[:3, 3]
        e_r = Rotation.from_matrix(R @ T[:3, :3].T).as_rotvec()
        if np.linalg.norm(e_p) < _AT_M and np.linalg.norm(e_r) < _AT_RAD:
            return True
        error = float(np.linalg.norm(e_p)) + _M_PER_RAD * float(np.linalg.norm(e_r))
        if error < self._progress[0] - _AT_M:  # nearer by a millimetre (or 2°): progress
            self._progress = (error, self.now)
        v = _K_LINEAR * e_p
        w = _K_ANGULAR * e_r
        v *= min(1.0, self.speed_mps / max(float(np.linalg.norm(v)), 1e-12))
        w *= min(1.0, self.turn_rps / max(float(np.linalg.norm(w)), 1e-12))
        self._command_world(v, w)
        return False

    def _command_world(self, v: np.ndarray, w: np.ndarray) -> None:
        """Add the twist ``(v, w)`` (world frame; m/s, rad/s) to the command, in the sensor frame."""
        Rt = self.pose[:3, :3].T
        self.command.add(self.name, (*(Rt @ v), *(Rt @ w)))

    def _turn_back(self, R: np.ndarray) -> np.ndarray:
        """The world angular velocity (rad/s) that holds the pad's orientation at ``R`` (world):
        ``_K_TURN`` times the rotation from the pad's to ``R``."""
        return _K_TURN * Rotation.from_matrix(R @ self.pose[:3, :3].T).as_rotvec()


class ReturnToSurface(TactileBehaviour):
    """Ask ``reapproach`` to take the pad back to the last contact recorded, and FAIL: for the
    branch of a ``selector`` after a ``touch`` that found nothing.

    A pad that lost its contact near the table, tilted, and then approached along its own normal
    can miss the object altogether: the table guard's brake cancels the descent, and the pad
    slides sideways away from everything for as long as the approach lasts, then again on every
    retry. This leaf writes ``{"probe": (point, normal), "home": (point, normal), "top_z": z,
    "return": True}`` (world, m; the last sample of the mission's contact cloud and its normal,
    and the highest sample) to ``key`` and fails, so that a ``retry`` around the sequence runs
    ``reapproach`` first: it lifts the pad off, moves it over the last contact and approaches it
    along its normal. It fails without a job when nothing has been recorded yet. A job on ``key``
    carried out but not yet taken in by the planner that wrote it (a far probe that found the
    table, say, before the touch after it found nothing) goes with the return, under
    ``"pending"``, for the planner to take in then.
    """

    key = Parameter(REAPPROACH_KEY, fixed=True, doc="Blackboard key of the pending re-approach (a dict).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.key = normalise_key(self.key)
        self._bb = self.attach_blackboard_client(name=f"{self.name}/return")
        self._bb.register_key(key=self.key, access=Access.WRITE)

    def update(self) -> Status:
        cloud = self.bb.contacts
        if cloud is None or not len(cloud):
            self.feedback_message = "no contact, and none recorded to return to"
            return Status.FAILURE
        point, normal = cloud.points[-1].copy(), cloud.normals[-1].copy()
        top_z = float(np.max(cloud.points[:, 2]))
        job = {"probe": (point, normal), "home": (point, normal), "top_z": top_z, "return": True}
        before = read_or(self.key)
        if isinstance(before, dict) and "result" in before and not before.get("applied"):
            job["pending"] = before  # what it found is still news to the planner
        write(self.key, job)
        x, y, z = point * 1e3
        self.feedback_message = f"no contact: returning to the last contact at ({x:.0f}, {y:.0f}, {z:.0f}) mm"
        return Status.FAILURE
