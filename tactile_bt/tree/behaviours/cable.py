"""``cable_end``: the end of a cable found by touch, or the line reported lost.

While the pad slides along a cable, the cable's imprint is a line through the pad centre along
the direction of travel that crosses the pad from border to border (centring and edge alignment
keep it there). Each cycle the leaf judges whether the contact still looks like that, from the
part of it within ``window_m`` of the pad centre along the travel (a bend ahead of the pad
centre is not yet the pad's business; the shape comes from :mod:`.line_shape`):

* **a line**: its tactels are spread along one axis (across it at most ``max_width_m`` wide,
  the width of a uniform band with the same spread) and cover at most ``max_area_ratio`` of the
  pad's tactels in the window — otherwise a ``patch``;
* **along the travel**: its orientation is within ``max_turn_rad`` of the direction of travel —
  otherwise ``turned``;
* **the same line**: its axis moved less than ``max_jump_m`` across the pad since the last
  cycle — otherwise ``jumped`` (another line took its place);
* **through the centre**: its axis passes within ``max_offset_m`` of the pad centre —
  otherwise ``offset``;
* **reaching ahead**: its leading end lies at least ``reach_m`` ahead of the pad centre —
  otherwise ``short``, and the end is *in view* when the line's leading half touches no border
  of the pad (the end lies inside the pad, not beyond a border it left through).

Success needs evidence of the end: most cycles of the last ``dwell_s`` say ``short``, or the
contact stops being the line (a patch, the pad's edge on the table, no contact) within
``end_memory_m`` of travel after a settled line's end was in view. Any other way of leaving the
line — turning away faster than the pad follows, sliding out sideways, flattening into a patch,
another line in its place, contact lost — is a loss, and so is a pad that stops advancing along
the line (less than ``min_headway_m`` in ``stall_s``: e.g. the arm holds a joint on its limit):
FAILURE with a message that says what was lost where (``cable lost: the line left the pad
sideways 212 mm along the path``), so that the tree can back up and re-acquire the line
(:mod:`tactile_bt.tree.behaviours.cable_recovery`).

Every cycle the leaf writes whether the contact is the followed line to ``on_line_key``
(``record_contacts: {only_when: /cable/on_line}``), appends the pad pose of on-line cycles to
the path record ``path_key`` (:class:`~tactile_bt.tree.behaviours.cable_recovery.PadPath`), and
with ``keep_line`` asks feature extraction for the contact region nearest to where the line was
last seen (:meth:`CableEnd.region_hint`) instead of the largest one, so that another strand
under the pad does not replace the followed one, and for the centre of pressure and orientation
of the line's part within ``window_m`` of that point, so that the servos follow the line where
the pad centre is, not a bend ahead of it.

Layer: tree.
"""

from __future__ import annotations

import math
from collections import Counter, deque

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.perception.features import wrap_half_pi
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.cable_recovery import CableLoss, PadPath
from tactile_bt.tree.behaviours.line_shape import along, leading_border, line_reach, line_shape, reach, windowed_basis
from tactile_bt.tree.blackboard import FEATURES_RAW, POSE, TIME, read, read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between, normalise_key

__all__ = ["CableEnd", "line_reach"]


class CableEnd(TactileBehaviour):
    """SUCCESS at the end of a cable, FAILURE when the line is lost (see the module docstring);
    RUNNING while the line goes on.

    The defaults leave wide margins to what following shows on the shipped cables (from 2 to
    6 mm thick, soft and stiff, bends down to 30 mm radius): 3 to 4 tactels wide, within a few
    degrees of the travel and 0.7 px of the centre, reaching the leading border.
    """

    uses = frozenset({"pressure", "orientation"})
    reports_success = True

    direction_rad = Parameter(math.pi / 2, doc="Direction of travel in the sensor frame, from +x towards +y (rad); "
                                               "``pi/2`` is the sensor y axis, along which ``guided_slide`` moves the "
                                               "pad in the cable trees.")
    reach_m = Parameter(0.015, bound=NON_NEGATIVE,
                        doc="The line ends under the pad when its leading end is less than this far ahead of the pad "
                            "centre (m; ``3 px`` are three tactels of the pad). The imprint reaches a tactel or two "
                            "beyond the cable's end (the foam spreads the load), so 15 mm ends the follow with the "
                            "end of the cable about at the pad centre.")
    max_offset_m = Parameter(0.010, bound=NON_NEGATIVE, doc="Largest distance of the line's axis from the pad centre (m).")
    max_turn_rad = Parameter(math.radians(20.0), bound=between(0.0, math.pi / 2),
                             doc="Largest angle between the line (near the pad centre) and the direction of travel "
                                 "(rad).")
    window_m = Parameter(0.02, bound=POSITIVE,
                         doc="Half-length of the part of the contact along the travel, around the pad centre, that is "
                             "judged a line (m); with ``keep_line`` also that of the part of the followed line whose "
                             "centre of pressure and orientation the servos see (a bend ahead of it does not turn the "
                             "pad before its centre gets there).")
    max_jump_m = Parameter(0.008, bound=POSITIVE,
                           doc="Largest move of the line's axis across the pad from one cycle to the next (m); more "
                               "is another line in its place.")
    max_width_m = Parameter(0.03, bound=POSITIVE, doc="Above this width across its axis the contact is no line (m).")
    max_area_ratio = Parameter(0.5, bound=between(0.0, 1.0, low_open=True), unit=None,
                               doc="Above this share of the pad's tactels within ``window_m`` of its centre the "
                                   "contact is no line.")
    lost_s = Parameter(0.3, bound=NON_NEGATIVE,
                       doc="Time without contact that ends the follow (s): the end when it was in view, a loss "
                           "otherwise.")
    dwell_s = Parameter(0.1, bound=NON_NEGATIVE,
                        doc="A verdict counts when it was given in more than half of the cycles of the last "
                            "``dwell_s`` of mission time (a single odd frame decides nothing).")
    end_memory_m = Parameter(0.02, bound=NON_NEGATIVE,
                             doc="Pad travel (m) after the line's end was last in view during which a contact that "
                                 "stops being the line is still the end of the cable (the pad tips onto the table "
                                 "past it).")
    min_headway_m = Parameter(0.005, bound=NON_NEGATIVE,
                              doc="The follow has stalled when the pad centre moved less than this in ``stall_s`` (m).")
    stall_s = Parameter(5.0, bound=NON_NEGATIVE,
                        doc="Mission time over which the headway is measured (s; 0 = no stall check).")
    keep_line = Parameter(True, doc="Ask feature extraction for the contact region nearest to where the followed line "
                                    "was last seen (False: the largest region, the paper's rule).")
    on_line_key = Parameter("/cable/on_line", fixed=True,
                            doc="Blackboard key written every cycle: whether the contact is the followed line.")
    path_key = Parameter("/cable/path", fixed=True,
                         doc="Blackboard key of the pad path recorded in on-line cycles (a ``PadPath``, kept across "
                             "restarts of the leaf within a mission; ``backtrack`` follows it back).")
    lost_key = Parameter("/cable/lost", fixed=True,
                         doc="Blackboard key the leaf writes a ``CableLoss`` to when it loses the line.")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.on_line_key = normalise_key(self.on_line_key)
        self.path_key = normalise_key(self.path_key)
        self.lost_key = normalise_key(self.lost_key)
        self._writer = self.attach_blackboard_client(name=f"{self.name}/on_line")
        for key in (self.on_line_key, self.path_key, self.lost_key):
            self._writer.register_key(key=key, access=Access.WRITE)
        self._window: deque[tuple[float, str]] = deque()
        self._gone = 0  # verdicts in the window that say the contact is not the line
        self._lost_since: float | None = None
        self._judged_since: float | None = None  # the first verdict of the current window
        self.reach_px = math.nan
        self._cache = (None, math.nan, math.nan, None, None, None)  # pad, direction, window; along, leading, basis
        self._path: PadPath | None = None
        self._hint: tuple[float, float] | None = None
        self._window_px: tuple[float, float, float] | None = None
        self._offset_px = math.nan  # signed distance of the last line's axis from the pad centre
        self._end_in_view_s = -math.inf  # path length at which a settled line's end was last in view
        self._jumped_s = -math.inf
        self._resumed_s = 0.0  # path length when the leaf (re)started
        self._headway: deque[tuple[float, list[float]]] = deque()  # (time, pad position) every 0.5 s

    def setup(self, **kwargs) -> None:
        """A new mission: a new, empty path record and no loss (the blackboard outlives missions)."""
        super().setup(**kwargs)
        write(self.path_key, PadPath())
        write(self.lost_key, None)

    def initialise(self) -> None:
        self._window.clear()
        self._gone = 0
        self._lost_since = None
        self._judged_since = None
        self.reach_px = math.nan
        self.feedback_message = ""
        write(self.on_line_key, False)
        path = read_or(self.path_key)
        if not isinstance(path, PadPath):
            path = PadPath()
            write(self.path_key, path)
        self._path = path
        path.resume(read(POSE))
        self._resumed_s = path.length_m
        self._hint = None
        self._offset_px = math.nan
        self._end_in_view_s = -math.inf
        self._jumped_s = -math.inf
        self._headway.clear()

    def _stalled(self, now: float, pose: np.ndarray) -> bool:
        """Whether the pad centre moved less than ``min_headway_m`` in the last ``stall_s``."""
        if self.stall_s <= 0:
            return False
        headway = self._headway
        if headway and now - headway[-1][0] < 0.5:
            return False  # judged on the samples, every 0.5 s
        position = pose[:3, 3].tolist()
        headway.append((now, position))
        if now - headway[0][0] < self.stall_s:
            return False
        while len(headway) > 1 and now - headway[1][0] >= self.stall_s:
            headway.popleft()
        return math.dist(position, headway[0][1]) < self.min_headway_m

    def region_hint(self) -> tuple[tuple[float, float] | None, tuple[float, float, float] | None]:
        """Where feature extraction should look for the followed line (its ``near_px`` and
        ``window_px``): the point of the line's last seen axis nearest the pad centre (tactels,
        ``[column, row]``; the pad centre before the line was seen), and the window of
        ``window_m`` along that axis whose part of the line the servos see; ``(None, None)``
        with ``keep_line`` off (the largest region, the whole of it)."""
        if not self.keep_line:
            return None, None
        if self._hint is None:
            pad = self.pad
            return pad.centre_px, (math.cos(self.direction_rad), math.sin(self.direction_rad), self.window_m / pad.pitch)
        return self._hint, self._window_px

    def judge(self, f) -> str:
        """Why the contact ``f`` is not the followed line (a short word, see the module
        docstring), or ``""`` when it is."""
        pad = f.pad
        cached_pad, direction, window, along_travel, leading, basis = self._cache
        if pad is not cached_pad or direction != self.direction_rad or window != self.window_m:
            direction, window = self.direction_rad, self.window_m
            key = (pad.shape, pad.centre_px, float(direction))
            along_travel, leading = along(*key), leading_border(*key)
            basis = windowed_basis(*key, window / pad.pitch)
            self._cache = (pad, direction, window, along_travel, leading, basis)
        width, axis, mx, my, n = line_shape(f.mask, basis)
        if n > self.max_area_ratio * basis[0].sum() or width * pad.pitch > self.max_width_m or not math.isfinite(axis):
            return "patch"
        turn = wrap_half_pi(axis - self.direction_rad)
        if abs(turn) > self.max_turn_rad:
            return "turned"
        axis = self.direction_rad + turn  # pointing along the travel: the offset's sign is kept
        cx, cy = pad.centre_px
        ux, uy = math.cos(axis), math.sin(axis)
        offset = (mx - cx) * uy - (my - cy) * ux  # signed distance of the axis from the centre (tactels)
        previous, self._offset_px = self._offset_px, offset
        if abs(offset - previous) * pad.pitch > self.max_jump_m:
            return "jumped"
        if abs(offset) * pad.pitch > self.max_offset_m:
            return "offset"
        along_axis = (cx - mx) * ux + (cy - my) * uy
        self._hint = (mx + along_axis * ux, my + along_axis * uy)
        self._window_px = (ux, uy, self.window_m / pad.pitch)
        self.reach_px = reach(along_travel, f.mask)
        if not f.mask.ravel()[leading].any():
            self._end_in_view_s = self._path.length_m
            if self.reach_px * pad.pitch < self.reach_m:
                return "short"
        return ""

    def update(self) -> Status:
        f = read(FEATURES_RAW)
        now = read(TIME)
        path = self._path
        pose = read(POSE)
        path.advance(pose)
        if self._stalled(now, pose):
            return self._finish("stalled")
        if not f.in_contact:
            write(self.on_line_key, False)
            self._window.clear()
            self._gone = 0
            self._judged_since = None
            self._offset_px = math.nan
            if self._lost_since is None:
                self._lost_since = now
            if now - self._lost_since >= self.lost_s:
                return self._finish("none")
            self.feedback_message = f"no contact for {now - self._lost_since:.2f} s"
            return Status.RUNNING
        self._lost_since = None
        verdict = self.judge(f)
        on_line = not verdict
        write(self.on_line_key, on_line)
        if on_line:
            path.record(read(POSE))
        elif verdict == "jumped":
            self._jumped_s = path.length_m
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
        if on_line or now - self._judged_since < self.dwell_s - 1e-9 or 2 * self._gone <= len(window):
            if verdict:
                self.feedback_message = verdict
            else:
                self._feedback = None  # described when read
            return Status.RUNNING
        return self._finish(Counter(v for _, v in window if v).most_common(1)[0][0])

    def _finish(self, verdict: str) -> Status:
        """SUCCESS when ``verdict`` (the prevailing one) ends a line whose end was in view,
        FAILURE with a :class:`CableLoss` on the blackboard otherwise."""
        path = self._path
        if verdict == "short":
            self.feedback_message = (f"end of cable: the line ends inside the pad, "
                                     f"{self.reach_px * self.pad.pitch * 1e3:.0f} mm ahead of its centre")
            return Status.SUCCESS
        since_end = path.length_m - self._end_in_view_s
        if verdict in _AFTER_END and since_end <= self.end_memory_m:
            self.feedback_message = (f"end of cable: the line's end was in view {since_end * 1e3:.0f} mm before "
                                     f"{_AFTER_END[verdict]}")
            return Status.SUCCESS
        if verdict == "offset" and path.length_m - self._jumped_s <= self.end_memory_m:
            verdict = "jumped"
        what = _LOSSES[verdict]
        prefix = "cable follow stalled" if verdict == "stalled" else "cable lost"
        where = f"{path.length_m * 1e3:.0f} mm along the path"
        if path.resumed and path.length_m - self._resumed_s < self.end_memory_m:
            message = f"{prefix}: {path.first_loss}; re-acquiring failed ({what} {where})"
        elif path.resumed:
            message = f"{prefix}: {what} {where} (after {len(path.losses)} earlier, the first: {path.first_loss})"
        else:
            message = f"{prefix}: {what} {where}"
        loss = CableLoss(what=what, path_m=path.length_m, time_s=read(TIME), message=message)
        path.lost(loss)
        write(self.lost_key, loss)
        self.feedback_message = message
        return Status.FAILURE

    def describe(self) -> str:
        """On the line: how far it reaches ahead of the pad centre."""
        return f"on the line, reaching {self.reach_px:.1f} px ahead"


#: What the contact became after the line's end was in view (the end of the cable).
_AFTER_END = {
    "patch": "the contact became a patch (the pad is on the table)",
    "offset": "the contact left the pad centre (the pad's edge is on the table)",
    "turned": "the contact turned away (the cable's end under the pad)",
    "none": "contact ended",
}
#: How the line was lost, for each verdict.
_LOSSES = {
    "patch": "the line flattened into a patch",
    "turned": "the line turned away faster than the pad followed",
    "offset": "the line left the pad sideways",
    "jumped": "another line took the followed line's place",
    "none": "contact ended",
    "stalled": "the pad stopped advancing along the line",
}
