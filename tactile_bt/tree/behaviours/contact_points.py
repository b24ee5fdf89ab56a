"""The ``record_contacts`` leaf: the robot as a ruler (paper Sec. IV). Each cycle in contact, the
centre of pressure (or the whole contact imprint) is carried to the base frame through the
forward kinematics ``T_gs`` into the mission's contact cloud
(:class:`~tactile_bt.contacts.cloud.ContactCloud`, on the blackboard).

Only a settled contact is a measurement: the pad surface lies inside the object by what the
pressure compresses, so a contact pressed far above its target, a pad that bridges a hollow
(two regions at its borders, each pressed in deep) or a pad still moving into the object
records points that lie inside it. The leaf records a cycle only while the smoothed pressure
lies between ``min_pressure_ratio`` and ``max_pressure_ratio`` times the pressure target (the
adapted one of ``target_key`` when written, :mod:`tactile_bt.tree.behaviours.stiffness`) and the
pad moves into the object at most at ``max_approach_mps``. A contact point (``cop``, ``local``)
is recorded only while the contact is one region (any other region carries at most
``other_region_share`` of its force): the centre of pressure of a pad bridging a hollow lies
between its two contacts. An imprint (``point: region``) is the largest region's alone, so a
second region does not stop it (a flat pad bridging a hollow touches at its borders only, and
would otherwise record nothing there). Within a settled contact every point lies inside the
object by what its own pressure compresses the foam and the object: the centre of a curved
contact is pressed more than the region's mean, and is recorded all the same.

Layer: tree.
"""

from __future__ import annotations

import functools
import math
from typing import Literal

import numpy as np
from py_trees.common import Access, Status

from tactile_bt import defaults
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.blackboard import FEATURES, FEATURES_RAW, POSE, TIME, pressure_target, read, read_or
from tactile_bt.tree.behaviours.stiffness import FORCE_TARGET_KEY
from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, table_height
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, POSITIVE_OR_INF, between, normalise_key
from tactile_bt.perception.features import line_spans_window, local_contact_point
from tactile_bt.sense.geometry import PadGeometry

__all__ = ["RecordContacts", "drawn_in", "imprint_points", "other_contact"]

_SQRT2 = math.sqrt(2.0)
#: An imprint reaching at most this many tactels beyond the half-width :func:`drawn_in` finds is
#: left as it is: the half-peak contour of a flat contact lies on its border to within a fraction
#: of a tactel, which the strip's width taken from the spread does not match as closely.
_DRAW_IN_SLACK = 0.25


@functools.lru_cache(maxsize=8)
def _imprint_grid(pad: PadGeometry, step: float):
    """Bilinear interpolation matrices from tactel centres to a grid of sample points covering
    the pad at spacing ``step`` (m), and the samples' sensor-frame x, y (m), row-major."""
    pitch = pad.pitch

    def axis(n: int) -> tuple[np.ndarray, np.ndarray]:
        count = max(1, int(round(n * pitch / step)))
        # sample centres across the pad's full width, in tactel units (tactel centres at 0..n-1)
        u = (np.arange(count) + 0.5) * (n / count) - 0.5
        uc = np.clip(u, 0.0, n - 1.0)
        lo = np.minimum(np.floor(uc).astype(int), n - 2) if n > 1 else np.zeros(count, int)
        frac = uc - lo
        A = np.zeros((count, n))
        A[np.arange(count), lo] += 1.0 - frac
        if n > 1:
            A[np.arange(count), lo + 1] += frac
        return A, (u - (n - 1) * 0.5) * pitch

    A_r, y = axis(pad.rows)
    A_c, x = axis(pad.cols)
    X, Y = np.meshgrid(x, y)  # (len(y), len(x)): rows of samples along y
    xy = np.column_stack((X.ravel(), Y.ravel(), np.zeros(X.size)))
    return A_r, A_c, xy


def _dilated(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one tactel along rows and columns: ``scipy.ndimage.binary_dilation``
    with its default cross-shaped element and nothing beyond the border, in four slices."""
    region = mask.copy()
    region[1:] |= mask[:-1]
    region[:-1] |= mask[1:]
    region[:, 1:] |= mask[:, :-1]
    region[:, :-1] |= mask[:, 1:]
    return region


def other_contact(features) -> tuple[float, int]:
    """Force (N) and tactels of the contact outside the largest region and its fringe: a second
    contact, such as the other border of a flat pad bridging a hollow; ``(0.0, 0)`` without one.
    The figures extraction found at its own threshold (``features.others_force``,
    ``features.others_tactels``): with 8-connected regions no tactel above the threshold touches
    the largest region, so its fringe holds none."""
    if not features.in_contact or features.others_tactels <= 0:
        return 0.0, 0
    return features.others_force, features.others_tactels


def _percentile(values: np.ndarray, q: float) -> float:
    """``numpy.percentile(values, q)`` of a non-empty 1-D array of finite floats (its default
    linear method, the same operations in the same order), without its generic machinery."""
    n = values.size
    virtual = (n - 1) * (q / 100)
    if virtual >= n - 1:
        return float(values.max())
    below = math.floor(virtual)
    ordered = np.partition(values, (below, below + 1))
    a, b = float(ordered[below]), float(ordered[below + 1])
    gamma = virtual - below
    diff = b - a
    return b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma


def drawn_in(points: np.ndarray, features, spread_px: float) -> np.ndarray:
    """``points`` ``(k, 2)`` (sensor xy, m) of the imprint of ``features``' contact region drawn in
    towards its centre of pressure along each principal axis of the region's force image, to
    the half-width of the uniform strip whose spread, widened by the sensor's own
    ``spread_px`` (tactels, standard deviation), is the region's (a line contact's imprint, as
    wide as the sensor's spread, to its line; a small round contact, such as a corner or a
    sphere pressed in lightly, towards its centre); never pushed out, and left as it is where it
    reaches less than a quarter tactel beyond that half-width. The foam spreads a contact
    narrower than a tactel over about a tactel on either side at half its peak: an edge under a
    tilted pad would otherwise record the pad's plane up to 5 mm beside the edge, in the air."""
    mask = features.mask
    rows, cols = np.nonzero(mask)
    weights = features.image[rows, cols]
    total = float(weights.sum())
    if len(points) < 2 or not total > 0.0:
        return points
    pad = features.pad
    xy = pad.px_to_m(np.column_stack((cols, rows)))
    w = weights / total
    centre = w @ xy
    d = xy - centre
    variance, axes = np.linalg.eigh((w[:, None] * d).T @ d)
    spread = (spread_px * pad.pitch) ** 2
    out = points - centre
    for j in range(2):
        half = math.sqrt(3.0 * max(0.0, float(variance[j]) - spread))  # a strip of width 2h: variance h²/3
        u = out @ axes[:, j]
        reach = float(np.abs(u).max())
        if reach > half + _DRAW_IN_SLACK * pad.pitch:  # a flat contact's imprint ends on its border already
            out = out + (half / reach - 1.0) * u[:, None] * axes[:, j]
    return centre + out


def imprint_points(features, level: float = 0.5, step_m: float = 0.0025,
                   spread_px: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The whole contact imprint as points in the sensor frame: "the robot as a ruler" (paper
    Sec. IV) applied to every part of the contact region, not only its centre of pressure.

    The force image of the contact region R is interpolated bilinearly onto a grid of spacing
    ``step_m`` over the pad; a sample belongs to the imprint where the interpolated force
    reaches ``level`` times the region's peak (the 90th percentile of its tactel forces). With
    the foam's symmetric spread, the half-peak contour of a flat contact lies on its true border
    to within a fraction of a tactel, and the samples stay off the blurred fringe beyond it.

    Parameters
    ----------
    features : ContactFeatures
        Features with ``image`` and ``mask`` (raw features of the cycle).
    level : float
        Fraction of the peak force (0–1).
    step_m : float
        Sample spacing on the pad (m).
    spread_px : float
        The sensor's own spread of a line contact (tactels, standard deviation): the samples of
        a contact no wider are drawn in to its line (:func:`drawn_in`; 0 = as found).

    Returns
    -------
    points : (k, 3) array
        Sensor-frame points (m), z = 0 (the pad surface).
    pressure : (k,) array
        Interpolated local pressure at the points (Pa).
    """
    image = features.image
    if not features.in_contact or image is None:
        return np.zeros((0, 3)), np.zeros(0)
    mask = features.mask
    pad = features.pad
    # only the largest region (and its immediate fringe): other blobs are not this contact
    img = np.where(_dilated(mask), image, 0.0)
    peak = _percentile(image[mask], 90)
    if not peak > 0.0:
        return np.zeros((0, 3)), np.zeros(0)
    A_r, A_c, xy = _imprint_grid(pad, float(step_m))
    values = (A_r @ img @ A_c.T).ravel()
    keep = values >= level * peak
    points = xy[keep]  # a new array: drawn in in place
    if spread_px > 0.0:
        points[:, :2] = drawn_in(points[:, :2], features, spread_px)
    return points, values[keep] / pad.tactel_area_m2


class RecordContacts(TactileBehaviour):
    """While RUNNING, append the contact point ``T_gs · cop`` of every cycle in contact to the
    mission's contact cloud (``/tactile/contacts``); with ``point: region`` the whole imprint.
    Never finishes by itself; the feedback message counts the samples.
    """

    uses = frozenset({"cop", "pressure"})

    min_spacing_m = Parameter(0.0, bound=NON_NEGATIVE,
                              doc="Skip a cycle whose contact point lies closer than this (m) to the previous recorded "
                                  "one (0 keeps all). With ``point: region``: skip the cycle until the pad has moved "
                                  "this far (its centre of pressure, plus half the pad's longer side, 40 mm on the "
                                  "default pad, times the turn of the pad in rad).")
    point = Parameter("cop", type=Literal["cop", "local", "region"], fixed=True,
                      doc="``\"cop\"``: the centre of pressure (Eq. 1). ``\"local\"``: where an elongated contact "
                          "crosses the pad centre (:func:`~tactile_bt.perception.features.local_contact_point`), which "
                          "removes the chord bias of the COP on curved lines such as a bent cable; needs the "
                          "orientation and the line on both sides of the centre (a cycle without them records "
                          "nothing: near a cable's tip the point would slide onto the tip). ``\"region\"``: every point of the "
                          "contact imprint (:func:`imprint_points`), each with its local pressure; covers a surface "
                          "as fast as the pad is wide.")
    voxel_m = Parameter(0.0, bound=NON_NEGATIVE,
                        doc="Keep at most one sample per voxel of this edge (m), shared by every recorder of the "
                            "mission (0 = off).")
    region_level = Parameter(0.5, bound=between(0, 1, low_open=True), unit=None,
                             doc="``point: region``: fraction of the contact's peak force where the imprint ends (0–1).")
    region_step_m = Parameter(0.0025, bound=POSITIVE,
                              doc="``point: region``: spacing of the imprint samples on the pad (m).")
    region_spread_px = Parameter(0.0, bound=NON_NEGATIVE, unit="tactel",
                                 doc="``point: region``: the spread of a line contact on the sensor (standard "
                                     "deviation across its force image; 0.75 on the simulated pad, "
                                     "``defaults.IMPRINT_SPREAD_PX``): an imprint no wider than that, such as an edge "
                                     "under a tilted pad, is drawn in to its line, and a wider one to the width it "
                                     "has without the spread (:func:`drawn_in`). 0 = as found: each pass then "
                                     "covers more, and the samples beside an edge lie up to a tactel off it, in the "
                                     "air.")
    reconstruct = Parameter("none", type=Literal["none", "auto", "delaunay", "surface", "hull"], fixed=True,
                            doc="Surface reconstruction of the cloud at the end of the mission, written to "
                                "``surface.ply`` (:mod:`tactile_bt.contacts.reconstruct`): ``none``, ``auto``, "
                                "``delaunay``, ``surface`` or ``hull``.")
    only_when = Parameter("", doc="A blackboard key (e.g. ``/cable/on_line``, written by ``cable_end``): record only "
                                  "in cycles where its value is true. Empty: every cycle in contact.")
    table_margin_m = Parameter(0.0, bound=NON_NEGATIVE,
                               doc="Leave out the points less than this (m) above the table of the set-up "
                                   "(``table_key``): a contact with the table is not a point of the object (0 = keep "
                                   "them all).")
    table_key = Parameter(TABLE_Z_KEY, fixed=True,
                          doc="Blackboard key of the table's height (m, world z; absent or NaN: no table), read when "
                              "the leaf starts (:mod:`tactile_bt.tree.behaviours.table`).")
    max_pressure_ratio = Parameter(defaults.RECORD_MAX_PRESSURE_RATIO, bound=POSITIVE_OR_INF, unit=None,
                                   doc="Record only while the smoothed pressure is at most this many times the "
                                       "target (inf: no limit).")
    min_pressure_ratio = Parameter(defaults.RECORD_MIN_PRESSURE_RATIO, bound=NON_NEGATIVE, unit=None,
                                   doc="Record only while the smoothed pressure is at least this many times the "
                                       "target (0: from the first touch).")
    other_region_share = Parameter(defaults.RECORD_OTHER_REGION_SHARE, bound=POSITIVE_OR_INF, unit=None,
                                   doc="``point: cop`` or ``local``: record only while the tactels in contact outside "
                                       "the largest region (and its fringe) carry at most this share of its force "
                                       "(inf: never check).")
    max_approach_mps = Parameter(defaults.RECORD_MAX_APPROACH_MPS, bound=POSITIVE_OR_INF,
                                 doc="Record only while the pad moves into the object along its normal at most this "
                                     "fast (m/s, averaged over the features' smoothing window; inf: never check).")
    nominal_pa = Parameter(defaults.TARGET_PRESSURE_PA, bound=POSITIVE,
                           doc="The pressure target (Pa) while ``target_key`` holds none.")
    target_key = Parameter(FORCE_TARGET_KEY, fixed=True,
                           doc="Blackboard key of the adapted pressure target (Pa), read every cycle (empty: none).")

    _floor = -math.inf  # points at or below this z (m) are the table's
    _last: list[float] | None = None  # the last recorded contact point (m, world)
    _last_rotation: np.ndarray | None = None
    _in_contact = False

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self._setup = self.attach_blackboard_client(name=f"{self.name}/setup")
        self._setup.register_key(key=self.table_key, access=Access.READ)
        self.target_key = normalise_key(self.target_key) if self.target_key else ""
        if self.target_key:
            self._setup.register_key(key=self.target_key, access=Access.READ)
        self._position: np.ndarray | None = None  # the pad's position last cycle (m, world)
        self._speed = 0.0  # its speed into the object along the normal, low-passed (m/s)
        self.skipped = 0  # cycles in contact not recorded because the contact was not settled

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if "only_when" in changed:
            self.only_when = normalise_key(self.only_when) if self.only_when else ""
        if "table_key" in changed:
            self.table_key = normalise_key(self.table_key)
        if "point" in changed and self.point == "local":
            self.uses = frozenset({"cop", "pressure", "orientation"})

    def describe(self) -> str:
        """Samples in the cloud, and whether the pad is in contact."""
        contacts = getattr(self, "contacts", None)
        n = len(contacts) if contacts is not None else 0
        return f"{n} contacts" + ("" if self._in_contact else ", not in contact")

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        self.contacts = self.bb.contacts
        table_height(self._setup, self.table_key)  # a bad value fails before the mission runs

    def initialise(self) -> None:
        self._last = None
        self._last_rotation = None
        self._position = None
        table_z = table_height(self._setup, self.table_key)
        self._floor = table_z + self.table_margin_m if self.table_margin_m > 0 and math.isfinite(table_z) else -math.inf

    def update(self) -> Status:
        # Runs every cycle: plain floats where numpy would only add call overhead; the numpy
        # products stay as they were (BLAS rounds them its own way).
        f = read(FEATURES_RAW)
        self._feedback = None
        T = read(POSE)
        approach = self._approach_speed(T)
        if not f.in_contact:
            self._in_contact = False
            return Status.RUNNING
        self._in_contact = True
        if self.only_when and not read_or(self.only_when, False):
            self._feedback = f"{len(self.contacts)} contacts, not recording ({self.only_when} is false)"
            return Status.RUNNING
        target = self.current_target()
        unsettled = self._unsettled(f, target, approach)
        if unsettled:
            self.skipped += 1
            self._feedback = f"{len(self.contacts)} contacts, not recording ({unsettled})"
            return Status.RUNNING
        R = T[:3, :3]
        if self.point == "local":
            if f.orientation != f.orientation:  # no line direction this cycle: the COP lies on the chord
                self._feedback = f"{len(self.contacts)} contacts, not recording (no line direction)"
                return Status.RUNNING
            if not line_spans_window(f):  # the line's end near the centre: the point would slide onto its tip
                self._feedback = f"{len(self.contacts)} contacts, not recording (the line ends near the pad centre)"
                return Status.RUNNING
            x, y = f.pad.xy_px_to_m(*local_contact_point(f).tolist())
        else:
            x, y = f.cop_xy
        point = R @ (x, y, 0.0) + T[:3, 3]
        p = point.tolist()
        last = self._last
        if self.point == "region":
            if last is not None and self.min_spacing_m > 0:
                d0, d1, d2 = p[0] - last[0], p[1] - last[1], p[2] - last[2]
                moved = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                if moved < self.min_spacing_m:
                    # a turn of the pad by θ rad moves its border by about half its width times θ
                    turn = (R - self._last_rotation).ravel()
                    moved += f.pad.half_width_m * math.sqrt(turn.dot(turn)) / _SQRT2
                    if moved < self.min_spacing_m:
                        return Status.RUNNING
            self._record_region(f, T)
            self._last, self._last_rotation = p, R.copy()
            return Status.RUNNING
        if p[2] <= self._floor:  # a contact with the table, not the object
            return Status.RUNNING
        if last is not None and self.min_spacing_m > 0:
            d0, d1, d2 = p[0] - last[0], p[1] - last[1], p[2] - last[2]
            if d0 * d0 + d1 * d1 + d2 * d2 < self.min_spacing_m**2:
                return Status.RUNNING
        cloud = self.contacts
        if self.voxel_m > 0 and not cloud.fresh(point[None, :], self.voxel_m)[0]:
            return Status.RUNNING
        n0, n1, n2 = T[:3, 2].tolist()
        cloud.append(p, (-n0, -n1, -n2), f.pressure, read(TIME))
        self._last = p
        return Status.RUNNING

    def current_target(self) -> float:
        """The pressure target of this cycle (Pa): ``target_key``'s value when it holds a
        positive number, else ``nominal_pa``."""
        return pressure_target(self.target_key, self.nominal_pa)

    def _approach_speed(self, T: np.ndarray) -> float:
        """The pad's speed into the object along its normal (m/s), averaged over the features'
        smoothing window (``defaults.SMOOTHING_SAMPLES`` cycles, low-passed)."""
        position = T[:3, 3]
        previous, self._position = self._position, position.copy()
        if previous is None:
            self._speed = 0.0
            return 0.0
        n = T[:3, 2]
        step = position - previous
        speed = float(n[0] * step[0] + n[1] * step[1] + n[2] * step[2]) / self.dt
        self._speed += (speed - self._speed) / defaults.SMOOTHING_SAMPLES
        return self._speed

    def _unsettled(self, f, target: float, approach_mps: float) -> str:
        """Why the contact of ``f`` is not settled ("" when it is)."""
        pressure = read(FEATURES).pressure
        if pressure > self.max_pressure_ratio * target:
            return f"pressure {pressure:.0f} Pa above {self.max_pressure_ratio:g} x {target:.0f} Pa"
        if pressure < self.min_pressure_ratio * target:
            return f"pressure {pressure:.0f} Pa below {self.min_pressure_ratio:g} x {target:.0f} Pa"
        if approach_mps > self.max_approach_mps:
            return f"pressing in at {approach_mps * 1e3:.1f} mm/s"
        if self.point != "region" and self.other_region_share < math.inf and f.force > 0.0:
            others, _ = other_contact(f)
            if others > self.other_region_share * f.force:
                return f"a second region carrying {others / f.force:.0%} of the first's force"
        return ""

    def _record_region(self, f, T: np.ndarray) -> None:
        """Add the imprint of ``f`` with the pad at ``T`` to the cloud."""
        local, pressure = imprint_points(f, self.region_level, self.region_step_m, self.region_spread_px)
        world = local @ T[:3, :3].T + T[:3, 3]
        if self._floor > -math.inf and len(world):  # never the table's contacts
            above = world[:, 2] > self._floor
            world, pressure = world[above], pressure[above]
        cloud = self.contacts
        if self.voxel_m > 0 and len(world):
            keep = cloud.fresh(world, self.voxel_m)
            world, pressure = world[keep], pressure[keep]
        cloud.extend(world, -T[:3, 2], pressure, read(TIME))
