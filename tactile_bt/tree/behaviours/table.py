"""The table the object lies on: part of the robot's known set-up, never of the object.

Its height reaches the tree through the blackboard key ``/setup/table_z_m`` (:data:`TABLE_Z_KEY`,
m, world z of the table's surface): the mission writes the scene's ``table`` there when it
starts (NaN when the scene has none), and on a real cell the calibrated height comes the same
way (``--blackboard /setup/table_z_m=...``). Absent or NaN means "no table known": every test
below is then off.

:func:`pad_clearance` is the height of the pad's lowest corner above the table, through the
forward kinematics ``T_gs``; the ``table_clearance`` guard fails the branch when it drops below
a limit, or, with ``recover_s``, raises the alarm :data:`TABLE_ALARM_KEY` on which the frontier
planner (:mod:`tactile_bt.tree.behaviours.frontier`) backs off, and fails only when the pad does
not get clear in time, trips too often or touches the table. The planner turns back before
that. ``record_contacts: {table_margin_m: ...}`` leaves out the contacts at the table's height.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.errors import BlackboardReferenceError
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, normalise_key

__all__ = ["TABLE_ALARM_KEY", "TABLE_Z_KEY", "TableClearance", "pad_clearance", "pad_corners", "lowest_corner", "table_height", "write_table_height"]

#: Blackboard key of the table's height (m, world z of its surface; NaN or absent: no table).
TABLE_Z_KEY = "/setup/table_z_m"
#: Blackboard key of the table-clearance alarm: the world position (m) of the pad's lowest
#: corner while it is too close to the table, None otherwise (written by a recovering guard).
TABLE_ALARM_KEY = "/scan/table_alarm"


def pad_corners(pad: PadGeometry, margin_m: float = 0.0) -> np.ndarray:
    """The pad's four corners in the sensor frame, ``(4, 3)`` (m), the sensing area grown by
    ``margin_m`` on every side (the pad's frame around it)."""
    corners = pad.corners_m()
    if margin_m > 0:
        corners = corners + np.sign(corners) * np.array([margin_m, margin_m, 0.0])
    return corners


def lowest_corner(pose: np.ndarray, pad: PadGeometry, margin_m: float = 0.0) -> np.ndarray:
    """The world position (m) of the lowest of the pad's four corners at ``pose`` (``T_gs``),
    the sensing area grown by ``margin_m`` on every side (the pad's frame around it)."""
    world = pad_corners(pad, margin_m) @ pose[:3, :3].T + pose[:3, 3]
    return world[int(np.argmin(world[:, 2]))]


def pad_clearance(pose: np.ndarray, pad: PadGeometry, table_z_m: float, margin_m: float = 0.0) -> float:
    """Height (m) of the pad's lowest corner (:func:`lowest_corner`) above the table at
    ``table_z_m``; ``inf`` when no table is known (NaN)."""
    if not math.isfinite(table_z_m):
        return math.inf
    return float(lowest_corner(pose, pad, margin_m)[2] - table_z_m)


def table_height(client, key: str = TABLE_Z_KEY) -> float:
    """The table height on the blackboard through ``client`` (which registered ``key`` for
    reading), NaN when absent. A value that is not a finite number (or NaN) is a
    :class:`~tactile_bt.errors.BlackboardReferenceError`: the leaves reading it check it when
    the tree is set up, before the mission runs."""
    if not client.exists(key):
        return math.nan
    value = client.get(key)
    try:
        z = float(value)
    except (TypeError, ValueError):
        z = None
    if z is None or isinstance(value, bool) or math.isinf(z):
        raise BlackboardReferenceError(f"blackboard key {key!r} (the table's height, from the scene or "
                                       f"--blackboard) must be a number in m (or .nan: no table), got {value!r}")
    return z


class TableClearance(TactileBehaviour):
    """Guard on the pad's lowest corner above the table of the set-up (``table_key``, read when
    the guard starts). RUNNING (and never failing) when no table is known.

    The corners are those of the sensing area grown by ``margin_m`` (the pad's frame), carried
    to the world through ``T_gs``: the forward kinematics, not a contact, so the guard trips
    before the pad's border touches the table.

    With ``recover_s = 0`` it fails as soon as the corner comes below ``min_clearance_m``, with
    the clearance and the corner in the message. With ``recover_s > 0`` a trip is recoverable:
    while the corner is below the limit the guard writes the corner (world, m) to
    ``alarm_key`` (None otherwise) and stays RUNNING, and the tree backs off
    (``frontier_guidance`` does). It fails when the corner stays below the limit longer than
    ``recover_s``, when it comes below ``hit_m`` (the pad touches the table), or at the
    ``max_trips``-th trip. With ``lift_mps`` the guard also lifts the pad itself, along the
    world's z, from the trip until the corner is ``brake_margin_m`` above the limit again: a
    compliant arm pressed against an edge sinks on faster than the tree's back-off takes hold.

    With ``brake_s > 0`` it also looks ahead: each cycle it takes the twist the leaves ticked
    before it have summed (the guard belongs last in the tree), predicts where the pad's
    corners will be after ``brake_s`` at that twist, and where one would come below
    ``min_clearance_m + brake_margin_m`` it slows the turn down just enough that it does not,
    and lifts the pad (world z) by what the translation alone would still lower it. It reckons
    with the twist as the command's limits will send it, and where the lift would take the
    motion over the linear limit it slows the motion across the world's z instead: the limits
    would otherwise scale the lift down with the slide (a pad sliding at the limit, 50 mm/s,
    while it rolled its corner down onto the table). A roll that
    would swing a corner down onto the table at 1 rad/s then slows as the corner nears it, and
    the corner settles above the limit instead of tripping the guard; the pad's sliding goes
    on, and motions that lift the corners are never slowed.

    With ``sink_tau_s > 0`` the brake also watches how the corners really move (off by default:
    docs/scanning.md says why the shipped scan leaves it off). A compliant arm does not go exactly
    where the twist sends it: pressed against an edge near the pad's border, it pivots the pad
    about the edge, and the far corner sinks although the twist holds it (a pad tilted 20° over
    a block's edge sank onto the table at 5–13 mm/s under a twist that kept its corner still).
    Each cycle it compares each corner's height with where the last cycle's twist should have
    taken it; the sinking beyond the twist, smoothed over ``sink_tau_s``, counts as part of the
    corners' motion in the next prediction, and the brake lifts the pad against it. Only a
    corner that really came down sank: one that rose less than the twist asked (a lift that a
    loaded contact holds back) did not, and motion upwards beyond the twist is ignored.
    """

    min_clearance_m = Parameter(0.001, doc="Least height of the lowest corner above the table (m; may be negative to "
                                           "allow the corner to press into a soft table cover).")
    margin_m = Parameter(0.0, bound=NON_NEGATIVE, doc="Width of the pad's frame around the sensing area (m).")
    recover_s = Parameter(0.0, bound=NON_NEGATIVE,
                          doc="Time the corner may stay below ``min_clearance_m`` while the tree backs off (s; 0: no "
                              "recovery, the guard fails at once).")
    hit_m = Parameter(0.0, doc="With recovery, the guard fails at once below this height of the corner (m; at most "
                               "``min_clearance_m``).")
    max_trips = Parameter(0, bound=NON_NEGATIVE, unit=None, doc="With recovery, the guard fails at this trip (0: any number).")
    lift_mps = Parameter(0.0, bound=NON_NEGATIVE,
                         doc="With recovery, from the trip until the corner is ``brake_margin_m`` above "
                             "``min_clearance_m`` again, the cycle's twist is replaced by a lift along the world's z "
                             "at this speed (m/s; 0: the tree alone backs off, and the trip ends at "
                             "``min_clearance_m``).")
    brake_s = Parameter(0.0, bound=NON_NEGATIVE,
                        doc="Look-ahead of the brake (s; 0: no brake): the cycle's turn is slowed, and the pad lifted, "
                            "where the twist would bring a corner below ``min_clearance_m + brake_margin_m`` within "
                            "this time.")
    brake_margin_m = Parameter(0.001, bound=NON_NEGATIVE, doc="Height above ``min_clearance_m`` the brake keeps the "
                                                              "corners at (m).")
    sink_tau_s = Parameter(0.0, bound=NON_NEGATIVE,
                           doc="Time constant (s) over which the brake smooths how fast the corners sink beyond "
                               "what the twist explains (a compliant arm pivoting the pad about an edge; 0.05 s "
                               "works); 0: the brake reckons with the twist alone.")
    table_key = Parameter(TABLE_Z_KEY, fixed=True, doc="Blackboard key of the table's height (m, world z).")
    alarm_key = Parameter(TABLE_ALARM_KEY, fixed=True, doc="Blackboard key of the alarm (see above).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.table_key = normalise_key(self.table_key)
        self.alarm_key = normalise_key(self.alarm_key)
        self._setup = self.attach_blackboard_client(name=f"{self.name}/setup")
        self._setup.register_key(key=self.table_key, access=Access.READ)
        self._setup.register_key(key=self.alarm_key, access=Access.WRITE)
        self.table_z_m = math.nan
        self.clearance_m = math.inf
        #: Trips since the guard started, and the mission time (s) of the current one (None: clear).
        self.trips = 0
        self._tripped_at: float | None = None
        #: Whether the brake slowed the twist down at the last tick.
        self.braked = False
        self._reset_sink()
        #: Over the whole mission, however often the guard starts again: cycles watched, cycles
        #: braked, trips, time lifting (s) and the lowest clearance (m), for :meth:`summary`.
        self._cycles = self._braked_cycles = self._all_trips = 0
        self._lifted_s = 0.0
        self._lowest_m = math.inf

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        table_height(self._setup, self.table_key)  # a bad value fails before the mission runs

    def initialise(self) -> None:
        self.table_z_m = table_height(self._setup, self.table_key)
        self.trips = 0
        self._tripped_at = None
        self._reset_sink()
        self._setup.set(self.alarm_key, None)

    def terminate(self, new_status: Status) -> None:
        self._setup.set(self.alarm_key, None)

    def _where(self, corner: np.ndarray) -> str:
        return (f"the pad's corner is {self.clearance_m * 1e3:.1f} mm above the table "
                f"(limit {self.min_clearance_m * 1e3:.1f} mm) at x {corner[0] * 1e3:.0f}, y {corner[1] * 1e3:.0f} mm")

    def update(self) -> Status:
        if not math.isfinite(self.table_z_m):
            self.feedback_message = "no table in the set-up"
            return Status.RUNNING
        corner = lowest_corner(self.pose, self.pad, self.margin_m)
        self.clearance_m = clearance = float(corner[2] - self.table_z_m)
        self._cycles += 1
        self._lowest_m = min(self._lowest_m, clearance)
        watching = self.brake_s > 0 and self.sink_tau_s > 0
        if self.brake_s > 0:
            # the corners (sensor frame) and their heights (m, world z), once for the whole tick
            corners = pad_corners(self.pad, self.margin_m)
            pose = self.pose
            heights = corners @ pose[2, :3] + pose[2, 3]
            if watching:
                self._watch_sink(heights)
            self._brake(corners, heights)
            self._braked_cycles += self.braked
        status = self._judge(corner, clearance)
        if watching:  # the twist as sent, the lift included
            self._expect(corners, heights)
        return status

    def _judge(self, corner: np.ndarray, clearance: float) -> Status:
        """The guard's status with the lowest ``corner`` (world, m) ``clearance`` (m) above the
        table; a trip raises the alarm and, with ``lift_mps``, lifts the pad."""
        # a lifting trip lasts until the corner is back up at the brake's floor (hysteresis), or
        # the tree's twist would bring it down again at once, tripping the guard tick after tick
        clear_m = self.min_clearance_m
        if self.lift_mps > 0 and self._tripped_at is not None:
            clear_m += self.brake_margin_m
        if clearance >= clear_m:
            self._tripped_at = None
            self._setup.set(self.alarm_key, None)
            self._feedback = None
            return Status.RUNNING
        if self.recover_s <= 0:
            self.feedback_message = self._where(corner)
            return Status.FAILURE
        if self._tripped_at is None:
            self._tripped_at = self.now
            self.trips += 1
            self._all_trips += 1
        below_s = self.now - self._tripped_at
        if clearance < min(self.hit_m, self.min_clearance_m):
            self.feedback_message = f"{self._where(corner)}: the pad touches the table (trip {self.trips})"
            return Status.FAILURE
        if self.max_trips and self.trips >= self.max_trips:
            self.feedback_message = f"{self._where(corner)}: trip {self.trips} of at most {self.max_trips}"
            return Status.FAILURE
        if below_s > self.recover_s:
            self.feedback_message = f"{self._where(corner)}: not clear after backing off {self.recover_s:.1f} s"
            return Status.FAILURE
        self._setup.set(self.alarm_key, corner.copy())
        if self.lift_mps > 0:
            self._send(np.concatenate((self.lift_mps * self.pose[2, :3], np.zeros(3))))  # world z, sensor frame
            self._lifted_s += self.dt
        self.feedback_message = f"backing off: {self._where(corner)} (trip {self.trips})"
        return Status.RUNNING

    @property
    def sink_mps(self) -> np.ndarray:
        """The corners' sinking beyond the twist (m/s, world z, each <= 0), smoothed."""
        return np.minimum(self._beyond_mps, 0.0)

    def _reset_sink(self) -> None:
        #: The corners' motion beyond the twist (m/s, world z), smoothed both ways.
        self._beyond_mps = np.zeros(4)
        #: The corners' heights (m, world z) at the last tick, the rates (m/s) its twist should
        #: have moved them by, and the time (s); None before the first braking tick.
        self._expected: tuple[np.ndarray, np.ndarray, float] | None = None

    def _corner_rates(self, twist: np.ndarray, corners: np.ndarray) -> tuple[float, np.ndarray]:
        """How fast ``twist`` (sensor frame) moves the ``corners`` (:func:`pad_corners`) along the
        world's z (m/s): the translation's share, the same for every corner, and the turn's, one
        per corner."""
        up = self.pose[2, :3]  # the world's z in the sensor frame
        return float(twist[:3] @ up), np.cross(twist[3:], corners) @ up

    def _watch_sink(self, heights: np.ndarray) -> None:
        """Update :attr:`sink_mps` from how far the corners came since the last tick (to
        ``heights``, m, world z) against where its twist should have taken them."""
        if self._expected is None:
            return
        before, rates, then = self._expected
        dt = self.now - then
        if not 0.0 < dt <= max(10.0 * self.sink_tau_s, 0.05):  # not the last tick's successor: start again
            self._reset_sink()
            return
        actual = (heights - before) / dt
        # a corner that did not come down did not sink, whatever the twist asked: a lift that a
        # loaded contact holds back is no sinking
        beyond = np.where(actual < 0.0, actual - rates, np.maximum(actual - rates, 0.0))
        # smoothed both ways and clipped only after (sink_mps): a pose measured less often than
        # the tree ticks moves by nothing, then by twice the twist, and must not leave a bias
        self._beyond_mps += dt / (self.sink_tau_s + dt) * (beyond - self._beyond_mps)

    def _expect(self, corners: np.ndarray, heights: np.ndarray) -> None:
        """Remember the corners' ``heights`` and the rates the cycle's twist (as the limits send
        it) moves the ``corners`` by, for :meth:`_watch_sink` at the next tick."""
        a, b = self._corner_rates(self.command.twist(), corners)
        self._expected = (heights, a + b, self.now)

    def _brake(self, corners: np.ndarray, heights: np.ndarray) -> None:
        """Slow the cycle's turn down, and lift the pad if its translation alone would still
        do it, so that no corner comes below the brake's floor within ``brake_s`` (see the
        class docstring); ``corners`` (:func:`pad_corners`) at ``heights`` (m, world z)."""
        command = self.command
        # the sum as the twist limits will send it: a brake reckoned on the sum before them
        # would see its lift scaled down with the slide when the slide is at the limit
        twist = command.twist()
        v, w = twist[:3], twist[3:]
        up = self.pose[2, :3]  # the world's z in the sensor frame
        # the rate each corner may come down at, less what it sinks by beyond the twist
        floor_rate = -(np.maximum(heights - self.table_z_m
                                  - (self.min_clearance_m + self.brake_margin_m), 0.0)) / self.brake_s - self.sink_mps
        a, b = self._corner_rates(twist, corners)  # m/s of every corner, world z: the translation's, the turn's
        short = floor_rate - (a + b)
        self.braked = bool((short > 0.0).any())
        if not self.braked:
            return
        # the turn scaled down as far as the corners that it lowers need, the translation kept
        lowering = b < 0.0
        scale = 1.0
        if lowering.any():
            scale = float(np.clip(np.min((a - floor_rate[lowering]) / -b[lowering]), 0.0, 1.0))
        lift = max(0.0, float(np.max(floor_rate - (a + scale * b))))  # what the translation still lowers
        # within the linear limit by slowing the motion across the world's z, never the lift:
        # the sum sent is then this, which the limits leave as it is
        rise = a + lift
        across = v - a * up
        room = math.sqrt(max(command.linear_limit ** 2 - rise * rise, 0.0))
        norm = float(np.linalg.norm(across))
        k = min(1.0, room / norm) if norm > 0.0 else 1.0
        self._send(np.concatenate((k * across + rise * up, scale * w)))

    def _send(self, twist: np.ndarray) -> None:
        """Make the cycle's twist ``twist`` (sensor frame, m/s and rad/s): add what it lacks to
        what the leaves ticked before the guard have summed."""
        command = self.command
        command.add(self.name, tuple((twist - command.summed()).tolist()))

    def summary(self) -> dict:
        """What report.json shows under ``table``, over the whole mission: the cycles the guard
        watched with a table known, the share of them the brake slowed, the trips, the time it
        lifted the pad (s) and the lowest clearance of the pad's lowest corner (m; None when no
        table was known)."""
        return {"node": self.name, "cycles": self._cycles,
                "braked_share": self._braked_cycles / self._cycles if self._cycles else 0.0,
                "trips": self._all_trips, "lifted_s": self._lifted_s,
                "lowest_clearance_m": self._lowest_m if math.isfinite(self._lowest_m) else None}

    def describe(self) -> str:
        """The clearance of the pad's lowest corner at the last tick, and the trips."""
        if not math.isfinite(self.table_z_m):
            return "no table in the set-up"
        trips = f", {self.trips} trips" if self.recover_s > 0 else ""
        return f"clearance {self.clearance_m * 1e3:.1f} mm{trips}"


def write_table_height(table_z_m: float, key: str = TABLE_Z_KEY) -> None:
    """Put the set-up's table height (m, world z; NaN: no table) on the blackboard at ``key``,
    as the mission does when it starts."""
    import py_trees

    client = py_trees.blackboard.Client(name="setup")
    client.register_key(key=normalise_key(key), access=Access.WRITE)
    client.set(normalise_key(key), float(table_z_m))
