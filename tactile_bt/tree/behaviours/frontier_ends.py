"""How an attempt of ``frontier_guidance`` ends: the bookkeeping of its blocks and the backing
off (:mod:`tactile_bt.tree.behaviours.frontier`), as a mixin of its class.

An attempt to reach a frontier ends when an end-of-surface leaf writes its end to ``end_key``
(:mod:`tactile_bt.tree.behaviours.surface_end`), when the pad's lowest corner sinks to within
``table_clearance_m`` of the table, or when the target is not reached in time. The frontier the
attempt was heading for is then *blocked* in that direction, with the end's cause (an arm holding
a joint at its limit turns a stall, a lost contact or a late target into its reach; when that
joint alone, and it is the one that turns a square pad about its normal, into
:data:`~tactile_bt.contacts.frontier_map.WRIST`, the reach of a wrist wound up, which a re-approach
turning the pad back a quarter turn may undo), and the pad
*backs off*, uphill and away from the way it went. A recovering ``table_clearance`` guard's alarm
and an intervention of the supervisor end an attempt the same way, once per alarm. While the pad
rests on two contacts across a hollow, the map may be told where it bridged (``bridge_watch_s``),
whether or not the attempt ends there.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Access

from tactile_bt.contacts.frontier_map import WRIST
from tactile_bt.tree.behaviours.supervision import REASON, RETREATING
from tactile_bt.tree.behaviours.surface_end import bridge_ends
from tactile_bt.tree.behaviours.table import TABLE_ALARM_KEY, lowest_corner
from tactile_bt.tree.blackboard import read_or, turn_room
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, normalise_key

__all__ = ["FrontierEnds"]


#: Ends of an attempt at an edge under the pad (its imprint reached the edge across its width).
_EDGE_CAUSES = frozenset({"shrink", "edge", "turn"})
#: Half the width (m) of the strip between two contacts the pad bridged that the map marks as a
#: hollow (the contacts' centres lie mid-way along their lines).
_BRIDGED_HALF_WIDTH_M = 0.01
#: A pad resting on two contacts at least half its width apart, the lesser carrying at least this
#: share of the load, bridges a hollow.
_BRIDGE_SHARE = 0.25
#: Breaks (s) in such resting that do not start ``bridge_watch_s`` over (the pad rocks between them).
_BRIDGE_GAP_S = 0.25
#: An attempt ends near the table only when the pad's corner has sunk this much (m) since it began.
_SINKING_M = 0.0005
#: Ends an arm holding a joint at its limit explains: the pad stopped, or lost the contact,
#: because the arm could not follow (its reach), not because the surface ends.
_HELD_CAUSES = frozenset({"stall", "contact lost", "time"})
#: A joint held at its limit this recently (s) explains those ends.
_HELD_S = 1.0


class FrontierEnds:
    """The ends of attempts, the blocks and the backing off of a frontier planner (a mixin; the
    planner has ``map``, ``target``, ``direction``, its table settings and its guidance)."""

    block_radius_m = Parameter(0.0, bound=NON_NEGATIVE,
                               doc="Radius around the pad centre within which frontier cells facing the way the pad "
                                   "went are blocked when the attempt ends at an edge (the contact shrinks or the pad "
                                   "rolls over it: the imprint has reached the edge across the pad; m; 0 = half the "
                                   "pad's width).")
    local_block_radius_m = Parameter(0.01, bound=NON_NEGATIVE,
                                     doc="Radius around the contact point within which they are blocked at the other "
                                         "ends: the tilt limit, the table, a stall, a jump or a loss of the contact "
                                         "(m).")
    retreat_m = Parameter(0.005, bound=NON_NEGATIVE,
                          doc="After an attempt has ended the pad backs off, uphill and away from the way it went, at "
                              "least this far (m) and until it is about as level as where the attempt started.")
    bridge_watch_s = Parameter(0.0, bound=NON_NEGATIVE,
                               doc="While the pad rests on two contacts at least half its width apart, the lesser "
                                   "carrying a quarter of the load or more (a flat pad bridging a hollow), the map "
                                   "marks the strip between them as a hollow every this many seconds (s; 0: never, "
                                   "the default). The marks let an untouched channel the pad was seen to bridge, "
                                   "open at its ends, count as a valley, as ``contact_bridged`` does when it ends an "
                                   "attempt, but without ending it (1.5 s in the shipped scan tree). Strips across a hole "
                                   "that the touched area encloses (a ring's) mark no channel.")
    alarm_key = Parameter(TABLE_ALARM_KEY, fixed=True,
                          doc="Blackboard key of the table-clearance alarm (the pad's lowest corner, world, while a "
                              "recovering ``table_clearance`` guard finds it too close to the table; None or absent "
                              "otherwise).")

    # -- the pad -----------------------------------------------------------------------------
    def _clearance(self) -> tuple[float, np.ndarray]:
        """Height (m) of the pad's lowest corner above the table, and the corner (world)."""
        if not math.isfinite(self.table_z_m):
            return math.inf, np.zeros(3)
        corner = lowest_corner(self.pose, self.pad, self.corner_margin_m)
        return float(corner[2] - self.table_z_m), corner

    def _tilt_cos(self) -> float:
        """Cosine of the pad's tilt from the vertical."""
        return -float(self.pose[2, 2])

    # -- bridging ----------------------------------------------------------------------------
    def _resting_on_two(self) -> bool:
        """Whether the pad rests on two contacts (its largest region and the others) at least
        half its width apart, the other regions carrying at least ``_BRIDGE_SHARE`` of the load."""
        f = self.features_raw
        if not (f.in_contact and f.others_tactels > 0 and f.others_force >= _BRIDGE_SHARE * (f.force + f.others_force)):
            return False
        x, y = f.cop_xy
        ox, oy = f.pad.xy_px_to_m(*f.others_cop_px)
        return math.hypot(ox - x, oy - y) >= 0.5 * min(self.pad.size_m)

    def _watch_bridge(self) -> None:
        """Mark the strip between the pad's two contacts as a hollow on the map once the pad has
        rested on both for ``bridge_watch_s`` (each side carrying ``_BRIDGE_SHARE`` of the load
        or more), and again every ``bridge_watch_s`` while it goes on."""
        if not self.bridge_watch_s > 0 or self.map is None:
            return
        now = self.now
        if not self._resting_on_two() or self.features_raw.lesser_share < _BRIDGE_SHARE:
            if now - self._bridge_last > _BRIDGE_GAP_S:
                self._bridge_since = None
            return
        self._bridge_last = now
        if self._bridge_since is None:
            self._bridge_since = now
        elif now - self._bridge_since >= self.bridge_watch_s:
            self.map.mark_bridged(*bridge_ends(self.pose, self.features_raw), half_width_m=_BRIDGED_HALF_WIDTH_M)
            self._bridge_since = now

    # -- ends of attempts --------------------------------------------------------------------
    def _attempt_end(self, point: np.ndarray) -> tuple[str, bool]:
        """Why the current attempt has come to an end ("" while it goes on), and whether at an
        edge under the pad: an end-of-surface leaf's (on ``end_key``), the table or the time."""
        end = read_or(self.end_key)
        if end is not None and end.get("attempt") == self.attempts:
            self._cause = end["cause"]
            if "bridge" in end and self.map is not None:  # the pad rested on both sides of a hollow
                self.map.mark_bridged(*end["bridge"], half_width_m=_BRIDGED_HALF_WIDTH_M)
            return end["message"], self._cause in _EDGE_CAUSES
        clearance, _ = self._clearance()
        if clearance < self.table_clearance_m and clearance < self._clearance_start - _SINKING_M:
            self._cause = "table"
            return f"the pad's corner {clearance * 1e3:.1f} mm above the table", False
        if self.now > self._deadline:
            self._cause = "time"
            return "target not reached in time", False
        return "", False

    def _block(self, point: np.ndarray, why: str, at_edge: bool = False, cause: str = "",
               direction: np.ndarray | None = None) -> None:
        """Block the frontier the attempt was heading for, in its direction (or ``direction``,
        world xy), and count the end under ``cause``."""
        if at_edge:  # the surface ends at an edge under the pad: as far as the pad reaches
            radius, centre = self.block_radius_m or self.pad.half_width_m, self.pose[:3, 3]
        else:  # too steep, the table, stuck: only this part of the frontier is out of reach
            radius, centre = self.local_block_radius_m, point
        d = direction if direction is not None else self.direction if np.any(self.direction) else self._target_out
        cause = cause or why
        if cause in _HELD_CAUSES and self._held[0] and self.now - self._held[1] <= _HELD_S:
            joints = " and ".join(str(j) for j in self._held[0])
            room = turn_room(self.pad)
            if room is not None and self._held[0] == (room.joint,):  # only the pad's turn was stopped
                why, cause = f"{why} with joint {joints} at its limit (the pad can turn back)", WRIST
            else:
                why, cause = f"{why} with joint {joints} at its limit", "reach"
        self.map.block(centre[:2], radius, d, cause=cause)
        self.map.block(point[:2], 2 * self.cell_m, d, cause=cause)
        if self.target is not None:
            # the target and the frontier on the way to it, out of reach along this way
            rows, cols, out = self.map.frontier()
            xy = self.map.centre_of(rows, cols)
            a, b = point[:2], self._target_xy
            ab = b - a
            u = np.clip(((xy - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
            on_way = np.linalg.norm(xy - (a + u[:, None] * ab), axis=1) <= self.local_block_radius_m
            on_way |= (rows == self.target[0]) & (cols == self.target[1])
            self.map.block_cells(rows[on_way], cols[on_way], out[on_way], cause)
        self.blocks += 1
        self.ends[cause] += 1
        self.last_end = why
        self._avoid = np.array(d, dtype=float)
        self.target = None

    def _start_retreat(self, point: np.ndarray, why: str, away: np.ndarray | None = None) -> None:
        """Back off, uphill and away from the way the attempt went (or along ``away``, world
        xy), at least ``retreat_m``, until the pad is about as level as where the attempt
        started and clear of the table: it may have rolled over an edge or down a slope."""
        if away is None:
            away = -(self.direction if np.any(self.direction) else self._target_out)
        direction = np.array([away[0], away[1], 1.0])  # the world's up is uphill on the pad
        self._retreat = (direction, point[:2].copy(), self.now + self.attempt_s, why)

    def _retreating(self, point: np.ndarray) -> bool:
        """Steer the retreat; False once it is over."""
        direction, origin, until, why = self._retreat
        back = float(np.hypot(*(point[:2] - origin)))
        level = self._tilt_cos() >= self._start_tilt_cos and self._clearance()[0] >= 2 * self.table_clearance_m
        if (level and back >= self.retreat_m) or self.now > until:
            self._retreat = None
            return False
        self._guide(direction)
        self._state = f"backing off ({why})"
        return True

    def _listen_for_alarms(self, client) -> None:
        """Register the keys of the alarms that end an attempt for reading on the blackboard
        ``client`` (the table guard's ``alarm_key``, the supervisor's retreat and its reason),
        none answered yet."""
        self.alarm_key = normalise_key(self.alarm_key)
        for key in (self.alarm_key, RETREATING, REASON):
            client.register_key(key=key, access=Access.READ)
        self._alarms_on: set[str] = set()  # the alarms answered already ("table", "supervisor")

    def _alarm_begins(self, alarm: str, on: bool) -> bool:
        """Whether ``alarm`` (on or off this tick) has just come on: True on its first tick
        only, so that an alarm lasting many ticks ends one attempt."""
        if not on:
            self._alarms_on.discard(alarm)
            return False
        if alarm in self._alarms_on:
            return False
        self._alarms_on.add(alarm)
        return True

    def _table_alarm(self, point: np.ndarray) -> bool:
        """React to a new alarm of the table-clearance guard (the pad's lowest corner, world, at
        ``alarm_key``): end the attempt, block the frontier towards the corner as the table's
        and back off away from it. True when it has just started backing off."""
        corner = read_or(self.alarm_key)
        if not self._alarm_begins("table", corner is not None):
            return False
        low = np.asarray(corner, dtype=float)[:2] - self.pose[:2, 3]
        low = low / max(float(np.linalg.norm(low)), 1e-9)
        why = "the table-clearance guard tripped"
        if self.map is not None:
            self._block(point, why, cause="table", direction=low)
        self._start_retreat(point, why, -low)
        return True

    def _supervisor_alarm(self, point: np.ndarray) -> bool:
        """React to an intervention of the supervisor (a force or pressure limit passed,
        :data:`~tactile_bt.tree.behaviours.supervision.RETREATING`): end the attempt, block the
        frontier it was heading for ("pressure", which explains nothing) and back off, rather
        than press on where the supervisor has just pulled the pad back (a pad rocking between
        the rims of a groove, its servo pressing it back onto one between the supervisor's
        retreats, until the grace time was over). Once per intervention. True when it has just
        started backing off."""
        if not self._alarm_begins("supervisor", bool(read_or(RETREATING, False))):
            return False
        why = f"the supervisor pulled back ({read_or(REASON, '')})"
        if self.map is not None and self.target is not None:
            self._block(point, why, cause="pressure")
        self._start_retreat(point, why)
        return True
