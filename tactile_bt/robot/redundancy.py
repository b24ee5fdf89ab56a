"""The LWR 4's redundancy: keep the joints off their limits and the wrist off its singularity.

The arm has seven joints for the six-dimensional motion of the pad, so a one-dimensional family
of postures (the *elbow swivel*: the elbow turning about the shoulder-wrist line) leaves the pad
where it is.  :meth:`LimitAvoidance.q_dot` is a joint velocity that
:meth:`~tactile_bt.robot.kinematics.LWR4Kinematics.resolved_rate` projects into the null space of
the pad's Jacobian (with the right singular vectors its damped least-squares SVD computes
anyway: no extra factorisation), so it moves the arm along that family without disturbing the
commanded pad twist.

Objective
---------
With ``r_i = q_max_i - q_min_i`` and the normalised position ``u_i = (2 q_i - q_max_i - q_min_i) / r_i``
(``-1`` and ``+1`` at the limits, ``0`` mid-range), the cost is

    H(q) = sum_i w_i u_i^2 / (1 - u_i^2)  +  w_wrist c(q_6),
    c(q_6) = (1 - |q_6| / delta)^2  for |q_6| < delta, else 0,

a barrier per joint (``u^2`` near mid-range, the classic joint-range criterion of Liegeois 1977;
infinite at either limit, so the joint nearest its limit dominates the sum: the joints are
weighed by their margin) plus a term that pushes the wrist bend ``q_6`` out of the band
``|q_6| < delta`` around the wrist singularity ``q_6 = 0`` (joints 5 and 7 aligned).  The
secondary velocity is its negative gradient,

    q_dot_null = -k dH/dq,
    dH/dq_i = w_i (2 / r_i) 2 u_i / (1 - u_i^2)^2  (+ w_wrist dc/dq_6 for i = 6),

and :meth:`~tactile_bt.robot.kinematics.LWR4Kinematics.resolved_rate` scales its null-space
projection so that no joint moves faster than ``speed_max``.  Defaults (:class:`LimitAvoidance`):
``k = 0.05 rad^2/s``, ``delta = 20 deg``, ``w_wrist = 1``, ``speed_max = 0.5 rad/s``, weights 1
except ``w_4 = 0``.  A joint 9 deg from a 170 deg limit then gets about 3 rad/s before the
projection and the cap (the swivel turns it away at up to ``speed_max``); mid-range (``u = 0.5``)
the pull is 0.03 rad/s, a slow drift to the middle of the joint ranges.

The wrist term has little leverage, and needs little: near ``q_6 = 0`` the self-motion is mostly
joints 5 and 7 turning against each other, which leaves ``q_6`` alone (``tests/robot/test_redundancy.py``
measures about 0.5 deg/s at ``q_6 = 14 deg``), and the 7-joint Jacobian keeps its rank there
(smallest singular value 0.127 m/rad at ``q_6 = 0``, 0.142 at 20 deg, near the ready posture).
``q_6 = 0`` is singular only for the six other joints, when joint 5 or 7 is held on a limit; the
resolved-rate solve then slows the pad down rather than letting it jump
(:mod:`tactile_bt.robot.resolved_rate`).

The elbow (joint 4) is not in the cost: its angle is set by the shoulder-wrist distance, which
the pad pose fixes, so the swivel cannot move it (its component of the null space is zero).  When
the elbow reaches its limit, the resolved-rate solve saturates it and the mission reports it
(:mod:`tactile_bt.mission.joints`).

Layer: robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LimitAvoidance", "joint_margins"]

#: Closest ``1 - u^2`` the barrier evaluates (a joint exactly on its limit gets a large, finite push).
_MIN_GAP = 1e-3


def joint_margins(q, q_min, q_max) -> np.ndarray:
    """Normalised distance of each joint from its nearer limit: ``1 - |u_i|``, 1 mid-range, 0 on a limit.

    Parameters
    ----------
    q, q_min, q_max : (7,) arrays
        Joint angles and limits (rad).
    """
    q, lo, hi = (np.asarray(a, float) for a in (q, q_min, q_max))
    return np.minimum(q - lo, hi - q) / (0.5 * (hi - lo))


@dataclass(frozen=True)
class LimitAvoidance:
    """Secondary (null-space) objective of the arm: joint limits and the wrist singularity.

    Attributes
    ----------
    gain : float
        ``k`` in rad^2/s: ``q_dot_null = -k dH/dq`` (module docstring).
    wrist_band_rad : float
        ``delta``: half width of the band around ``q_6 = 0`` the wrist is pushed out of (rad).
    wrist_weight : float
        ``w_wrist``, weight of the wrist term against the joint-limit barrier.
    speed_max : float
        Largest joint speed (rad/s) of the null-space motion after its projection.
    weights : tuple of 7 floats
        ``w_i`` of each joint's barrier; joint 4 (the elbow) is 0 (the swivel cannot move it).
    """

    gain: float = 0.05
    wrist_band_rad: float = math.radians(20.0)
    wrist_weight: float = 1.0
    speed_max: float = 0.5
    weights: tuple = (1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        for name in ("gain", "wrist_band_rad", "wrist_weight", "speed_max"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"LimitAvoidance.{name} must be a finite number >= 0, got {value!r}")
        w = np.asarray(self.weights, float)
        if w.shape != (7,) or not np.all(np.isfinite(w)) or np.any(w < 0.0):
            raise ValueError(f"LimitAvoidance.weights must be 7 finite numbers >= 0, got {self.weights!r}")
        object.__setattr__(self, "_w", w)

    def _normalised(self, q, q_min, q_max):
        r = q_max - q_min
        u = (2.0 * q - q_max - q_min) / r
        gap = np.maximum(1.0 - u * u, _MIN_GAP)
        return r, u, gap

    def cost(self, q, q_min, q_max) -> float:
        """``H(q)`` of the module docstring (dimensionless)."""
        q = np.asarray(q, float)
        _, u, gap = self._normalised(q, q_min, q_max)
        h = float(np.sum(self._w * u * u / gap))
        a = abs(float(q[5])) / self.wrist_band_rad if self.wrist_band_rad > 0.0 else 1.0
        if a < 1.0:
            h += self.wrist_weight * (1.0 - a) ** 2
        return h

    def q_dot(self, q, q_min, q_max) -> np.ndarray:
        """``-k dH/dq`` (rad/s), before the null-space projection; cheap (7-vector arithmetic)."""
        q = np.asarray(q, float)
        r, u, gap = self._normalised(q, q_min, q_max)
        grad = self._w * (2.0 / r) * 2.0 * u / (gap * gap)
        band = self.wrist_band_rad
        q6 = float(q[5])
        if band > 0.0 and abs(q6) < band:
            side = 1.0 if q6 >= 0.0 else -1.0
            grad[5] -= self.wrist_weight * 2.0 * side * (1.0 - abs(q6) / band) / band
        return -self.gain * grad
