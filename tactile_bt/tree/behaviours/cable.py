"""``cable_end``: the end of a cable, found by touch.

While the pad slides along a cable, the cable's imprint is a line through the pad centre along
the direction of travel that crosses the pad from border to border (centring and edge alignment
keep it there). Each cycle the leaf judges whether the contact still looks like that:

* **a line**: its tactels are spread along one axis (anisotropy at least ``min_anisotropy``) and
  cover at most ``max_area_ratio`` of the pad — otherwise the pad lies on the table;
* **through the centre**: the line's axis passes within ``max_offset_m`` of the pad centre — a
  contact at the pad's border is the pad's edge on the table;
* **along the travel**: its orientation is within ``max_turn_rad`` of the direction of travel;
* **reaching ahead**: its leading end lies at least ``reach_m`` ahead of the pad centre —
  otherwise the cable ends under the pad.

It writes the judgement to ``on_line_key`` (``record_contacts: {only_when: /cable/on_line}``
records only then, so no contact that is not on the cable enters the cloud) and succeeds, with
the reason in its feedback message, once most cycles of the last ``dwell_s`` of mission time
(or ``lost_s`` without contact) say the line is gone. In a ``parallel`` with ``success_on_one``
it ends a cable-following branch by touch, whatever the mission's budget.

Layer: tree.
"""

from __future__ import annotations

import functools
import math
from collections import deque

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.perception.features import wrap_half_pi
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.blackboard import FEATURES_RAW, TIME, read, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, between, normalise_key

__all__ = ["CableEnd", "line_reach"]


@functools.lru_cache(maxsize=16)
def _grid(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Column and row index of every tactel of a ``shape`` pad, flattened (row-major), as floats."""
    rows, cols = np.indices(shape, dtype=float)
    return cols.ravel(), rows.ravel()


@functools.lru_cache(maxsize=16)
def _along(shape: tuple[int, int], centre_px: tuple[float, float], direction_rad: float) -> np.ndarray:
    """Position of every tactel along ``direction_rad`` from the pad centre (tactels), flattened."""
    x, y = _grid(shape)
    return (x - centre_px[0]) * math.cos(direction_rad) + (y - centre_px[1]) * math.sin(direction_rad)


@functools.lru_cache(maxsize=16)
def _moment_basis(shape: tuple[int, int]) -> np.ndarray:
    """Rows 1, x, y, x², y², x·y over the tactels of a ``shape`` pad (x = column, y = row): one
    product with a mask gives every sum :func:`_shape` needs."""
    x, y = _grid(shape)
    return np.stack((np.ones_like(x), x, y, x * x, y * y, x * y))


def line_reach(mask: np.ndarray, centre_px: tuple[float, float], direction_rad: float) -> float:
    """How far (tactels) the contact region ``mask`` reaches ahead of the pad centre along
    ``direction_rad`` (sensor frame, from +x towards +y): the largest projection of its tactels,
    plus half a tactel (a tactel's far edge). ``-inf`` for an empty mask."""
    return _reach(_along(mask.shape, tuple(centre_px), float(direction_rad)), mask)


def _reach(along: np.ndarray, mask: np.ndarray) -> float:
    """:func:`line_reach` from the tactels' positions ``along`` the direction (flattened)."""
    ahead = along[mask.ravel()]
    return float(ahead.max()) + 0.5 if ahead.size else -math.inf


def _shape(mask: np.ndarray) -> tuple[float, float]:
    """Anisotropy ``(l1 - l2) / (l1 + l2)`` (1 for a line, 0 for a disc) and axis angle (rad,
    from +x towards +y) of the tactel positions of ``mask`` (second moments by one matrix
    product, exact sums of small integers: this runs every control cycle)."""
    n, sum_x, sum_y, sum_xx, sum_yy, sum_xy = (_moment_basis(mask.shape) @ mask.ravel().astype(float)).tolist()
    if n < 3:
        return 1.0, math.nan
    mx, my = sum_x / n, sum_y / n
    sxx = sum_xx / n - mx * mx
    syy = sum_yy / n - my * my
    sxy = sum_xy / n - mx * my
    total = sxx + syy
    if total <= 0:
        return 0.0, math.nan
    return math.hypot(sxx - syy, 2.0 * sxy) / total, 0.5 * math.atan2(2.0 * sxy, sxx - syy)


class CableEnd(TactileBehaviour):
    """SUCCESS at the end of a cable (see the module docstring); RUNNING while the line goes on.

    The defaults leave wide margins to what following shows on the shipped cables (from 3 to
    6 mm thick, soft and stiff, bends down to 51 mm radius): anisotropy at least 0.82, the line
    within 3° of the travel and 0.7 px of the centre, reaching the leading border.
    """

    uses = frozenset({"pressure", "orientation"})
    reports_success = True

    direction_rad = Parameter(math.pi / 2, doc="Direction of travel in the sensor frame, from +x towards +y (rad); "
                                               "``pi/2`` is the sensor y axis, along which ``guided_slide`` moves the "
                                               "pad in the cable trees.")
    reach_m = Parameter(0.015, bound=NON_NEGATIVE,
                        doc="The line has ended when its leading end is less than this far ahead of the pad centre "
                            "(m; ``3 px`` are three tactels of the pad). The imprint reaches a tactel or two beyond "
                            "the cable's end (the foam spreads the load), so 15 mm ends the follow with the end of "
                            "the cable about at the pad centre.")
    max_offset_m = Parameter(0.010, bound=NON_NEGATIVE, doc="Largest distance of the line's axis from the pad centre (m).")
    max_turn_rad = Parameter(math.radians(10.0), bound=between(0.0, math.pi / 2),
                             doc="Largest angle between the line and the direction of travel (rad).")
    min_anisotropy = Parameter(0.7, bound=between(0.0, 1.0), unit=None,
                               doc="Below this the contact is no line: ``(l1 - l2) / (l1 + l2)`` of its tactel "
                                   "positions.")
    max_area_ratio = Parameter(0.35, bound=between(0.0, 1.0, low_open=True), unit=None,
                               doc="Above this share of the pad's tactels the contact is no line.")
    lost_s = Parameter(0.3, bound=NON_NEGATIVE, doc="Time without contact taken as the end (s).")
    dwell_s = Parameter(0.1, bound=NON_NEGATIVE,
                        doc="The line is gone when it was judged gone in more than half of the cycles of the last "
                            "``dwell_s`` of mission time (a single odd frame decides nothing).")
    on_line_key = Parameter("/cable/on_line", fixed=True,
                            doc="Blackboard key written every cycle: whether the contact is the followed line.")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.on_line_key = normalise_key(self.on_line_key)
        self._writer = self.attach_blackboard_client(name=f"{self.name}/on_line")
        self._writer.register_key(key=self.on_line_key, access=Access.WRITE)
        self._window: deque[tuple[float, str]] = deque()
        self._gone = 0  # verdicts in the window that say the line is gone
        self._lost_since: float | None = None
        self._judged_since: float | None = None  # the first verdict of the current window
        self.reach_px = math.nan
        self._along_of = (None, math.nan, None)  # (pad, direction, tactels along it): judge's cache

    def initialise(self) -> None:
        self._window.clear()
        self._gone = 0
        self._lost_since = None
        self._judged_since = None
        self.reach_px = math.nan
        self.feedback_message = ""
        write(self.on_line_key, False)

    def judge(self, f) -> str:
        """Why the contact ``f`` is not the followed line (a short word), or ``""`` when it is."""
        pad = f.pad
        if f.area > self.max_area_ratio * pad.tactels:
            return "patch"
        anisotropy, axis = _shape(f.mask)
        if anisotropy < self.min_anisotropy or not math.isfinite(axis):
            return "patch"
        if abs(wrap_half_pi(axis - self.direction_rad)) > self.max_turn_rad:
            return "turned"
        cx, cy = pad.centre_px
        px, py = f.cop_px.tolist()
        dx, dy = px - cx, py - cy
        if abs(dx * math.sin(axis) - dy * math.cos(axis)) * pad.pitch > self.max_offset_m:
            return "offset"
        cached_pad, direction, along = self._along_of
        if pad is not cached_pad or direction != self.direction_rad:
            direction = self.direction_rad
            along = _along(pad.shape, pad.centre_px, float(direction))
            self._along_of = (pad, direction, along)
        self.reach_px = _reach(along, f.mask)
        if self.reach_px * pad.pitch < self.reach_m:
            return "short"
        return ""

    def update(self) -> Status:
        f = read(FEATURES_RAW)
        now = read(TIME)
        if not f.in_contact:
            write(self.on_line_key, False)
            self._window.clear()
            self._gone = 0
            self._judged_since = None
            if self._lost_since is None:
                self._lost_since = now
            if now - self._lost_since >= self.lost_s:
                self.feedback_message = "contact lost: the pad has left the cable (taken as its end)"
                return Status.SUCCESS
            self.feedback_message = f"no contact for {now - self._lost_since:.2f} s"
            return Status.RUNNING
        self._lost_since = None
        verdict = self.judge(f)
        write(self.on_line_key, not verdict)
        window = self._window
        if self._judged_since is None:
            self._judged_since = now
        window.append((now, verdict))
        if verdict:
            self._gone += 1
        while window[0][0] < now - self.dwell_s - 1e-9:
            if window.popleft()[1]:
                self._gone -= 1
        # A verdict needs dwell_s of judging behind it: measured from the first verdict, not from the
        # oldest one in the window (with a real sensor's frame times, that one is always younger).
        if not verdict or now - self._judged_since < self.dwell_s - 1e-9 or 2 * self._gone <= len(window):
            if verdict:
                self.feedback_message = verdict
            else:
                self._feedback = None  # described when read
            return Status.RUNNING
        gone = [v for _, v in window if v]
        self.feedback_message = "end of cable: " + _REASONS[max(set(gone), key=gone.count)]
        return Status.SUCCESS

    def describe(self) -> str:
        """On the line: how far it reaches ahead of the pad centre."""
        return f"on the line, reaching {self.reach_px:.1f} px ahead"


#: What each verdict of :meth:`CableEnd.judge` means at the end of a follow.
_REASONS = {
    "patch": "the contact is no line any more (the pad is on the table)",
    "turned": "the contact turned away from the direction of travel",
    "offset": "the contact left the pad centre (the pad's edge is on the table)",
    "short": "the line ends under the pad",
}
