"""Servo controller of the paper's Sec. IV: PID on feature errors, inverse task Jacobian (Eq. 5),
projection matrix and external guidance twist (Eq. 3), summed once per control cycle.

Feature error
-------------
``Δf = f_target − f = [Δx, Δy, Δp, Δα]`` (the paper's Fig. 6: target minus measured), with
``Δx, Δy`` in metres in the sensor frame, ``Δp`` in Pa and ``Δα`` in rad taken modulo π in
(−π/2, π/2].

Signs of J⁻¹ for our frames (derived, and proven by ``tests/control/test_control.py``)
---------------------------------------------------------------------------
The object is fixed and the sensor moves with body twist ``[v; ω]`` (sensor frame, +z towards
the object):

* sliding: a contact point seen at ``x`` moves as ``ẋ = −v_x`` → ``v_x = −u_x`` (same for y);
* force: moving along +z presses harder, ``ṗ ∝ +v_z`` → ``v_z = +u_p``;
* turning: a line at angle α in the pad turns as ``α̇ = −ω_z`` → ``ω_z = −u_α``;
* rolling about the pad's tangential axes over a curved object of radius ρ at height h moves the
  contact as ``ẋ ≈ −(ρ + h) ω_y`` and ``ẏ ≈ +(ρ + h) ω_x`` → ``ω_y = −u_x / r``, ``ω_x = +u_y / r``.

The paper writes every entry as 1; the rolling rows carry ``1/r`` (``roll_radius``, m) so that a
position command in m/s becomes an angular rate in rad/s.

Layer: control.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from tactile_bt.perception.features import wrap_half_pi

__all__ = [
    "per_component",
    "FEATURE_NAMES",
    "TWIST_NAMES",
    "inverse_task_jacobian",
    "projection",
    "PROJECTIONS",
    "feature_error",
    "feature_errors_of",
    "PID",
    "ServoCommand",
    "limit_twist",
]

#: Order of the feature-error vector Δf (the paper's).
FEATURE_NAMES = ("x", "y", "pressure", "orientation")
#: Order of twist components.
TWIST_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")


def inverse_task_jacobian(roll_radius: float = 0.05) -> np.ndarray:
    """The fixed 6×4 inverse task Jacobian J⁻¹ of paper Eq. 5 in our sensor frame.

    Parameters
    ----------
    roll_radius : float
        Length (m) converting a position command (m/s) into a rolling rate (rad/s) in rows
        ωx and ωy.
    """
    J = np.zeros((6, 4))
    J[0, 0] = -1.0  # vx <- Δx
    J[1, 1] = -1.0  # vy <- Δy
    J[2, 2] = 1.0  # vz <- Δp
    J[3, 1] = 1.0 / roll_radius  # ωx <- Δy
    J[4, 0] = -1.0 / roll_radius  # ωy <- Δx
    J[5, 3] = -1.0  # ωz <- Δα
    return J


def projection(diagonal: Sequence[float]) -> np.ndarray:
    """6×6 diagonal 0/1 projection matrix P from its diagonal."""
    d = np.asarray(diagonal, dtype=float)
    if d.shape != (6,) or not np.all((d == 0.0) | (d == 1.0)):
        raise ValueError(f"projection diagonal must be six 0/1 values, got {list(diagonal)!r}")
    return np.diag(d)


#: The projections of the paper's experiments (Sec. V).
PROJECTIONS = {
    "force": (0, 0, 1, 0, 0, 0),
    "position": (1, 1, 0, 0, 0, 0),
    "hybrid": (1, 1, 1, 0, 0, 0),
    "rolling": (1, 1, 1, 1, 1, 0),
    "edge": (0, 0, 1, 0, 0, 1),
    "cable": (1, 1, 1, 0, 0, 1),
    "explore": (1, 1, 1, 1, 1, 1),
}


def feature_errors_of(components: Sequence[int],
                      computed: Sequence[int] | None = None) -> Callable[[object, tuple], list[float]]:
    """The error function of ``components`` of Δf (indices into :data:`FEATURE_NAMES`).

    The one place of the formulas: ``errors(features, targets) -> [Δf[c] for c in components]``
    with ``targets = (target_cop (m, m), target_pressure (Pa), target_orientation (rad))`` and
    ``features`` in contact (the caller checks ``in_contact``).

    Parameters
    ----------
    components : sequence of int
        The components of Δf, in the order of the returned list.
    computed : sequence of int, optional
        Positions in ``components`` that are computed; the others are NaN (default: all). Each
        call computes only these, and the usual selections (pressure, orientation, the COP) get
        a function of one formula: a servo leaf calls it every control cycle.
    """
    components = tuple(int(c) for c in components)
    if any(c not in range(len(FEATURE_NAMES)) for c in components):
        raise ValueError(f"feature components must be in 0..{len(FEATURE_NAMES) - 1}, got {components!r}")
    n = len(components)
    computed = list(range(n)) if computed is None else [int(j) for j in computed]
    if len(computed) == n:  # every component computed: one formula for each usual selection
        if components == (2,):
            return lambda f, targets: [targets[1] - f.pressure]
        if components == (3,):
            return lambda f, targets: [wrap_half_pi(targets[2] - f.orientation)]
        if components == (0, 1):
            def cop_error(f, targets):
                x, y = f.cop_xy
                cop = targets[0]
                return [cop[0] - x, cop[1] - y]
            return cop_error
    wanted = {components[j] for j in computed}
    cop_wanted = 0 in wanted or 1 in wanted

    def errors(f, targets):
        full = [math.nan] * 4
        cop, pressure, alpha = targets
        if cop_wanted:
            x, y = f.cop_xy
            full[0], full[1] = cop[0] - x, cop[1] - y
        if 2 in wanted:
            full[2] = pressure - f.pressure
        if 3 in wanted:
            full[3] = wrap_half_pi(alpha - f.orientation)
        out = [math.nan] * n
        for j in computed:
            out[j] = full[components[j]]
        return out
    return errors


_ALL_ERRORS = feature_errors_of(range(len(FEATURE_NAMES)))


def feature_error(features, target_cop=(0.0, 0.0), target_pressure=0.0, target_orientation=0.0) -> tuple:
    """Δf = target − measured, ``(Δx (m), Δy (m), Δp (Pa), Δα (rad, modulo π))``.

    Components that cannot be measured (no contact, orientation not computed or undefined) are
    NaN; callers skip them. The formulas are :func:`feature_errors_of`'s.
    """
    if not features.in_contact:
        return (math.nan, math.nan, math.nan, math.nan)
    return tuple(_ALL_ERRORS(features, (target_cop, target_pressure, target_orientation)))


def per_component(value, n: int, label: str, owner: str = "") -> list[float]:
    """One number or ``n`` numbers (a gain, a limit, a band) as ``n`` Python floats.

    The one place where per-component settings are broadcast and checked: raises
    ``ValueError`` naming ``owner`` and ``label`` when ``value`` has another length, or holds a
    NaN or a negative number.
    """
    prefix = f"{owner}: " if owner else ""
    try:
        array = np.broadcast_to(np.asarray(value, dtype=float), (n,))
    except ValueError:
        raise ValueError(f"{prefix}{label} must be one number or {n} numbers (one per controlled component), "
                         f"got {value!r}") from None
    if np.any(np.isnan(array)) or np.any(array < 0):
        raise ValueError(f"{prefix}{label} must not be negative, got {value!r}")
    return [float(v) for v in array]


class PID:
    """Vector PID with anti-windup, one independent loop per component (paper Eq. 3).

    ``u = kp·e + ki·∫e dt + kd·de/dt``. The derivative is taken per second (``(e(t) − e(t−1)) / dt``)
    so gains do not depend on the control rate. Anti-windup: the integral is clamped so that
    ``|ki·∫e| ≤ output_limit``, and it does not grow while the output saturates in the direction of
    the error or while the proportional and derivative terms alone saturate it (conditional
    integration: after a large step the integral does not wind up and overshoot). NaN error components leave their state untouched and give ``u = 0``.

    The loops run on Python floats: with one to four components that is several times faster
    than numpy's per-call overhead, and this runs every control cycle.

    Parameters
    ----------
    kp, ki, kd : float or sequence of float
        Gains per component; units are (command unit) / (error unit) [/ s or · s].
    output_limit : float or sequence of float
        Largest ``|u|`` per component.
    n : int, optional
        Number of components (default: the length of ``kp``).
    owner : str
        Name of the leaf the PID belongs to, for error messages.
    """

    def __init__(self, kp, ki=0.0, kd=0.0, output_limit=math.inf, n: int | None = None, owner: str = "") -> None:
        n = int(np.atleast_1d(np.asarray(kp, dtype=float)).shape[0]) if n is None else int(n)
        self.kp = per_component(kp, n, "kp", owner)
        self.ki = per_component(ki, n, "ki", owner)
        self.kd = per_component(kd, n, "kd", owner)
        self.output_limit = per_component(output_limit, n, "output_limit", owner)
        self._imax = [lim / ki if ki > 0 else math.inf for lim, ki in zip(self.output_limit, self.ki)]
        self.n = n
        self.reset()

    def reset(self) -> None:
        """Forget the integral and the previous error (called when a leaf starts)."""
        self._integral = [0.0] * self.n
        self._previous = [math.nan] * self.n

    @property
    def integral(self) -> np.ndarray:
        """The integral ∫e dt per component (error unit · s)."""
        return np.array(self._integral)

    def update(self, error, dt: float, active: Sequence[int] | None = None) -> list[float]:
        """Advance by ``dt`` seconds with ``error`` (sequence of n floats); return ``u`` (list).
        Only the components ``active`` (indices; all by default) advance: the others keep
        their state and command nothing, as for a NaN error."""
        n = self.n
        u = [0.0] * n
        kp, ki_, kd, limits, imaxes = self.kp, self.ki, self.kd, self.output_limit, self._imax
        integrals, previous = self._integral, self._previous
        for i in range(n) if active is None else active:
            e = float(error[i])
            if e != e:  # NaN: hold the state, command nothing
                continue
            prev = previous[i]
            p_and_d = kp[i] * e + (kd[i] * (e - prev) / dt if prev == prev else 0.0)
            ki, lim = ki_[i], limits[i]
            integral = integrals[i] + e * dt
            v = p_and_d + ki * integral
            if abs(p_and_d) >= lim or (v > lim and e > 0) or (v < -lim and e < 0):
                # Anti-windup: no integration while the proportional and derivative terms alone
                # saturate the output (a large error: the integral would only overshoot later),
                # nor into saturation.
                integral = integrals[i]
            imax = imaxes[i]
            if integral < -imax:  # min(max(integral, -imax), imax), without two calls
                integral = -imax
            elif integral > imax:
                integral = imax
            integrals[i] = integral
            previous[i] = e
            v = p_and_d + ki * integral
            u[i] = -lim if v < -lim else (lim if v > lim else v)
        return u


def _limited(values, linear_limit: float, angular_limit: float) -> tuple[float, ...]:
    """Six floats with the linear and the angular part scaled into their norm limits."""
    vx, vy, vz, wx, wy, wz = values
    v = math.sqrt(vx * vx + vy * vy + vz * vz)
    w = math.sqrt(wx * wx + wy * wy + wz * wz)
    if v > linear_limit:
        s = linear_limit / v
        vx, vy, vz = vx * s, vy * s, vz * s
    if w > angular_limit:
        s = angular_limit / w
        wx, wy, wz = wx * s, wy * s, wz * s
    return vx, vy, vz, wx, wy, wz


def limit_twist(twist: np.ndarray, linear_limit: float, angular_limit: float) -> np.ndarray:
    """Scale the linear and angular parts separately so their norms stay within the limits.

    Direction is kept; the limits are in m/s and rad/s.
    """
    out = np.array(twist, dtype=float)
    out[:] = _limited(out.tolist(), linear_limit, angular_limit)
    return out


class ServoCommand:
    """The twist of one control cycle, summed from the parts that running leaves add.

    Each servo leaf adds ``P_i · J⁻¹ · u_i`` and ``guided_slide`` adds ``V_ext``; running
    several leaves in parallel is the paper's superimposed projection (Eq. 3). The mission
    calls :meth:`clear` before the tree tick and :meth:`twist` after it, once per cycle.

    Parameters
    ----------
    linear_limit, angular_limit : float
        Bounds on the summed twist in m/s and rad/s.
    """

    def __init__(self, linear_limit: float = 0.05, angular_limit: float = 1.0) -> None:
        self.linear_limit = float(linear_limit)
        self.angular_limit = float(angular_limit)
        self._sum = [0.0] * 6
        self._added: list[tuple[str, tuple]] = []  # (source, twist) in the order added
        self.errors: dict[str, float] = {}

    def clear(self) -> None:
        """Start a new cycle: no parts, no errors."""
        self._sum = [0.0] * 6
        self._added.clear()
        self.errors.clear()

    def add(self, source: str, twist) -> None:
        """Add a partial sensor-frame twist (6 numbers, m/s and rad/s) from the leaf ``source``."""
        values = tuple(twist.tolist() if isinstance(twist, np.ndarray) else twist)
        if len(values) != 6:
            raise ValueError(f"{source}: a twist must be 6 finite numbers, got {twist!r}")
        v0, v1, v2, v3, v4, v5 = values
        if not math.isfinite(v0 + v1 + v2 + v3 + v4 + v5):
            raise ValueError(f"{source}: a twist must be 6 finite numbers, got {twist!r}")
        total = self._sum
        self._sum = [total[0] + v0, total[1] + v1, total[2] + v2, total[3] + v3, total[4] + v4, total[5] + v5]
        self._added.append((source, values))

    @property
    def parts(self) -> dict[str, np.ndarray]:
        """The twist each source added this cycle, by source name."""
        parts: dict[str, list] = {}
        for source, values in self._added:
            previous = parts.get(source)
            parts[source] = list(values) if previous is None else [p + v for p, v in zip(previous, values)]
        return {k: np.array(v, dtype=float) for k, v in parts.items()}

    def report_error(self, feature: str, value: float) -> None:
        """Record the error of a controlled feature this cycle (for logs and metrics)."""
        self.errors[feature] = float(value)

    def summed(self) -> np.ndarray:
        """The parts added so far this cycle, summed, before the twist limits (sensor frame,
        m/s and rad/s): what a leaf ticked after the others (a guard) sees of the cycle."""
        return np.array(self._sum, dtype=float)

    def twist(self) -> np.ndarray:
        """The summed sensor-frame twist of this cycle, within the twist limits."""
        return np.array(_limited(self._sum, self.linear_limit, self.angular_limit))
