"""Resolved-rate motion of the LWR 4: damped least squares with joint-limit saturation.

:class:`ResolvedRateMixin` gives :class:`~tactile_bt.robot.kinematics.LWR4Kinematics` its
``resolved_rate`` method (joint velocities for a spatial twist of the sensor), with the
diagnostics :class:`RateSolution`; :func:`damped_least_squares`, the damped least-squares solve, also serves
the pose IK ``LWR4Kinematics.ik_pose``.  :mod:`tactile_bt.robot.kinematics` re-exports them.

Method
------
``resolved_rate`` is damped least squares with a singular-value-based damping
schedule (Chiaverini 1997; Maciejewski & Klein 1988; Nakamura & Hanafusa 1986 use the
manipulability instead): ``lambda^2 = lambda_max^2 (1 - (sigma_min / eps)^2)`` when the smallest
singular value ``sigma_min`` drops below ``eps``, 0 otherwise, so ``|q_dot| <= |V| / (2 lambda_max)``
however close the arm is to a singularity.  Joint limits are handled by saturation in the
null space (after Flacco, De Luca & Khatib 2012, "SNS"): a joint that would leave its range in
the next step is fixed at the velocity that just reaches the limit, and the remaining joints
are re-solved for the rest of the twist, so a 7-DOF arm keeps the commanded Cartesian motion
while one joint rests on its stop.  Joint velocity limits scale the whole vector (the direction
is kept).  The least-squares problem is posed on the *hybrid* twist ``[p_dot; w]`` of the pad
centre, not on ``V_g``: the two give the same exact solution, but only the former makes the
damped (approximate) solution independent of where the base origin lies.

Layer: robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_bt.control.spatial import skew

__all__ = ["RateSolution", "ResolvedRateMixin"]


@dataclass
class RateSolution:
    """Diagnostics of one :meth:`~ResolvedRateMixin.resolved_rate` solve.

    Attributes
    ----------
    q_dot : (7,) ndarray
        Joint velocities in rad/s.
    damping : float
        Damping ``lambda`` actually used (same unit as the hybrid Jacobian, m/rad).
    sigma_min : float
        Smallest singular value of the hybrid Jacobian at ``q``.
    saturated : (7,) ndarray of bool
        Joints held at the velocity that reaches their position limit.
    scale : float
        Factor (<= 1) applied to respect the velocity limits.
    """

    q_dot: np.ndarray
    damping: float
    sigma_min: float
    saturated: np.ndarray
    scale: float



class ResolvedRateMixin:
    """Resolved-rate motion of a 7-joint arm (module docstring).

    Mixed into :class:`~tactile_bt.robot.kinematics.LWR4Kinematics`, whose ``_check_q``,
    ``pose_and_jacobian`` and limits ``q_min``, ``q_max`` and ``qd_max`` it uses.
    """

    def resolved_rate(
        self,
        q,
        twist_g,
        dt: float | None = None,
        damping: float = 0.05,
        sigma_threshold: float = 0.05,
        q_dot_null=None,
        velocity_limits: bool = True,
        return_info: bool = False,
    ):
        """Joint velocities that realise a spatial twist of the sensor (damped least squares).

        Parameters
        ----------
        q : (7,) array
            Current joint angles in rad (for the compliant arm: the equilibrium posture).
        twist_g : (6,) array
            Desired spatial twist ``V_g = Ad(T_gs) V_s`` of the sensor, global frame (m/s, rad/s).
        dt : float, optional
            Duration in s the velocities will be applied for.  With it, no joint passes its
            limit at the end of the step (a joint driven into its limit stops exactly there);
            without it, joints already at or beyond a limit only may not move further out.
        damping : float
            Largest damping ``lambda_max`` (m/rad), reached at a singularity.  ``0`` gives the
            plain pseudo-inverse (with a rank cut-off, never inf).
        sigma_threshold : float
            ``eps``: damping switches on when the smallest singular value of the hybrid
            Jacobian drops below it (m/rad).
        q_dot_null : (7,) array, optional
            Secondary joint velocity (rad/s), projected into the null space of the Jacobian
            (posture keeping, limit avoidance); it does not disturb the Cartesian motion.
        velocity_limits : bool
            Scale the whole vector down so that ``|q_dot_i| <= qd_max_i`` (direction kept).
        return_info : bool
            Return a :class:`RateSolution` instead of the bare vector.

        Returns
        -------
        (7,) ndarray or RateSolution
            ``q_dot`` in rad/s, always finite.
        """
        q = self._check_q(q)
        V = np.asarray(twist_g, dtype=float)
        if V.shape != (6,) or not math.isfinite(float(V @ V)):
            raise ValueError(f"twist_g must be 6 finite numbers, got {twist_g!r}")
        if dt is not None and not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        null = None
        if q_dot_null is not None:
            null = np.asarray(q_dot_null, float)
            if null.shape != (7,) or not math.isfinite(float(null @ null)):
                raise ValueError("q_dot_null must be 7 finite numbers")
        T, J = self.pose_and_jacobian(q)
        S = skew(T[:3, 3])
        Jh = J.copy()
        Jh[:3] -= S @ J[3:]
        Vh = V.copy()
        Vh[:3] -= S @ V[3:]

        # Velocity bounds that keep the joints inside their limits after dt.
        if dt is None:
            lo = np.where(q <= self.q_min, 0.0, -np.inf)
            hi = np.where(q >= self.q_max, 0.0, np.inf)
        else:
            lo = np.minimum((self.q_min - q) / dt, 0.0)
            hi = np.maximum((self.q_max - q) / dt, 0.0)

        qd, lam, smin = damped_least_squares(Jh, Vh, damping, sigma_threshold, null)
        free = np.ones(7, dtype=bool)
        if not ((qd >= lo).all() and (qd <= hi).all()):
            # Saturation in the null space: fix the worst offender at its bound, re-solve the rest.
            for _ in range(7):
                over = np.where(free, np.maximum(qd - hi, lo - qd), -np.inf)
                j = int(np.argmax(over))
                if over[j] <= 1e-12:
                    break
                qd[j] = min(max(qd[j], lo[j]), hi[j])
                free[j] = False
                if not free.any():
                    break
                rest = Vh - Jh[:, ~free] @ qd[~free]
                qd[free] = damped_least_squares(Jh[:, free], rest, damping, sigma_threshold,
                                None if null is None else null[free])[0]
            qd = np.minimum(np.maximum(qd, lo), hi)
        scale = 1.0
        if velocity_limits:
            peak = float(np.max(np.abs(qd) / self.qd_max))
            if peak > 1.0:
                scale = 1.0 / peak
                qd = qd * scale
        if not math.isfinite(float(qd @ qd)):  # cannot happen with finite inputs; belt and braces
            qd = np.zeros(7)
        if return_info:
            return RateSolution(qd, lam, smin, ~free, scale)
        return qd


def damped_least_squares(J: np.ndarray, V: np.ndarray, lam_max: float, eps: float, null=None):
    """Damped least squares ``J^T (J J^T + lambda^2 I)^-1 V`` with the damping schedule.

    Returns ``(x, lambda, sigma_min)``; ``null`` (optional) is projected on the null space of
    ``J`` (the right singular vectors beyond the numerical rank) and added.
    """
    rows, n = J.shape
    if n == 0:
        return np.zeros(0), 0.0, 0.0
    U, s, Vt = np.linalg.svd(J, full_matrices=null is not None)
    m = s.shape[0]
    # With fewer free joints than task rows the missing directions count as zero.
    smin = float(s[-1]) if m == rows else 0.0
    lam2 = lam_max * lam_max * (1.0 - (smin / eps) ** 2) if smin < eps else 0.0
    denom = s * s + lam2
    gain = np.divide(s, denom, out=np.zeros(m), where=denom > 1e-24)
    x = Vt[:m].T @ (gain * (U[:, :m].T @ V))
    if null is not None:
        N = Vt[int(np.count_nonzero(s > 1e-9)):]
        x += N.T @ (N @ null)
    return x, math.sqrt(lam2), smin
