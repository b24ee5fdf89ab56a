"""Servo primitives of the paper (Sec. IV–V): each one PID loop on some feature components
mapped through its rows of the inverse task Jacobian. All share :class:`ServoLeaf`.

Layer: tree.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from py_trees.common import Access

from tactile_bt import defaults
from tactile_bt.tree.behaviours.base import ROLL_RADIUS, ServoLeaf
from tactile_bt.tree.behaviours.contact_points import other_contact
from tactile_bt.tree.blackboard import FEATURES, FEATURES_RAW, pressure_target, read
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import POSITIVE, normalise_key

__all__ = ["ForceHold", "Centre", "Roll", "AlignEdge", "TactileServo"]


class ForceHold(ServoLeaf):
    """Hold the contact pressure at ``target_pa`` by moving along the pad normal (row vz of
    J⁻¹; the paper's P = diag(0, 0, 1, 0, 0, 0), Sec. V-A-1).

    RUNNING while it servos (SUCCESS on convergence with ``converge``); its feedback message
    shows the pressure error (measured − target, Pa).

    With ``target_key`` the target follows that blackboard key every cycle (a blackboard
    reference ``target_pa: "@/key"`` is read only when the leaf starts): one dictionary look-up
    per cycle, ``target_pa`` while the key holds no positive number. ``adapt_force_target``
    writes such a key (:mod:`tactile_bt.tree.behaviours.stiffness`).

    With ``all_regions`` the leaf holds the highest pressure of the contact at the target: the
    pressure of the largest region (Eq. 2), or of the tactels in contact outside it (a second
    contact, such as the far border of a flat pad bridging a hollow, low-passed over
    ``smoothing_s``) when that is higher. Servoing on the largest region alone would press on
    while the other border carries more and more. The logged error stays the largest region's.
    """

    uses = frozenset({"pressure"})
    components = (2,)
    rows = (2,)

    target_pa = Parameter(defaults.TARGET_PRESSURE_PA, bound=POSITIVE,
                          doc="Target contact pressure (Pa; the paper's p = 1 is 2000 Pa).")
    kp = ServoLeaf.kp.replace(default=defaults.FORCE_KP, unit="(m/s)/Pa", doc="Proportional gain ((m/s)/Pa).")
    ki = ServoLeaf.ki.replace(default=defaults.FORCE_KI, unit="(m/s)/(Pa·s)",
                              doc="Integral gain ((m/s)/(Pa·s)); non-zero to remove the static error.")
    kd = ServoLeaf.kd.replace(default=defaults.FORCE_KD, unit="m/Pa", doc="Derivative gain (m/Pa).")
    output_limit = ServoLeaf.output_limit.replace(default=defaults.FORCE_LIMIT_MPS, unit="m/s",
                                                  doc="Largest speed along the normal (m/s).")
    band = ServoLeaf.band.replace(default=0.05 * defaults.TARGET_PRESSURE_PA, unit="Pa",
                                  doc="Convergence band of the pressure error (Pa).")
    target_key = Parameter("", fixed=True, doc="Blackboard key of a target that replaces ``target_pa`` every cycle "
                                               "(Pa; empty: none).")
    all_regions = Parameter(True, doc="Hold the highest pressure of every contact region at the target, not only "
                                      "the largest region's.")
    smoothing_s = Parameter(defaults.SMOOTHING_SAMPLES / defaults.RATE_HZ / 2, bound=POSITIVE,
                            doc="Time constant of the low-pass on the other regions' pressure (s).")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.target_key = normalise_key(self.target_key) if self.target_key else ""
        if self.target_key:
            self._target_client = self.attach_blackboard_client(name=f"{self.name}/target")
            self._target_client.register_key(key=self.target_key, access=Access.READ)
        self._other_pa = 0.0  # low-passed pressure of the contact outside the largest region (Pa)
        self._excess_pa = 0.0  # by how much it exceeded the largest region's this cycle (Pa)

    def current_target(self) -> float:
        """The pressure target of this cycle (Pa): ``target_key``'s value when it holds a
        positive number, else ``target_pa``."""
        return pressure_target(self.target_key, self.target_pa)

    def initialise(self) -> None:
        super().initialise()
        self._other_pa = self._excess_pa = 0.0

    def targets(self):
        target = self.current_target()
        if not self.all_regions:
            return (0.0, 0.0), target, 0.0
        raw = read(FEATURES_RAW)
        force, count = other_contact(raw)
        other = force / (count * raw.pad.tactel_area_m2) if count else 0.0
        self._other_pa += (other - self._other_pa) * self.dt / (self.dt + self.smoothing_s)
        # the error target - max(p, p_other), written as a lower target for the same formula
        pressure = read(FEATURES).pressure
        excess = self._other_pa - pressure if self._other_pa > pressure else 0.0
        self._excess_pa = excess
        return (0.0, 0.0), target - excess, 0.0

    def update(self):
        status = super().update()
        if self._excess_pa and "pressure_pa" in self.command.errors:
            self.command.errors["pressure_pa"] -= self._excess_pa  # the largest region's error, as logged
        return status


def _target_cop(name: str, target_m) -> tuple[float, float]:
    target = np.asarray(target_m, dtype=float)
    if target.shape != (2,) or not np.all(np.isfinite(target)):
        raise ValueError(f"{name}: target_m must be [x, y] in metres, got {target_m!r}")
    return float(target[0]), float(target[1])


class _PositionLeaf(ServoLeaf):
    """Common part of the COP controllers: target COP in metres in the sensor frame."""

    uses = frozenset({"cop"})
    components = (0, 1)

    target_m = Parameter((0.0, 0.0), type=Sequence[float], bound=None,
                         doc="Target centre of pressure ``[x, y]`` in the sensor frame (m; [0, 0] is the pad centre).")
    ki = ServoLeaf.ki.replace(unit="1/s²", doc="Integral gain (1/s²).")
    kd = ServoLeaf.kd.replace(unit=None, doc="Derivative gain (dimensionless).")
    band = ServoLeaf.band.replace(default=defaults.COP_BAND_M, unit="m",
                                  doc="Convergence band of each COP error component (m; 0.5 mm by default, a tenth "
                                      "of the default pad's tactel; ``0.1 px`` is a tenth of the scene's).")

    def parameters_changed(self, changed: frozenset[str]) -> None:
        super().parameters_changed(changed)
        if "target_m" in changed:
            self.target_m = _target_cop(self.name, self.target_m)

    def targets(self):
        return self.target_m, 0.0, 0.0


class Centre(_PositionLeaf):
    """Move the centre of pressure to ``target_m`` by sliding (rows vx, vy of J⁻¹; the paper's
    contact position control, P = diag(1, 1, 0, 0, 0, 0), Sec. V-A-2).

    RUNNING while it servos (SUCCESS on convergence with ``converge``); its feedback message
    shows the COP error (measured − target, in tactels of the mission's pad).
    """

    rows = (0, 1)

    kp = ServoLeaf.kp.replace(default=defaults.CENTRE_KP, unit="1/s",
                              doc="Proportional gain ((m/s)/m = 1/s), both axes.")
    ki = _PositionLeaf.ki.replace(default=defaults.CENTRE_KI)
    kd = _PositionLeaf.kd.replace(default=defaults.CENTRE_KD)
    output_limit = ServoLeaf.output_limit.replace(default=defaults.CENTRE_LIMIT_MPS, unit="m/s",
                                                  doc="Largest sliding speed per axis (m/s).")


class Roll(_PositionLeaf):
    """Move the centre of pressure to ``target_m`` by rolling about the pad's x and y axes
    (rows ωx, ωy of J⁻¹, paper Sec. V-B). The command is a position rate (m/s) turned into an
    angular rate by ``roll_radius`` (m): ωx = +u_y/r, ωy = −u_x/r.
    """

    rows = (3, 4)

    kp = ServoLeaf.kp.replace(default=defaults.ROLL_KP, unit="1/s",
                              doc="Proportional gain of the position rate ((m/s)/m = 1/s).")
    ki = _PositionLeaf.ki.replace(default=defaults.ROLL_KI)
    kd = _PositionLeaf.kd.replace(default=defaults.ROLL_KD)
    output_limit = ServoLeaf.output_limit.replace(
        default=defaults.ROLL_LIMIT_MPS, unit="m/s",
        doc="Largest position rate per axis (m/s), i.e. ``output_limit / roll_radius`` rad/s.")
    band = _PositionLeaf.band.replace(doc="Convergence band of each COP error component (m).")
    roll_radius = ROLL_RADIUS.replace()


class AlignEdge(ServoLeaf):
    """Turn about the pad normal (row ωz of J⁻¹, paper Sec. V-C) until the contact's major axis
    lies at ``target_rad``. Errors are taken modulo π. A contact without a dominant axis
    (orientation NaN) adds nothing.
    """

    uses = frozenset({"orientation"})
    components = (3,)
    rows = (5,)

    target_rad = Parameter(np.pi / 2, doc="Target orientation of the major axis, from +x towards +y (rad; π/2 puts "
                                          "an edge along the sensor y axis).")
    kp = ServoLeaf.kp.replace(default=defaults.ALIGN_KP, unit="1/s", doc="Proportional gain ((rad/s)/rad = 1/s).")
    ki = ServoLeaf.ki.replace(default=defaults.ALIGN_KI, unit="1/s²", doc="Integral gain (1/s²).")
    kd = ServoLeaf.kd.replace(default=defaults.ALIGN_KD, unit=None, doc="Derivative gain (dimensionless).")
    output_limit = ServoLeaf.output_limit.replace(default=defaults.ALIGN_LIMIT_RPS, unit="rad/s",
                                                  doc="Largest turning rate (rad/s).")
    band = ServoLeaf.band.replace(default=float(np.deg2rad(2.0)), unit="rad",
                                  doc="Convergence band of the orientation error (rad; 2° by default).")

    def targets(self):
        return (0.0, 0.0), 0.0, self.target_rad


class TactileServo(ServoLeaf):
    """The paper's controller in one leaf (Eq. 3): an explicit projection diagonal ``P`` and
    per-feature gains and targets on all four components ``[x, y, pressure, orientation]``.

    ``P`` selects the twist rows ``[vx, vy, vz, ωx, ωy, ωz]``: diag(0,0,1,0,0,0) is force
    control, diag(1,1,0,0,0,0) contact position, diag(1,1,1,0,0,0) hybrid, diag(1,1,1,1,1,0)
    rolling, diag(0,0,1,0,0,1) edge alignment (paper Sec. V). Components without a row in
    ``P·J⁻¹`` are neither controlled nor logged, and do not gate convergence.
    """

    uses = frozenset({"cop", "pressure", "orientation"})
    components = (0, 1, 2, 3)

    P = Parameter((1, 1, 1, 0, 0, 0), type=Sequence[float], unit=None, fixed=True,
                  doc="Diagonal of the 6×6 projection matrix, six 0/1 values.")
    target_m = _PositionLeaf.target_m.replace()
    target_pa = Parameter(defaults.TARGET_PRESSURE_PA, bound=POSITIVE, doc="Target contact pressure (Pa).")
    target_rad = Parameter(np.pi / 2, doc="Target orientation of the contact's major axis (rad, from +x towards +y).")
    kp = ServoLeaf.kp.replace(
        default=(defaults.CENTRE_KP, defaults.CENTRE_KP, defaults.FORCE_KP, defaults.ALIGN_KP), type=Sequence[float],
        unit=None,
        doc="Proportional gains ``[x, y, pressure, orientation]``: 1/s, 1/s, (m/s)/Pa, 1/s.")
    ki = ServoLeaf.ki.replace(
        default=(defaults.CENTRE_KI, defaults.CENTRE_KI, defaults.FORCE_KI, defaults.ALIGN_KI), type=Sequence[float],
        unit=None, doc="Integral gains, the same units per second.")
    kd = ServoLeaf.kd.replace(default=(0.0, 0.0, 0.0, 0.0), type=Sequence[float], unit=None,
                              doc="Derivative gains, the same units times seconds.")
    output_limit = ServoLeaf.output_limit.replace(
        default=(defaults.CENTRE_LIMIT_MPS, defaults.CENTRE_LIMIT_MPS, defaults.FORCE_LIMIT_MPS,
                 defaults.ALIGN_LIMIT_RPS), type=Sequence[float], unit=None,
        doc="Largest command per component: m/s, m/s, m/s, rad/s.")
    band = ServoLeaf.band.replace(
        default=(defaults.COP_BAND_M, defaults.COP_BAND_M, 0.05 * defaults.TARGET_PRESSURE_PA, float(np.deg2rad(2.0))),
        type=Sequence[float], unit=None, doc="Convergence band per component: m, m, Pa, rad.")
    roll_radius = ROLL_RADIUS.replace()

    def parameters_changed(self, changed: frozenset[str]) -> None:
        if "P" in changed:
            diagonal = np.asarray(self.P, dtype=float)
            if diagonal.shape != (6,) or not np.all((diagonal == 0) | (diagonal == 1)):
                raise ValueError(f"{self.name}: P must be six 0/1 values, got {self.P!r}")
            self.P = tuple(int(v) for v in diagonal)
            self.rows = tuple(int(i) for i in np.flatnonzero(diagonal))
        super().parameters_changed(changed)
        if "target_m" in changed:
            self.target_m = _target_cop(self.name, self.target_m)
        if "P" in changed:
            self.uses = frozenset(_USES[c] for c in self._active_components())

    def _active_components(self):
        return [self.components[j] for j in self._active]

    def targets(self):
        return self.target_m, self.target_pa, self.target_rad


#: The feature each component needs (the mission computes only those of running leaves).
_USES = {0: "cop", 1: "cop", 2: "pressure", 3: "orientation"}
