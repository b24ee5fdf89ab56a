"""Servo primitives of the paper (Sec. IV–V): each one PID loop on some feature components
mapped through its rows of the inverse task Jacobian. All share :class:`ServoLeaf`."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from tactile_bt import defaults
from tactile_bt.behaviours.base import ServoLeaf

__all__ = ["ForceHold", "Centre", "Roll", "AlignEdge", "TactileServo"]


class ForceHold(ServoLeaf):
    """Hold the contact pressure at ``target_pa`` by moving along the pad normal (row vz).

    Gains: ``kp`` in (m/s)/Pa, ``ki`` in (m/s)/(Pa·s), ``kd`` in m/Pa; ``band`` in Pa.
    """

    uses = frozenset({"pressure"})
    components = (2,)
    rows = (2,)

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
    ) -> None:
        super().__init__(name, kp, ki, kd, output_limit, converge, band, dwell_s)
        self.target_pa = float(target_pa)

    def targets(self):
        return (0.0, 0.0), self.target_pa, 0.0


class _PositionLeaf(ServoLeaf):
    """Common part of the COP controllers: target COP in metres in the sensor frame."""

    uses = frozenset({"cop"})
    components = (0, 1)

    def __init__(self, name, target_m, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius=0.05):
        super().__init__(name, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius)
        target = np.asarray(target_m, dtype=float)
        if target.shape != (2,):
            raise ValueError(f"{name}: target_m must be [x, y] in metres, got {target_m!r}")
        self.target_m = (float(target[0]), float(target[1]))

    def targets(self):
        return self.target_m, 0.0, 0.0


class Centre(_PositionLeaf):
    """Move the centre of pressure to ``target_m`` (sensor frame, m) by sliding (rows vx, vy).

    Gains: ``kp`` in (m/s)/m = 1/s, ``ki`` in 1/s², ``kd`` dimensionless; ``band`` in m.
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
        band: float = 0.1 * defaults.PITCH_M,
        dwell_s: float = 0.5,
    ) -> None:
        super().__init__(name, target_m, kp, ki, kd, output_limit, converge, band, dwell_s)


class Roll(_PositionLeaf):
    """Move the centre of pressure to ``target_m`` by rolling about the pad's x and y axes
    (rows ωx, ωy of J⁻¹, paper Sec. V-B). The command is a position rate (m/s) turned into an
    angular rate by ``roll_radius`` (m)."""

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
        band: float = 0.1 * defaults.PITCH_M,
        dwell_s: float = 0.5,
        roll_radius: float = defaults.ROLL_RADIUS_M,
    ) -> None:
        super().__init__(name, target_m, kp, ki, kd, output_limit, converge, band, dwell_s, roll_radius)


class AlignEdge(ServoLeaf):
    """Turn about the pad normal (row ωz) until the contact's major axis lies at ``target_rad``
    (from +x towards +y; π/2 puts an edge along the sensor y axis). Errors are taken modulo π.

    Gains: ``kp`` in (rad/s)/rad, ``ki`` in 1/s², ``kd`` dimensionless; ``band`` in rad.
    """

    uses = frozenset({"orientation"})
    components = (3,)
    rows = (5,)

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
    """The paper's controller in one leaf (Eq. 3): explicit projection diagonal ``P`` and
    per-feature gains ``[x, y, pressure, orientation]`` on all four components.

    Gains are in the units of the single-feature leaves (1/s for x, y; (m/s)/Pa for pressure;
    1/s for orientation); the rolling rows use ``roll_radius``.
    """

    uses = frozenset({"cop", "pressure", "orientation"})
    components = (0, 1, 2, 3)

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
        roll_radius: float = defaults.ROLL_RADIUS_M,
    ) -> None:
        diagonal = np.asarray(P, dtype=float)
        if diagonal.shape != (6,) or not np.all((diagonal == 0) | (diagonal == 1)):
            raise ValueError(f"{name}: P must be six 0/1 values, got {P!r}")
        self.rows = tuple(int(i) for i in np.flatnonzero(diagonal))
        super().__init__(name, kp, ki, kd, output_limit, roll_radius=roll_radius)
        self.target_m = (float(target_m[0]), float(target_m[1]))
        self.target_pa = float(target_pa)
        self.target_rad = float(target_rad)

    def targets(self):
        return self.target_m, self.target_pa, self.target_rad
