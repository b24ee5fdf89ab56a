"""Forces the object can carry: the contact's stiffness estimated while the pad presses, and the
force target lowered where the object is too soft to carry it.

A soft object (a thin rubber cable, a foam block) gives way under the pad: holding the tree's
pressure target on it would press it flat, the pad reaching whatever hard lies below (the table)
while the servos still see a contact. ``adapt_force_target`` estimates how stiff the contact
is from what the tree can see, the pressure against the pad's own travel along its normal, and
writes a target the object can carry to a blackboard key that ``force_hold`` (``target_key``)
and ``record_contacts`` follow every cycle.

The estimate (:class:`ContactStiffness`) is a secant per contact: from the cycle the contact
begins, the indentation ``d`` is the travel, along the pad's normal (``+z`` of the sensor frame,
towards the object), of the pad's point at the contact (the centre of pressure; summed cycle by
cycle, so the pad may turn, and turning about the contact is no travel) and the stiffness is
``k = (p - p0) / d`` (Pa/m), ``p`` the raw pressure and ``p0`` the pressure when the contact
began. It counts once ``d`` exceeds ``min_travel_m`` and ``p`` has risen by ``min_rise_pa``,
follows the contact while the pad loads it (until the pressure first reaches 0.9 times the
adapted target) and is kept from then on; a contact lost before it was loaded (one fading at an
edge of the object while the pad moves on) leaves the estimate of the last loaded contact.
Sliding and rolling after the loading move the pad along its normal for reasons other than
indentation, so they do not change the estimate. A contact loaded within ``min_travel_m`` is
stiffer than its secant at ``min_travel_m``, which is kept.

What the object can give before the pad reaches something hard is ``max_indentation_m``, or
less when the set-up's table (``/setup/table_z_m``) lies closer below the contact along the pad
normal, from where the contact began. The contact carries ``p0 + k · give_share · give`` within
``give_share`` of that; when this is less than ``target_pa`` it becomes the target, never
below ``floor_pa`` (a stiffer contact later raises it again). An object whose smoothed pressure
is still below ``floor_pa`` when the pad has pressed ``give_share`` of its give into it is too
soft to servo on: with ``fail_below_floor`` the leaf then fails and says so, which ends a task
it runs beside with an honest ``failure`` rather than a servo on a contact too faint to follow;
without, the target becomes ``floor_pa``.

Layer: tree.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from py_trees.common import Access, Status

from tactile_bt import defaults
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, table_height
from tactile_bt.tree.blackboard import FEATURES, FEATURES_RAW, POSE, read, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import POSITIVE, between, normalise_key

__all__ = ["ContactStiffness", "AdaptForceTarget", "FORCE_TARGET_KEY", "STIFFNESS_KEY"]

#: Blackboard key of the adapted pressure target (Pa).
FORCE_TARGET_KEY = "/force/target_pa"
#: Blackboard key of the estimated contact stiffness (Pa/m; NaN while unknown).
STIFFNESS_KEY = "/force/stiffness_pa_per_m"


class ContactStiffness:
    """Secant contact stiffness per contact (the module's docstring), fed one cycle at a time.

    A contact's secant counts once the pad has pressed ``min_travel_m`` into it and the pressure
    has risen by ``min_rise_pa``; it is kept when the contact is loaded (the pressure reaches the
    loaded pressure), and dropped when the contact is lost before: a contact that flickers at an
    edge of the object, the pad moving on while it fades, is no measurement of its stiffness. A
    contact loaded before ``min_travel_m`` is stiffer than its secant at ``min_travel_m``, which
    is kept as its estimate.

    Parameters
    ----------
    min_travel_m : float
        Indentation (m) from the start of the contact before a secant counts.
    min_rise_pa : float
        Rise of the pressure (Pa) from the start of the contact before a secant counts.

    Attributes
    ----------
    stiffness_pa_per_m : float
        The estimate (Pa/m): of the contact under way while it is loaded, else of the last
        contact that was loaded; NaN before any.
    onset_pa : float
        The pressure when that contact began (Pa): the contact threshold already carries some.
    give_m : float
        What that contact could give (m), as given when it began.
    indentation_m : float
        The travel along the pad's normal of the pad's point at the contact since the contact
        under way began (m).
    contact_give_m : float
        What the contact under way can give (m), as given when it began.
    loading : bool
        Whether the contact under way is still being loaded (its estimate may still change).
    """

    def __init__(self, min_travel_m: float = defaults.STIFFNESS_MIN_TRAVEL_M,
                 min_rise_pa: float = defaults.STIFFNESS_MIN_RISE_PA) -> None:
        self.min_travel_m = float(min_travel_m)
        self.min_rise_pa = float(min_rise_pa)
        self.stiffness_pa_per_m = math.nan
        self.onset_pa = 0.0
        self.give_m = math.inf
        self.indentation_m = 0.0
        self.contact_give_m = math.inf
        self.loading = False
        self.contacts = 0
        self._kept = (math.nan, 0.0, math.inf)  # stiffness, onset, give of the last loaded contact
        self._in_contact = False
        self._last_pose: list | None = None  # T_gs as nested lists, while a contact is loading

    def update(self, in_contact: bool, pressure_pa: float, pose: np.ndarray, loaded_pa: float,
               give: Callable[[], float] = lambda: math.inf, cop_xy: tuple[float, float] = (0.0, 0.0)) -> bool:
        """One cycle: raw contact flag and pressure (Pa), the pad's pose ``T_gs`` (m), the
        pressure (Pa) at which loading ends, called when a contact begins, what it can give
        (m), and where the contact lies on the pad (``cop_xy``, m, sensor frame): the travel is
        that of the pad's point there, so that turning about a contact off the centre (a pad
        landing on its corner and rolling flat) is no indentation. Returns whether a contact
        began this cycle."""
        began = in_contact and not self._in_contact
        self._in_contact = in_contact
        if not in_contact:
            if self.loading:  # lost before it was loaded: back to the last loaded contact
                self.stiffness_pa_per_m, self.onset_pa, self.give_m = self._kept
                self.loading = False
            return False
        if began:
            self.indentation_m = 0.0
            self._onset = float(pressure_pa)
            self.contact_give_m = float(give())
            self.loading = True
            self.contacts += 1
        elif self.loading:  # the travel of the pad's point at the contact, from the last pose to this one
            x, y = cop_xy
            if not (math.isfinite(x) and math.isfinite(y)):
                x = y = 0.0
            t, t0 = pose.tolist(), self._last_pose  # plain floats: this runs every cycle of a loading
            sx = t[0][3] - t0[0][3] + (t[0][0] - t0[0][0]) * x + (t[0][1] - t0[0][1]) * y
            sy = t[1][3] - t0[1][3] + (t[1][0] - t0[1][0]) * x + (t[1][1] - t0[1][1]) * y
            sz = t[2][3] - t0[2][3] + (t[2][0] - t0[2][0]) * x + (t[2][1] - t0[2][1]) * y
            self.indentation_m += t[0][2] * sx + t[1][2] * sy + t[2][2] * sz
        if self.loading:  # the pose is needed only to follow a loading (once loaded the estimate is kept)
            self._last_pose = pose.tolist()
            d = self.indentation_m
            rise = pressure_pa - self._onset
            if rise >= self.min_rise_pa and (d >= self.min_travel_m or pressure_pa >= loaded_pa):
                self.stiffness_pa_per_m = rise / max(d, self.min_travel_m)
                self.onset_pa, self.give_m = self._onset, self.contact_give_m
            if pressure_pa >= loaded_pa:
                self.loading = False
                self._kept = (self.stiffness_pa_per_m, self.onset_pa, self.give_m)
        return began


def carried_target(target_pa: float, floor_pa: float, stiffness_pa_per_m: float, onset_pa: float, give_m: float,
                   give_share: float) -> float:
    """The pressure target (Pa) that a contact carries within ``give_share`` of the ``give_m``
    (m) it can give after it began at ``onset_pa`` (Pa) with ``stiffness_pa_per_m`` (Pa/m):
    ``target_pa`` when it needs no more indentation, else ``onset_pa + stiffness · give_share ·
    give``, at least ``floor_pa``; ``target_pa`` while the stiffness is unknown (NaN)."""
    if not stiffness_pa_per_m > 0.0:
        return target_pa
    carried = onset_pa + stiffness_pa_per_m * give_share * give_m
    return target_pa if carried >= target_pa else max(floor_pa, carried)


class AdaptForceTarget(TactileBehaviour):
    """Estimate the contact's stiffness and write the pressure target the object can carry
    (module docstring) to ``key``, and the estimate (Pa/m, NaN while unknown) to
    ``estimate_key``, every cycle; RUNNING. Run it beside the whole task (from before the
    approach) so that it sees the first contact loaded, and give ``force_hold`` the same key as
    its ``target_key``.
    """

    uses = frozenset({"pressure"})
    target_pa = Parameter(defaults.TARGET_PRESSURE_PA, bound=POSITIVE,
                          doc="The tree's pressure target (Pa): the adapted target never exceeds it.")
    floor_pa = Parameter(defaults.FORCE_TARGET_FLOOR_PA, bound=POSITIVE,
                         doc="Lowest adapted target (Pa): below it the contact is too faint to servo on.")
    give_share = Parameter(defaults.STIFFNESS_GIVE_SHARE, bound=between(0, 1, low_open=True), unit=None,
                           doc="Share of what the object can give that the target may use (0–1).")
    max_indentation_m = Parameter(defaults.STIFFNESS_MAX_INDENTATION_M, bound=POSITIVE,
                                  doc="What an object is taken to give before the pad reaches something hard, where "
                                      "the table below is farther (m).")
    min_travel_m = Parameter(defaults.STIFFNESS_MIN_TRAVEL_M, bound=POSITIVE,
                             doc="Indentation of a contact before its stiffness counts (m).")
    min_rise_pa = Parameter(defaults.STIFFNESS_MIN_RISE_PA, bound=POSITIVE,
                            doc="Rise of the pressure of a contact before its stiffness counts (Pa).")
    fail_below_floor = Parameter(True, doc="Fail when the pressure is still below ``floor_pa`` once the pad has pressed "
                                           "``give_share`` of what the object gives into it.")
    key = Parameter(FORCE_TARGET_KEY, fixed=True, doc="Blackboard key of the adapted target (Pa).")
    estimate_key = Parameter(STIFFNESS_KEY, fixed=True, doc="Blackboard key of the estimated stiffness (Pa/m).")
    table_key = Parameter(TABLE_Z_KEY, fixed=True,
                          doc="Blackboard key of the table's height (m, world z; absent or NaN: no table).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.key, self.estimate_key = normalise_key(self.key), normalise_key(self.estimate_key)
        self.table_key = normalise_key(self.table_key)
        self._writer = self.attach_blackboard_client(name=f"{self.name}/target")
        for k in (self.key, self.estimate_key):
            self._writer.register_key(key=k, access=Access.WRITE)
        self._writer.register_key(key=self.table_key, access=Access.READ)
        self.table_z_m = math.nan
        self._restart()

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if changed & {"floor_pa", "target_pa"} and not self.floor_pa <= self.target_pa:
            raise ValueError(f"{self.name}: floor_pa ({self.floor_pa:g} Pa) must not exceed target_pa "
                             f"({self.target_pa:g} Pa)")

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        table_height(self._writer, self.table_key)  # a bad value fails before the mission runs

    def initialise(self) -> None:
        self.table_z_m = table_height(self._writer, self.table_key)
        self._restart()

    def _restart(self) -> None:
        """No estimate, the tree's target (written at once: ``force_hold`` may read the key
        before this leaf's first tick)."""
        self.estimator = ContactStiffness(self.min_travel_m, self.min_rise_pa)
        self.target = self.lowest_target_pa = self.target_pa
        write(self.key, self.target)
        write(self.estimate_key, math.nan)

    def _give(self, f, T: np.ndarray) -> float:
        """What the object can give at the contact beginning now (m): ``max_indentation_m``, or
        the distance along the pad normal from the contact to the table when that is less."""
        give = self.max_indentation_m
        n_z = float(T[2, 2])
        if math.isfinite(self.table_z_m) and n_z < -0.2:  # the normal points down at the table
            x, y = f.cop_xy
            contact_z = float(T[2, 0] * x + T[2, 1] * y + T[2, 3])
            give = min(give, max(contact_z - self.table_z_m, 0.0) / -n_z)
        return give

    def update(self) -> Status:
        f = read(FEATURES_RAW)
        T = read(POSE)
        estimator = self.estimator
        estimator.update(bool(f.in_contact), float(f.pressure), T, 0.9 * self.target, lambda: self._give(f, T),
                         f.cop_xy if f.in_contact else (0.0, 0.0))
        k, give = estimator.stiffness_pa_per_m, estimator.give_m
        wanted = carried_target(self.target_pa, self.floor_pa, k, estimator.onset_pa, give, self.give_share)
        if estimator.loading:
            allowed = self.give_share * estimator.contact_give_m
            pressure = read(FEATURES).pressure
            if estimator.indentation_m >= allowed and pressure < self.floor_pa:  # not even the floor
                if self.fail_below_floor:
                    self.feedback_message = (f"too soft to carry {self.floor_pa:.0f} Pa: {pressure:.0f} Pa after "
                                             f"{estimator.indentation_m * 1e3:.2f} mm, {self.give_share:.0%} of the "
                                             f"{estimator.contact_give_m * 1e3:.2f} mm it gives")
                    return Status.FAILURE
                wanted = self.floor_pa
        self.target = wanted
        if wanted < self.lowest_target_pa:
            self.lowest_target_pa = wanted
        write(self.key, wanted)
        write(self.estimate_key, estimator.stiffness_pa_per_m)
        self._feedback = None
        return Status.RUNNING

    def describe(self) -> str:
        """The estimate and the target of the last tick."""
        k = self.estimator.stiffness_pa_per_m
        estimate = "stiffness unknown" if math.isnan(k) else f"stiffness {k:.3g} Pa/m"
        return f"{estimate}, target {self.target:.0f} Pa"

    def summary(self) -> dict:
        """What report.json shows under ``force.stiffness``: the estimate (Pa/m, None while
        unknown), what the contact it comes from could give (m; None while unknown), the adapted target at the end and the lowest
        one (Pa), and the contacts seen."""
        k, give = self.estimator.stiffness_pa_per_m, self.estimator.give_m
        return {"node": self.name, "stiffness_pa_per_m": None if math.isnan(k) else float(k),
                "give_m": float(give) if math.isfinite(give) else None, "target_pa": float(self.target),
                "lowest_target_pa": float(self.lowest_target_pa), "tree_target_pa": self.target_pa,
                "contacts": self.estimator.contacts}
