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
however close the arm is to a singularity.  Where the damping acts, its weak direction mixes a
slide of the pad with a turn (the wrist nearly straight, ``q6 ~ 0``, in some postures), and
damping it would drop the two together: a roll the arm can hardly make became a slide of 0.3 m/s
nobody asked for, and a retreat lost the slide that frees a corner from a wall.  There the
translation rows, which stay well conditioned, are solved first and the turn as far as the joints
then allow (:func:`translation_first`): what the damping drops is turn, never slide.  Joint limits are handled by saturation in the
null space (after Flacco, De Luca & Khatib 2012, "SNS"): a joint that would leave its range in
the next step is fixed at the velocity that just reaches the limit, and the remaining joints
are re-solved for the rest of the twist, so a 7-DOF arm keeps the commanded Cartesian motion
while one joint rests on its stop.  When that joint is the last (the flange's own rotation, which
the others can hardly make up for) and the twist is a pure translation (no rotation asked, as
the supervisor's retreat), the re-solve leaves out holding the orientation about its axis: the
pad moves as asked and may turn about its normal, instead of being held still by a hold of the
orientation the others cannot make (a retreat from the object slowed to a few per cent).  Any
other twist keeps all six parts; a motion that turns or rolls the pad then slows down on its
path, which the table guard's prediction of the corners relies on.  Joint velocity limits scale the whole vector (the direction
is kept), and the limits are checked on the scaled velocities.  With the velocity limits on, the
re-solve is *undamped* (pseudo-inverse with a rank cut-off at 1e-9): where the remaining joints
can make the twist only with large velocities (their Jacobian near singular), the scaling slows
the whole pad motion down on its commanded path, down to holding the pad, instead of letting
damping turn the part they cannot make into a motion in another direction.  (That was a 35 to
55 mm sideways jump of the pad when joint 7 saturated during a turn about the pad normal; see
docs/scanning.md, "Limits".)  Where that would slow the pad to less than 1/50, the re-solve is
damped after all, the translation first (:func:`translation_first`), if it then turns the pad
more about the axis asked than across it: with the arm stretched (the elbow straight) and joint 2
or 6 on its stop, the undamped re-solve made the twist with joints 3 and 5 turning against each
other at thousands of rad/s, scaled to nothing; they swung back and forth every cycle while the
pad stood still for 20 to 50 s (damped, it slides as asked and makes half the turn).  A turn
about the pad normal with joint 7 on its stop is still held: damped, 2 % of it was made, and a
tilt across it seven times as fast pressed the pad's edge in.  What they cannot do at all (the
elbow's direction, with joint 4 on its stop) is dropped in the least-squares sense.  With fewer
joints left than parts of the twist (two joints on their stops while the pad turns), that
least-squares fit would weigh metres per second against radians per second and trade a roll the
wrist cannot make for a slide of the pad (0.3 m/s into a ring's side, with joints 5 and 7 wound
onto their stops): there the translation is made first and the turn only as far as the joints
left over can make it (:func:`translation_first`).  The least-squares problem is posed on the
*hybrid* twist ``[p_dot; w]`` of the pad centre, not on ``V_g``: the two give the same exact
solution, but only the former makes the damped (approximate) solution independent of where the
base origin lies.

Null space
----------
``q_dot_null`` is projected on the null space of the (free columns of the) hybrid Jacobian with
the right singular vectors of the SVD the damped solve computes anyway, then scaled so that no
joint moves faster than ``null_speed_max``; so it cannot change ``J q_dot``.  The arm feeds it
the limit and wrist-singularity avoidance of :mod:`tactile_bt.robot.redundancy`.  While a joint
is saturated the re-solve keeps the null space of the remaining joints (for the LWR with its
elbow on a limit, still the swivel).  :attr:`RateSolution.residual` is the part of the
commanded hybrid twist the joint velocities do not realise (damping near a singularity, a
saturated joint, the velocity scaling): the mission integrates it into the task-space error of
a joint-limit warning.

Layer: robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_bt.control.spatial import skew

__all__ = ["RateSolution", "ResolvedRateMixin"]

#: The undamped re-solve after a saturation is kept while it needs at most this factor over the
#: joints' speed limits (the pad slowed down to 1/50 of the twist on its path); beyond it, it is
#: damped, translation first, where that turns the pad on its way.
_CRAWL_PEAK = 50.0


@dataclass
class RateSolution:
    """Diagnostics of one :meth:`~ResolvedRateMixin.resolved_rate` solve.

    Attributes
    ----------
    q_dot : (7,) ndarray
        Joint velocities in rad/s.
    damping : float
        Damping ``lambda`` of the six-row solve (same unit as the hybrid Jacobian, m/rad);
        where it is above 0, the translation was made first (:func:`translation_first`).
    sigma_min : float
        Smallest singular value of the hybrid Jacobian at ``q``.
    saturated : (7,) ndarray of bool
        Joints held at the velocity that reaches their position limit.
    scale : float
        Factor (<= 1) applied to respect the velocity limits.
    residual : (6,) ndarray
        Commanded minus realised hybrid twist ``[p_dot; w] - J_h q_dot`` of the pad centre
        (m/s, rad/s, global frame): what the solve could not do.
    """

    q_dot: np.ndarray
    damping: float
    sigma_min: float
    saturated: np.ndarray
    scale: float
    residual: np.ndarray



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
        null_speed_max: float | None = None,
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
        null_speed_max : float, optional
            Largest joint speed (rad/s) of the projected null-space motion (it is scaled down,
            direction kept); no cap when omitted.
        velocity_limits : bool
            Scale the whole vector down so that ``|q_dot_i| <= qd_max_i`` (direction kept).
            With it, the re-solve after a saturation is undamped (module docstring).
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
        if null_speed_max is not None and not (math.isfinite(null_speed_max) and null_speed_max >= 0.0):
            raise ValueError(f"null_speed_max must be a finite speed >= 0 rad/s, got {null_speed_max!r}")
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

        qd, lam, smin = damped_least_squares(Jh, Vh, damping, sigma_threshold, null, null_speed_max)
        if lam > 0.0:
            # Near a singularity of all six rows (the wrist nearly straight, q6 ~ 0, in some
            # postures): the weak direction mixes a slide with a turn, and damping it drops both
            # together, which adds a slide nobody asked for (0.3 m/s for a 0.6 rad/s roll) or
            # takes one away (a retreat that cannot leave a wall). The translation rows alone
            # are well conditioned there: make the translation first, the turn as far as it goes.
            qd = translation_first(Jh, Vh, damping, damping, sigma_threshold, null, null_speed_max)
        free = np.ones(7, dtype=bool)
        peak = self._speed_peak(qd) if velocity_limits else 1.0
        # Saturation in the null space: fix the worst offender at the velocity that reaches its
        # limit, re-solve the rest of the twist with the other joints; the bounds are checked on
        # the velocities as they will be applied (after the speed scaling).
        for _ in range(7):
            x = qd / peak if peak > 1.0 else qd
            if free.all() and (x >= lo).all() and (x <= hi).all():
                break  # the common case: no joint at a limit
            over = np.where(free, np.maximum(x - hi, lo - x), -np.inf)
            j = int(np.argmax(over))
            if over[j] <= 1e-12:
                break
            qd[j] = hi[j] if x[j] > hi[j] else lo[j]
            free[j] = False
            if not free.any():
                break
            rest = Vh - Jh[:, ~free] @ qd[~free]
            sub = None if null is None else null[free]
            rows = Jh[:, free]
            pure = not np.any(Vh[3:])  # a pure translation: the supervisor's retreat, a lift-off
            if pure and not free[-1]:  # with the flange's own rotation on its stop:
                keep = _without_axis(J[3:, -1])  # the pad may turn about that axis
                rows, rest = keep @ rows, keep @ rest
            # With the speed scaling, undamped: exact where the other joints can do it. Damping
            # would trade the rotation they can hardly make for a translation nobody asked for
            # (the pad "jumps" sideways); the speed scaling below scales the whole twist
            # instead, so the pad slows down on its path and holds where the rest is out of
            # reach. What the remaining joints cannot do at all (the elbow's direction) is
            # dropped in the least-squares sense; with fewer joints than rows, or for a pure
            # translation, the turn is dropped before the slide.
            lam = damping if not velocity_limits else 0.0
            if rows.shape[0] > rows.shape[1]:  # fewer joints left than parts of the twist
                qd[free] = translation_first(rows, rest, lam, lam, sigma_threshold, sub, null_speed_max)
            elif pure and free[-1]:  # hold the orientation only as far as it goes without a crawl
                qd[free] = translation_first(rows, rest, lam, damping, sigma_threshold, sub, null_speed_max)
            else:
                qd[free] = damped_least_squares(rows, rest, lam, sigma_threshold, sub, null_speed_max)[0]
            if velocity_limits:
                peak = self._speed_peak(qd)
                if peak > _CRAWL_PEAK:  # the joints left make this twist only at a crawl: damped after all,
                    # where that turns the pad more the way asked than another way
                    x = translation_first(rows, rest, damping, damping, sigma_threshold, sub, null_speed_max)
                    if _turns_on_its_way(rows @ x, rest):
                        qd[free] = x
                        peak = self._speed_peak(qd)
        scale = 1.0 / peak
        if scale < 1.0:
            qd = qd * scale
        if not free.all():
            qd = np.minimum(np.maximum(qd, lo), hi)
        if not math.isfinite(float(qd @ qd)):  # cannot happen with finite inputs; belt and braces
            qd = np.zeros(7)
        if return_info:
            return RateSolution(qd, lam, smin, ~free, scale, Vh - Jh @ qd)
        return qd

    def _speed_peak(self, qd: np.ndarray) -> float:
        """``max(1, max_i |qd_i| / qd_max_i)``: the factor that brings ``qd`` within the velocity limits."""
        return max(1.0, float(np.max(np.abs(qd) / self.qd_max)))


def _turns_on_its_way(made: np.ndarray, asked: np.ndarray) -> bool:
    """Whether the twist rows ``made`` turn the pad more about the axis ``asked`` turns it about
    than about any axis across it (True when no turn is asked, or the rows hold no turn)."""
    if made.shape[0] < 6:
        return True
    w = asked[3:]
    size = float(np.linalg.norm(w))
    if size < 1e-9:
        return True
    along = float(made[3:] @ w) / size
    return along > float(np.linalg.norm(made[3:] - along * w / size))


def _without_axis(axis: np.ndarray) -> np.ndarray:
    """``(5, 6)``: the rows of a hybrid twist ``[p_dot; w]`` but the rotation about ``axis``
    (world): the translation and the two rotations across it."""
    a = np.asarray(axis, dtype=float) / max(float(np.linalg.norm(axis)), 1e-12)
    u = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    keep = np.zeros((5, 6))
    keep[:3, :3] = np.eye(3)
    keep[3, 3:], keep[4, 3:] = u, np.cross(a, u)
    return keep


def translation_first(rows: np.ndarray, V: np.ndarray, lam_max: float, lam_turn: float, eps: float, null=None,
                      null_max: float | None = None) -> np.ndarray:
    """Joint velocities for the hybrid twist rows ``rows``, translation first, then rotation (the
    re-solve after a saturation, when fewer joints are left than rows or the twist is a pure
    translation; and the first solve wherever its damping acts, near a singularity): the
    translation ``V[:3]`` as well as the joints can
    make it (:func:`damped_least_squares`), then the rotation ``V[3:]`` as far as it goes
    without disturbing the translation (in the null space of the translation rows), damped up
    to ``lam_turn`` (rad/rad) where the joints could make it only with large velocities.

    Where the whole twist can be made this is the minimum-norm solution
    :func:`damped_least_squares` gives; where it cannot, what is dropped is turn (rad/s), never
    a slide (m/s) of the pad that nobody asked for, as a least-squares fit over both units would.
    ``null`` is projected on what null space is left of all rows.
    """
    P, W = rows[:3], rows[3:]
    x = damped_least_squares(P, V[:3], lam_max, eps)[0]
    _, s, Vt = np.linalg.svd(P)
    N = Vt[int(np.count_nonzero(s > 1e-9)):].T  # joint motions that leave the translation alone
    if N.shape[1] and W.shape[0]:
        z = damped_least_squares(W @ N, V[3:] - W @ x, lam_turn, eps)[0]
        x = x + N @ z
    if null is not None:
        x = x + damped_least_squares(rows, np.zeros(rows.shape[0]), 0.0, eps, null, null_max)[0]
    return x


def damped_least_squares(J: np.ndarray, V: np.ndarray, lam_max: float, eps: float, null=None,
                         null_max: float | None = None):
    """Damped least squares ``J^T (J J^T + lambda^2 I)^-1 V`` with the damping schedule.

    Returns ``(x, lambda, sigma_min)``; ``null`` (optional) is projected on the null space of
    ``J`` (the right singular vectors beyond the numerical rank), scaled so that its largest
    component is at most ``null_max`` (when given), and added.
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
    gain = np.divide(s, denom, out=np.zeros(m), where=(denom > 1e-24) & (s > 1e-9))
    x = Vt[:m].T @ (gain * (U[:, :m].T @ V))
    if null is not None:
        N = Vt[int(np.count_nonzero(s > 1e-9)):]
        xn = N.T @ (N @ null)
        if null_max is not None:
            peak = float(np.max(np.abs(xn))) if xn.size else 0.0
            if peak > null_max:
                xn *= null_max / peak
        x += xn
    return x, math.sqrt(lam2), smin
