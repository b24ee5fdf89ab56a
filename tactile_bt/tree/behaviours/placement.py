"""Placing the pad on a low object without touching the table: where the contact sits on the pad,
and how the pad is turned about its normal.

A pad lying tangent to an object touches it at one place and overhangs it everywhere else. Tilted
by θ on a slope, its border on the downhill side lies ``e·sin θ`` below the contact, ``e`` the
distance from the contact to that border: half the pad's width when the contact is centred and
an edge faces downhill, half its diagonal when a corner does. On an object lying on the table
that border reaches the table long before the contact reaches the object's foot.

- ``table_offset`` moves the contact's target on the pad towards the downhill border, just so far
  that the pad's lowest corner stays ``clearance_m`` above the table (known from the set-up,
  ``/setup/table_z_m``): it writes the target centre of pressure to a blackboard key each cycle.
- ``centre_to`` and ``roll_to`` are ``centre`` and ``roll`` whose target follows that key every
  cycle (a blackboard reference is read only when a leaf starts).
- ``square_to_slope`` turns the pad about its normal (row ωz) until one of its edges faces
  downhill, so that its lowest point is an edge, not a corner. It reads the pose only.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Access, Status

from tactile_bt import defaults
from tactile_bt.control.chatter import RockingDetector
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.servo import Centre, Roll
from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, table_height
from tactile_bt.tree.behaviours.supervision import RETREATING
from tactile_bt.tree.blackboard import read, read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, Bound, between, normalise_key

__all__ = ["TableOffset", "CentreTo", "RollTo", "SquareToSlope"]


class TableOffset(TactileBehaviour):
    """Write the target centre of pressure ``[x, y]`` (m, sensor frame) that keeps the pad's
    lowest corner ``clearance_m`` above the table to ``key``, every cycle, and slide the pad
    by as much the other way (rows vx, vy); RUNNING.

    With the pad tilted by θ and the contact ``h`` above the table, the pad's border may reach
    ``(h - clearance_m) / sin θ`` downhill of the contact. The target is the pad centre moved
    towards the downhill border until the border lies that far from it, at most ``max_offset_m``
    from the centre; [0, 0] when the pad lies flat, when the table is far enough below, out of
    contact, or when no table is known (``table_key`` absent or NaN). The target moves at most
    ``rate_mps``; as it moves, the leaf slides the pad the opposite way at the same rate, so that
    the contact stays where it is on the object and only its place on the pad changes (rolling
    to a target downhill of the contact would carry the contact downhill too).
    """

    uses = frozenset({"cop"})
    key = Parameter("/scan/cop_target", fixed=True, doc="Blackboard key of the target (m, sensor frame).")
    clearance_m = Parameter(0.006, bound=NON_NEGATIVE, doc="Height the pad's lowest corner keeps above the table (m).")
    max_offset_m = Parameter(0.03, bound=NON_NEGATIVE, doc="Largest distance of the target from the pad centre (m).")
    rate_mps = Parameter(0.02, bound=POSITIVE, doc="Largest speed of the target on the pad (m/s).")
    smoothing_s = Parameter(0.2, bound=POSITIVE, doc="Time constant of the low-pass filter on the wanted target (s).")
    table_key = Parameter(TABLE_Z_KEY, fixed=True, doc="Blackboard key of the table's height (m, world z).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.key = normalise_key(self.key)
        self.table_key = normalise_key(self.table_key)
        self._writer = self.attach_blackboard_client(name=f"{self.name}/target")
        self._writer.register_key(key=self.key, access=Access.WRITE)
        self._setup = self.attach_blackboard_client(name=f"{self.name}/setup")
        self._setup.register_key(key=self.table_key, access=Access.READ)
        self.table_z_m = math.nan
        self.target = np.zeros(2)
        self._goal = np.zeros(2)
        write(self.key, (0.0, 0.0))

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        table_height(self._setup, self.table_key)  # a bad value fails before the mission runs

    def initialise(self) -> None:
        self.table_z_m = table_height(self._setup, self.table_key)
        write(self.key, tuple(self.target))

    def wanted(self, pose: np.ndarray, contact_z: float) -> np.ndarray:
        """The target (m, sensor frame) for the pad at ``pose`` touching at height ``contact_z``
        (m, world), before the rate limit."""
        if not math.isfinite(self.table_z_m):
            return np.zeros(2)
        down = -pose[2, :2]  # world -z in the sensor frame, its part in the pad plane
        sin_tilt = float(np.hypot(down[0], down[1]))
        if sin_tilt < 1e-3:
            return np.zeros(2)
        u = down / sin_tilt
        reach = max(0.0, contact_z - self.table_z_m - self.clearance_m) / sin_tilt
        extent = float(np.max(self.pad.corners_m()[:, :2] @ u))  # centre to the lowest corner, along u
        offset = min(max(extent - reach, 0.0), self.max_offset_m)
        return offset * u

    def update(self) -> Status:
        f = self.features
        if f.in_contact:
            T = self.pose
            x, y = f.cop_xy
            z = float(T[2, 0] * x + T[2, 1] * y + T[2, 3])
            # the wanted target, low-passed: the contact's height over sin(tilt) is noisy
            self._goal += (self.wanted(T, z) - self._goal) * min(1.0, self.dt / self.smoothing_s)
            step = self._goal - self.target
            n = float(np.hypot(step[0], step[1]))
            limit = self.rate_mps * self.dt
            if n > limit:
                step = step * (limit / n)
            self.target = self.target + step
            # Slide the pad the other way as the target moves: the contact then stays where it is
            # on the object and arrives at the new target without an error for roll to correct
            # (rolling towards a target downhill of the contact would carry the contact
            # downhill, tilt the pad further and ask for a larger offset).
            if n > 0:
                self.command.add(self.name, (-step[0] / self.dt, -step[1] / self.dt, 0.0, 0.0, 0.0, 0.0))
        write(self.key, (float(self.target[0]), float(self.target[1])))
        self._feedback = None
        return Status.RUNNING

    def describe(self) -> str:
        """The target written at the last tick (mm)."""
        return f"target [{self.target[0] * 1e3:.1f}, {self.target[1] * 1e3:.1f}] mm"


class _FollowKey:
    """Mixin of the servo leaves whose COP target follows a blackboard key every cycle, and
    that may servo the centre of pressure of every contact region together (``all_regions``)."""

    target_key = Parameter("/scan/cop_target", fixed=True,
                           doc="Blackboard key of the target ``[x, y]`` (m, sensor frame).")
    all_regions = Parameter(False, doc="Servo the centre of pressure of every contact region together "
                                       "(``load_cop_xy``), not the largest region's, while the pad bridges: where "
                                       "a flat pad rests on two rims of a hollow, the largest region changes sides "
                                       "from one frame to the next, and the pad would chase each in turn.")
    bridge_share = Parameter(0.2, bound=between(0, 0.5, low_open=True), unit=None,
                             doc="With ``all_regions``: the pad bridges when the smaller of the largest region "
                                 "and the others carries this share of the load; from half of it up, the servoed "
                                 "centre moves from the largest region's towards the common one.")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.target_key = normalise_key(self.target_key)
        self._target_client = self.attach_blackboard_client(name=f"{self.name}/target")
        self._target_client.register_key(key=self.target_key, access=Access.READ)

    def targets(self):
        try:
            x, y = read(self.target_key)
        except KeyError:
            x, y = self.target_m
        x, y = float(x), float(y)
        if self.all_regions:
            # the error target - servoed centre, written as a shifted target for the same formula
            cx, cy = self.features.cop_xy
            sx, sy = self.servoed_cop()
            x, y = x + cx - sx, y + cy - sy
        return (x, y), 0.0, 0.0

    def servoed_cop(self) -> tuple[float, float]:
        """The centre of pressure this leaf servos (m, sensor frame): the largest region's, or
        with ``all_regions``, while the pad bridges, every region's together (blended in from
        half of ``bridge_share`` to all of it, so that the servoed centre never jumps)."""
        f = self.features
        x, y = f.cop_xy
        if not (self.all_regions and f.in_contact and f.others_tactels > 0):
            return x, y
        blend = min(max(2.0 * f.lesser_share / self.bridge_share - 1.0, 0.0), 1.0)
        if not blend:
            return x, y
        lx, ly = f.load_cop_xy
        return x + blend * (lx - x), y + blend * (ly - y)


class CentreTo(_FollowKey, Centre):
    """``centre`` with its target centre of pressure read from ``target_key`` every cycle (m,
    sensor frame; ``target_m`` while the key is not set), e.g. written by ``table_offset``.
    """

    target_m = Centre.target_m.replace(doc="Target while the key is not set (m).")


class RollTo(_FollowKey, Roll):
    """``roll`` with its target centre of pressure read from ``target_key`` every cycle (m,
    sensor frame; ``target_m`` while the key is not set), e.g. written by ``table_offset``.

    It rolls the pad about the contact, not about the pad centre: with the contact ``(x, y)``
    away from the centre, turning by ``(ωx, ωy)`` about the centre would also move the contact
    along the normal by ``ωx·y − ωy·x`` and press the pad in or lift it off, which the force
    hold then has to undo (on a stiff object it starts oscillating). The leaf adds the opposite
    normal speed (row vz); for a contact at the centre, the paper's case, that is zero.

    With ``rocking_hold_s`` above 0 (0 by default), while the pad rocks between two contacts
    (:class:`~tactile_bt.control.chatter.RockingDetector`: the largest region changing sides
    twice within 0.5 s, each time by more than half the pad's width, another region under the
    pad) and the supervisor has pulled it back within ``rocking_pulled_back_s``, the leaf holds
    the pad's tilt: it adds nothing until ``rocking_hold_s`` after the rocking stops. A flat pad
    bridging a hollow narrower than itself rests on its two rims; rolled towards the one that
    bears more, it presses the other, which then bears more, and the pad rocks from rim to rim,
    pressing each rim's narrow contact in turn (on a groove past twice the pressure target, until
    the supervisor ended the scan). Rocking that presses nothing that hard is left alone: a pad
    bridging a ring's hole rolls into its inner slope that way.
    """

    target_m = Roll.target_m.replace(doc="Target while the key is not set (m).")
    rocking_hold_s = Parameter(0.0, bound=NON_NEGATIVE,
                               doc="While the pad rocks between two contacts, the supervisor having pulled it back, "
                                   "and this long after, the leaf holds the pad's tilt (adds nothing) (s; 0: never; "
                                   "0.3 s holds a rocking pad on a groove's rims).")
    rocking_pulled_back_s = Parameter(defaults.ROCKING_PULLED_BACK_S, bound=Bound(0.0, allow_inf=True),
                                      doc="A rocking pad's tilt is held when the supervisor pulled it back within this "
                                          "time (s; inf: whenever it rocks).")

    def parameters_changed(self, changed: frozenset[str]) -> None:
        super().parameters_changed(changed)
        if "rocking_hold_s" in changed:
            # kept when the leaf starts again: whether the pad rocks is the contact's state, and a
            # scan's next attempt often begins where the last one ended
            self.rocking = RockingDetector(defaults.ROCKING_JUMP_SHARE, defaults.ROCKING_CHANGES,
                                           defaults.ROCKING_WINDOW_S, self.rocking_hold_s)
            self._pulled_back_at = -math.inf  # when the supervisor last pulled the pad back (s)

    def _holds_the_tilt(self) -> bool:
        """Whether the pad rocks, the supervisor having pulled it back within ``rocking_pulled_back_s``."""
        f = self.features
        now = self.now
        if read_or(RETREATING, False):
            self._pulled_back_at = now
        rocking = self.rocking.update(now, f.in_contact, f.cop_xy, f.others_tactels > 0, min(f.pad.size_m))
        return rocking and now - self._pulled_back_at <= self.rocking_pulled_back_s

    def update(self) -> Status:
        if self.rocking_hold_s > 0 and self._holds_the_tilt():
            self._last_twist = (0.0,) * 6
            self._feedback = "holding the tilt: the pad rocks between two contacts"
            return Status.RUNNING
        status = super().update()
        wx, wy = self._last_twist[3], self._last_twist[4]
        if wx or wy:
            x, y = self.servoed_cop()
            self.command.add(self.name, (0.0, 0.0, wy * x - wx * y, 0.0, 0.0, 0.0))
        return status


#: ``square_to_slope`` keeps turning to the same edge until another is nearer by this much (rad).
_HYSTERESIS_RAD = math.radians(10.0)


class SquareToSlope(TactileBehaviour):
    """Turn the pad about its normal (row ωz) until one of its edges faces downhill: the
    direction of steepest descent in the pad's plane lies along ±x or ±y of the sensor frame,
    so the pad's lowest point is an edge, not a corner. Adds ``ωz = kp · error`` (at most
    ``output_limit``) while the pad is tilted more than ``min_tilt_rad`` and in contact; RUNNING.
    The error comes from the pose alone. The pad turns about the contact (the centre of
    pressure ``(x, y)``: it adds ``vx = ωz·y, vy = −ωz·x``), so that a contact away from the
    centre keeps its place on the pad instead of being swept towards the border.

    Of the four edges it turns to the nearest one, never more than 45° (plus a hysteresis of
    10° for the edge it turned to before) away: a larger turn would swing a corner through the
    downhill direction, down towards the table. It never turns the pad more than
    ``max_turn_rad`` from where it was when the leaf started (it counts its own turns): going
    round an object, the pad would otherwise wind up its wrist joint to the limit. At that
    limit it holds, a corner drifting downhill, until the downhill direction has passed the
    pad's diagonal and the edge on the other side, back within the limit, is the nearest one.
    """

    uses = frozenset({"cop"})
    kp = Parameter(1.0, bound=NON_NEGATIVE, unit="1/s", doc="Proportional gain ((rad/s)/rad = 1/s).")
    output_limit = Parameter(0.5, bound=POSITIVE, unit="rad/s", doc="Largest turning rate (rad/s).")
    min_tilt_rad = Parameter(math.radians(5.0), bound=between(0, math.pi / 2),
                             doc="Below this tilt from the vertical the pad is level enough: nothing is added (rad).")
    max_turn_rad = Parameter(math.radians(120.0), bound=between(math.pi / 4, math.pi),
                             doc="Largest turn about the pad normal from the start (rad, either way).")
    error_rad = math.nan
    turned_rad = 0.0

    def initialise(self) -> None:
        self.turned_rad = 0.0
        self.error_rad = math.nan

    def error(self, pose: np.ndarray) -> float:
        """Turn (rad, about +z of the sensor frame) that brings a pad axis onto the downhill
        direction: the nearest one within ``max_turn_rad`` of the start; NaN when the pad is
        level within ``min_tilt_rad``."""
        down = -pose[2, :2]
        if math.hypot(down[0], down[1]) < math.sin(self.min_tilt_rad):
            return math.nan
        angle = math.atan2(down[1], down[0])  # of the downhill direction, from +x towards +y
        # turning the pad by +δ turns the direction in its frame by -δ: the turns that put an
        # axis on it are angle - k·90°
        quarter = math.pi / 2
        nearest = angle - round(angle / quarter) * quarter
        last = self.error_rad

        def cost(e: float) -> float:  # the nearest edge, the one turned to before by 10° more
            switch = last == last and abs(e - last) > quarter / 2
            return abs(e) + (_HYSTERESIS_RAD if switch else 0.0)

        # the edges at most 45° (55° for the one turned to before) away: turning to another
        # edge would swing a corner through the downhill direction, down towards the table
        near = [e for e in (nearest + k * quarter for k in (-1, 0, 1)) if abs(e) <= quarter / 2 + _HYSTERESIS_RAD]
        e = min(near, key=cost)
        limit = self.max_turn_rad
        if abs(self.turned_rad + e) <= limit:
            return e
        # at the turn limit: hold there, a corner drifting downhill, until the downhill
        # direction has passed the diagonal and the edge on the other side is the nearest
        return math.copysign(limit, self.turned_rad + e) - self.turned_rad

    def update(self) -> Status:
        self.error_rad = e = self.error(self.pose)
        if e != e or not self.features.in_contact:
            self.feedback_message = "level" if e != e else "no contact"
            return Status.RUNNING
        w = max(-self.output_limit, min(self.output_limit, self.kp * e))
        x, y = self.features.cop_xy  # turn about the contact: it keeps its place on the pad
        self.command.add(self.name, (w * y, -w * x, 0.0, 0.0, 0.0, w))
        self.turned_rad += w * self.dt
        self._feedback = None
        return Status.RUNNING

    def describe(self) -> str:
        """Error and turn so far (deg)."""
        return f"error {math.degrees(self.error_rad):+.1f}°, turned {math.degrees(self.turned_rad):+.0f}°"
