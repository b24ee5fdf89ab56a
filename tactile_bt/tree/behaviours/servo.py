"""Servo primitives of the paper (Sec. IV–V): each one PID loop on some feature components
mapped through its rows of the inverse task Jacobian. All share :class:`ServoLeaf`.

Layer: tree.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from py_trees.common import Access

from tactile_bt import defaults
from tactile_bt.tree.behaviours.base import ServoLeaf
from tactile_bt.tree.behaviours.contact_points import other_contact
from tactile_bt.tree.blackboard import FEATURES, FEATURES_RAW, read, read_or
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

    Parameters
    ----------
    target_pa : float
        Target contact pressure (Pa; the paper's p = 1 is 2000 Pa).
    target_key : str
        Blackboard key of a target that replaces ``target_pa`` every cycle (Pa; empty: none).
    all_regions : bool
        Hold the highest pressure of every contact region at the target, not only the largest's.
    smoothing_s : float
        Time constant of the low-pass on the other regions' pressure (s).
    kp : float
        Proportional gain ((m/s)/Pa).
    ki : float
        Integral gain ((m/s)/(Pa·s)); non-zero to remove the static error.
    kd : float
        Derivative gain (m/Pa).
    output_limit : float
        Largest speed along the normal (m/s).
    band : float
        Convergence band of the pressure error (Pa).
    """

    uses = frozenset({"pressure"})
    components = (2,)
    rows = (2,)
    parameter_units = {"kp": "(m/s)/Pa", "ki": "(m/s)/(Pa·s)", "kd": "m/Pa", "output_limit": "m/s", "band": "Pa"}
    parameter_bounds = {"target_pa": POSITIVE, "smoothing_s": POSITIVE}
    fixed_parameters = frozenset({"name", "roll_radius", "target_key"})

    def __init__(
        self,
        name: str = "force_hold",
        target_pa: float = defaults.TARGET_PRESSURE_PA,
        kp: float = defaults.FORCE_KP,
        ki: float = defaults.FORCE_KI,
        kd: float = defaults.FORCE_KD,
        output_limit: float = defaults.FORCE_LIMIT_MPS,
        converge: bool = False,
        band: float = 0.05 * defaults.TARGET_PRESSURE_PA,
        dwell_s: float = 0.5,
        target_key: str = "",
        all_regions: bool = True,
        smoothing_s: float = defaults.SMOOTHING_SAMPLES / defaults.RATE_HZ / 2,
    ) -> None:
        super().__init__(name, kp, ki, kd, output_limit, converge, band, dwell_s)
        self.target_pa = float(target_pa)
        self.all_regions = bool(all_regions)
        self.smoothing_s = float(smoothing_s)
        self._other_pa = 0.0  # low-passed pressure of the contact outside the largest region (Pa)
        self._excess_pa = 0.0  # by how much it exceeded the largest region's this cycle (Pa)
        self.target_key = normalise_key(target_key) if target_key else ""
        if self.target_key:
            self._target_client = self.attach_blackboard_client(name=f"{name}/target")
            self._target_client.register_key(key=self.target_key, access=Access.READ)

    def current_target(self) -> float:
        """The pressure target of this cycle (Pa): ``target_key``'s value when it holds a
        positive number, else ``target_pa``."""
        if self.target_key:
            value = read_or(self.target_key)
            if isinstance(value, float) and value > 0.0:
                return value
        return self.target_pa

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
    parameter_units = {"kp": "1/s", "ki": "1/s²", "output_limit": "m/s", "band": "m"}

    def __init__(self, name, target_m, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius=0.05):
        super().__init__(name, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius)
        self.target_m = _target_cop(name, target_m)

    def set_parameter(self, name: str, value) -> None:
        if name == "target_m":
            self.target_m = _target_cop(self.name, value)
        else:
            super().set_parameter(name, value)

    def targets(self):
        return self.target_m, 0.0, 0.0


class Centre(_PositionLeaf):
    """Move the centre of pressure to ``target_m`` by sliding (rows vx, vy of J⁻¹; the paper's
    contact position control, P = diag(1, 1, 0, 0, 0, 0), Sec. V-A-2).

    RUNNING while it servos (SUCCESS on convergence with ``converge``); its feedback message
    shows the COP error (measured − target, in tactels of the mission's pad).

    Parameters
    ----------
    target_m : list of float
        Target centre of pressure ``[x, y]`` in the sensor frame (m; [0, 0] is the pad centre).
    kp : float
        Proportional gain ((m/s)/m = 1/s), both axes.
    ki : float
        Integral gain (1/s²).
    kd : float
        Derivative gain (dimensionless).
    output_limit : float
        Largest sliding speed per axis (m/s).
    band : float
        Convergence band of each COP error component (m; 0.5 mm by default, a tenth of the
        default pad's tactel; ``0.1 px`` is a tenth of the scene's).
    """

    rows = (0, 1)

    def __init__(
        self,
        name: str = "centre",
        target_m: Sequence[float] = (0.0, 0.0),
        kp: float = defaults.CENTRE_KP,
        ki: float = defaults.CENTRE_KI,
        kd: float = defaults.CENTRE_KD,
        output_limit: float = defaults.CENTRE_LIMIT_MPS,
        converge: bool = False,
        band: float = defaults.COP_BAND_M,
        dwell_s: float = 0.5,
    ) -> None:
        super().__init__(name, target_m, kp, ki, kd, output_limit, converge, band, dwell_s)


class Roll(_PositionLeaf):
    """Move the centre of pressure to ``target_m`` by rolling about the pad's x and y axes
    (rows ωx, ωy of J⁻¹, paper Sec. V-B). The command is a position rate (m/s) turned into an
    angular rate by ``roll_radius`` (m): ωx = +u_y/r, ωy = −u_x/r.

    Parameters
    ----------
    target_m : list of float
        Target centre of pressure ``[x, y]`` in the sensor frame (m).
    kp : float
        Proportional gain of the position rate ((m/s)/m = 1/s).
    ki : float
        Integral gain (1/s²).
    kd : float
        Derivative gain (dimensionless).
    output_limit : float
        Largest position rate per axis (m/s), i.e. ``output_limit / roll_radius`` rad/s.
    band : float
        Convergence band of each COP error component (m).
    """

    rows = (3, 4)

    def __init__(
        self,
        name: str = "roll",
        target_m: Sequence[float] = (0.0, 0.0),
        kp: float = defaults.ROLL_KP,
        ki: float = defaults.ROLL_KI,
        kd: float = defaults.ROLL_KD,
        output_limit: float = defaults.ROLL_LIMIT_MPS,
        converge: bool = False,
        band: float = defaults.COP_BAND_M,
        dwell_s: float = 0.5,
        roll_radius: float = defaults.ROLL_RADIUS_M,
    ) -> None:
        super().__init__(name, target_m, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius)


class AlignEdge(ServoLeaf):
    """Turn about the pad normal (row ωz of J⁻¹, paper Sec. V-C) until the contact's major axis
    lies at ``target_rad``. Errors are taken modulo π. A contact without a dominant axis
    (orientation NaN) adds nothing.

    Parameters
    ----------
    target_rad : float
        Target orientation of the major axis, from +x towards +y (rad; π/2 puts an edge along
        the sensor y axis).
    kp : float
        Proportional gain ((rad/s)/rad = 1/s).
    ki : float
        Integral gain (1/s²).
    kd : float
        Derivative gain (dimensionless).
    output_limit : float
        Largest turning rate (rad/s).
    band : float
        Convergence band of the orientation error (rad; 2° by default).
    """

    uses = frozenset({"orientation"})
    components = (3,)
    rows = (5,)
    parameter_units = {"kp": "1/s", "ki": "1/s²", "output_limit": "rad/s", "band": "rad"}

    def __init__(
        self,
        name: str = "align_edge",
        target_rad: float = np.pi / 2,
        kp: float = defaults.ALIGN_KP,
        ki: float = defaults.ALIGN_KI,
        kd: float = defaults.ALIGN_KD,
        output_limit: float = defaults.ALIGN_LIMIT_RPS,
        converge: bool = False,
        band: float = np.deg2rad(2.0),
        dwell_s: float = 0.5,
    ) -> None:
        super().__init__(name, kp, ki, kd, output_limit, converge, band, dwell_s)
        self.target_rad = float(target_rad)

    def targets(self):
        return (0.0, 0.0), 0.0, self.target_rad


class TactileServo(ServoLeaf):
    """The paper's controller in one leaf (Eq. 3): an explicit projection diagonal ``P`` and
    per-feature gains and targets on all four components ``[x, y, pressure, orientation]``.

    ``P`` selects the twist rows ``[vx, vy, vz, ωx, ωy, ωz]``: diag(0,0,1,0,0,0) is force
    control, diag(1,1,0,0,0,0) contact position, diag(1,1,1,0,0,0) hybrid, diag(1,1,1,1,1,0)
    rolling, diag(0,0,1,0,0,1) edge alignment (paper Sec. V). Components without a row in
    ``P·J⁻¹`` are neither controlled nor logged, and do not gate convergence.

    Parameters
    ----------
    P : list of float
        Diagonal of the 6×6 projection matrix, six 0/1 values.
    target_m : list of float
        Target centre of pressure ``[x, y]`` in the sensor frame (m).
    target_pa : float
        Target contact pressure (Pa).
    target_rad : float
        Target orientation of the contact's major axis (rad, from +x towards +y).
    kp : list of float
        Proportional gains ``[x, y, pressure, orientation]``: 1/s, 1/s, (m/s)/Pa, 1/s.
    ki : list of float
        Integral gains, the same units per second.
    kd : list of float
        Derivative gains, the same units times seconds.
    output_limit : list of float
        Largest command per component: m/s, m/s, m/s, rad/s.
    band : list of float
        Convergence band per component: m, m, Pa, rad.
    """

    uses = frozenset({"cop", "pressure", "orientation"})
    components = (0, 1, 2, 3)
    fixed_parameters = frozenset({"name", "roll_radius", "P"})
    parameter_bounds = {"target_pa": POSITIVE}

    def __init__(
        self,
        name: str = "tactile_servo",
        P: Sequence[float] = (1, 1, 1, 0, 0, 0),
        target_m: Sequence[float] = (0.0, 0.0),
        target_pa: float = defaults.TARGET_PRESSURE_PA,
        target_rad: float = np.pi / 2,
        kp: Sequence[float] = (defaults.CENTRE_KP, defaults.CENTRE_KP, defaults.FORCE_KP, defaults.ALIGN_KP),
        ki: Sequence[float] = (defaults.CENTRE_KI, defaults.CENTRE_KI, defaults.FORCE_KI, defaults.ALIGN_KI),
        kd: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
        output_limit: Sequence[float] = (
            defaults.CENTRE_LIMIT_MPS,
            defaults.CENTRE_LIMIT_MPS,
            defaults.FORCE_LIMIT_MPS,
            defaults.ALIGN_LIMIT_RPS,
        ),
        converge: bool = False,
        band: Sequence[float] = (defaults.COP_BAND_M, defaults.COP_BAND_M, 0.05 * defaults.TARGET_PRESSURE_PA,
                                 float(np.deg2rad(2.0))),
        dwell_s: float = 0.5,
        roll_radius: float = defaults.ROLL_RADIUS_M,
    ) -> None:
        diagonal = np.asarray(P, dtype=float)
        if diagonal.shape != (6,) or not np.all((diagonal == 0) | (diagonal == 1)):
            raise ValueError(f"{name}: P must be six 0/1 values, got {P!r}")
        self.P = tuple(int(v) for v in diagonal)
        self.rows = tuple(int(i) for i in np.flatnonzero(diagonal))
        super().__init__(name, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius)
        self.target_m = _target_cop(name, target_m)
        self.target_pa = float(target_pa)
        self.target_rad = float(target_rad)
        self.uses = frozenset(_USES[c] for c in self._active_components())

    def _active_components(self):
        return [self.components[j] for j in self._active]

    def set_parameter(self, name: str, value) -> None:
        if name == "target_m":
            self.target_m = _target_cop(self.name, value)
        else:
            super().set_parameter(name, value)

    def targets(self):
        return self.target_m, self.target_pa, self.target_rad


#: The feature each component needs (the mission computes only those of running leaves).
_USES = {0: "cop", 1: "cop", 2: "pressure", 3: "orientation"}
