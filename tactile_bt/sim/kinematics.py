"""Kinematics of the 7-DOF KUKA LWR 4 with a tactile pad as fingertip.

Frames
------
* ``g``  -- the global (world) frame.  The arm's base frame ``0`` sits at ``T_g0`` (``base``,
  identity by default, so that ``g`` *is* the base frame unless a scene moves the robot).
* ``0..7`` -- the classic (distal, "standard") Denavit-Hartenberg frames; joint ``i`` (1-based)
  turns about ``z_{i-1}``.  Frame ``7`` is the flange ``e``.
* ``s``  -- the sensor frame O_s of DESIGN.md (origin at the pad centre, ``+z_s`` the sensing
  normal pointing at the object), ``T_es`` (``mount``) from the flange.

``fk(q)`` returns ``T_gs = T_g0 . T_07(q) . T_es``.

Twists and wrenches
-------------------
Twists are ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s).  The *spatial* twist ``V_g`` of the sensor
is ``[v_g; w]`` with ``v_g = p_dot + p x w`` (the velocity of the body point passing through the
origin of ``g``), so that ``V_g = Ad(T_gs) V_s`` and ``d/dt T_gs = [V_g] T_gs``.  The spatial
Jacobian gives ``V_g = J(q) q_dot``; its dual wrench ``[f; tau_O]`` (N, N m, torque about the
origin of ``g``) maps to joint torques by ``tau = J(q)^T w``.

DH parameters (source)
----------------------
Classic (distal) DH table of the LWR 4::

    i   d_i [m]   a_i   alpha_i    joint limit     velocity limit
    1   0.3105    0     +pi/2      +-170 deg       110 deg/s
    2   0         0     -pi/2      +-120 deg       110 deg/s
    3   0.4       0     -pi/2      +-170 deg       128 deg/s
    4   0         0     +pi/2      +-120 deg       128 deg/s
    5   0.39      0     +pi/2      +-170 deg       204 deg/s
    6   0         0     -pi/2      +-120 deg       184 deg/s
    7   0.078     0      0         +-170 deg       184 deg/s

* Twists ``alpha_i``, ``d_3 = 0.40`` and ``d_5 = 0.39``: P. Corke's Robotics Toolbox for Python,
  ``roboticstoolbox/models/DH/LWR4.py`` (standard ``RevoluteDH`` links, despite a comment there
  calling them modified), which takes its table from A. De Luca, *Robotics 1 -- Exercise: DH
  frames of the KUKA LWR 4*, http://www.diag.uniroma1.it/~deluca/rob1_en/09_Exercise_DH_KukaLWR4.pdf
  (that model puts its base frame at the shoulder, ``d_1 = 0``, and the flange in a tool offset).
* Base-to-shoulder ``d_1 = 0.3105 m``, wrist-to-flange ``d_7 = 0.078 m``, the joint axes, the
  limits and the velocities: the LWR 4+ URDF of CentroEPiaggio/kuka-lwr
  (``lwr_description/model/kuka_lwr.urdf.xacro``: 0.11 + 0.2005 m to the shoulder, 0.2 + 0.2 m and
  0.2 + 0.19 m for the two long links, 0.078 m to the flange; joint 2 about ``-y``, joint 4 about
  ``+y``, joint 6 about ``-y``), which this table reproduces exactly at ``q = 0`` (the arm
  stretched straight up; ``tests/test_arm.py`` checks it).  KUKA's data sheet rounds the
  shoulder height to 310 mm.

The classic convention is used, not the modified (Craig) one: both give the same flange pose,
they only attach the intermediate frames differently.

Inverse kinematics
------------------
:meth:`LWR4Kinematics.resolved_rate` is damped least squares with a singular-value-based damping
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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.spatial import adjoint, invert, make_pose, skew

__all__ = [
    "DH_D",
    "DH_A",
    "DH_ALPHA",
    "Q_MIN",
    "Q_MAX",
    "QD_MAX",
    "Q_READY",
    "DEFAULT_MOUNT_OFFSET_M",
    "PAD_SIZE_M",
    "default_mount",
    "RateSolution",
    "LWR4Kinematics",
]

_DEG = np.pi / 180.0

#: Classic DH link offsets ``d_i`` in metres (see module docstring for the source).
DH_D = np.array([0.3105, 0.0, 0.4, 0.0, 0.39, 0.0, 0.078])
#: Classic DH link lengths ``a_i`` in metres (all zero for the LWR).
DH_A = np.zeros(7)
#: Classic DH link twists ``alpha_i`` in radians.
DH_ALPHA = np.array([np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, 0.0])
#: Joint limits in radians (KUKA LWR 4: +-170 deg for the turning joints, +-120 deg for the bending).
Q_MAX = np.array([170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 170.0]) * _DEG
Q_MIN = -Q_MAX
#: Joint velocity limits in rad/s (LWR 4+ data, as in the CentroEPiaggio URDF).
QD_MAX = np.array([110.0, 110.0, 128.0, 128.0, 204.0, 184.0, 184.0]) * _DEG
#: A comfortable posture: elbow up, pad 0.54 m in front of the base (+x), normal pointing down
#: (``z_s = -z_g``, ``x_s = -x_g``, ``y_s = +y_g``), 0.34 m above the base plane with the default
#: mount; joints 30-90 deg from their limits, smallest singular value of the hybrid Jacobian 0.22.
Q_READY = np.array([0.0, -30.0, 0.0, 90.0, 0.0, -60.0, 0.0]) * _DEG

#: Distance from the flange to the pad centre along the flange z axis, in metres: a 30 mm
#: adapter plate plus the 10 mm stack of the pad (carrier PCB, sensing layer and foam).
DEFAULT_MOUNT_OFFSET_M = 0.04


def default_mount(offset: float = DEFAULT_MOUNT_OFFSET_M) -> np.ndarray:
    """Flange-to-sensor transform ``T_es`` of the default fingertip mount.

    The 16x16 pad (80 x 80 mm at 5 mm pitch) is centred on the flange axis, ``offset`` metres
    out along the flange ``z_e``; its axes are parallel to the flange's (``x_s = x_e``,
    ``y_s = y_e``), so the sensing normal ``+z_s = +z_e`` points away from the flange, towards
    whatever the fingertip touches.

    Parameters
    ----------
    offset : float
        Flange-to-pad-centre distance in metres (default 0.04 m).

    Returns
    -------
    (4, 4) ndarray
        ``T_es``.
    """
    return make_pose(None, (0.0, 0.0, float(offset)))


#: Side length of the pad in metres (16 tactels x 5 mm), for drawing.
PAD_SIZE_M = defaults.COLS * defaults.PITCH_M


@dataclass
class RateSolution:
    """Diagnostics of one :meth:`LWR4Kinematics.resolved_rate` solve.

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


def _homogeneous(frame) -> np.ndarray:
    """4x4 matrix from a chain frame ``(x, y, z, p)`` (axis and origin lists, global frame)."""
    x, y, z, p = frame
    return np.array([x + [0.0], y + [0.0], z + [0.0], p + [1.0]]).T


class LWR4Kinematics:
    """Forward and differential kinematics of the KUKA LWR 4 with a fingertip mount.

    Parameters
    ----------
    mount : (4, 4) array, optional
        Flange-to-sensor transform ``T_es``; :func:`default_mount` if omitted.
    base : (4, 4) array, optional
        Pose ``T_g0`` of the robot base in the global frame (identity if omitted).
    q_min, q_max : (7,) array, optional
        Joint limits in rad (default :data:`Q_MIN`, :data:`Q_MAX`).
    qd_max : (7,) array, optional
        Joint velocity limits in rad/s (default :data:`QD_MAX`).
    """

    n_joints: int = 7

    def __init__(
        self,
        mount: np.ndarray | None = None,
        base: np.ndarray | None = None,
        q_min: np.ndarray | None = None,
        q_max: np.ndarray | None = None,
        qd_max: np.ndarray | None = None,
    ) -> None:
        self.d = DH_D.copy()
        self.a = DH_A.copy()
        self.alpha = DH_ALPHA.copy()
        ca, sa = np.cos(self.alpha), np.sin(self.alpha)
        ca[np.abs(ca) < 1e-15] = 0.0  # exact zeros for the +-90 deg twists
        self._d_list, self._a_list = self.d.tolist(), self.a.tolist()
        self._ca_list, self._sa_list = ca.tolist(), sa.tolist()
        self.mount = default_mount() if mount is None else _check_pose(mount, "mount")
        self.base = np.eye(4) if base is None else base
        self.q_min = Q_MIN.copy() if q_min is None else np.asarray(q_min, float).copy()
        self.q_max = Q_MAX.copy() if q_max is None else np.asarray(q_max, float).copy()
        self.qd_max = QD_MAX.copy() if qd_max is None else np.asarray(qd_max, float).copy()
        for name in ("q_min", "q_max", "qd_max"):
            if getattr(self, name).shape != (7,):
                raise ValueError(f"{name} must have 7 entries")
        if np.any(self.q_min >= self.q_max):
            raise ValueError("every joint needs q_min < q_max")
        if np.any(self.qd_max <= 0.0):
            raise ValueError("joint velocity limits must be positive")

    @property
    def base(self) -> np.ndarray:
        """Pose ``T_g0`` of the robot base in the global frame (4x4, metres); settable."""
        return self._base.copy()

    @base.setter
    def base(self, T: np.ndarray) -> None:
        self._base = _check_pose(T, "base")
        self._base_list = tuple(self._base[:3, i].tolist() for i in range(4))

    # ------------------------------------------------------------------ forward kinematics
    def _check_q(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (7,):
            raise ValueError(f"joint vector must have shape (7,), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError(f"joint vector is not finite: {q}")
        return q

    def _chain(self, q: np.ndarray) -> list[tuple[list, list, list, list]]:
        """Axes and origins ``(x, y, z, p)`` of the frames ``0..7`` in the global frame.

        Plain-float recursion of ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`` (classic DH):
        ``p_i = p_{i-1} + d_i z_{i-1} + a_i x_i``, ``x_i = c x_{i-1} + s y_{i-1}``,
        ``y_i = ca (c y_{i-1} - s x_{i-1}) + sa z_{i-1}``, ``z_i = -sa (c y_{i-1} - s x_{i-1}) + ca z_{i-1}``.
        Seven small numpy matrix products cost more than this loop.
        """
        B = self._base_list
        x, y, z, p = B
        out = [B]
        for th, d, a, ca, sa in zip(q.tolist(), self._d_list, self._a_list, self._ca_list, self._sa_list):
            c, s = math.cos(th), math.sin(th)
            x0, x1, x2 = c * x[0] + s * y[0], c * x[1] + s * y[1], c * x[2] + s * y[2]
            u0, u1, u2 = c * y[0] - s * x[0], c * y[1] - s * x[1], c * y[2] - s * x[2]
            p = [p[0] + d * z[0] + a * x0, p[1] + d * z[1] + a * x1, p[2] + d * z[2] + a * x2]
            y, z = (
                [ca * u0 + sa * z[0], ca * u1 + sa * z[1], ca * u2 + sa * z[2]],
                [ca * z[0] - sa * u0, ca * z[1] - sa * u1, ca * z[2] - sa * u2],
            )
            x = [x0, x1, x2]
            out.append((x, y, z, p))
        return out

    def fk_all(self, q) -> np.ndarray:
        """Poses of every frame of the chain in the global frame.

        Parameters
        ----------
        q : (7,) array
            Joint angles in rad.

        Returns
        -------
        (9, 4, 4) ndarray
            ``[T_g0, T_g1, ..., T_g7, T_gs]``: the base, the six DH frames after joints 1-6
            (``T_gi`` carries joint ``i+1`` on its z axis), the flange ``T_g7 = T_ge``, and the
            sensor frame.  Good for drawing the arm as a polyline through the origins.
        """
        q = self._check_q(q)
        out = np.zeros((9, 4, 4))
        out[:8, :3, :] = np.array(self._chain(q)).transpose(0, 2, 1)  # columns x, y, z, p
        out[:8, 3, 3] = 1.0
        out[8] = out[7] @ self.mount
        return out

    def fk(self, q) -> np.ndarray:
        """Pose ``T_gs`` of the sensor frame in the global frame (4x4, metres)."""
        return _homogeneous(self._chain(self._check_q(q))[7]) @ self.mount

    def fk_flange(self, q) -> np.ndarray:
        """Pose ``T_ge`` of the flange in the global frame (4x4, metres)."""
        return self.fk_all(q)[7]

    # ------------------------------------------------------------ differential kinematics
    def pose_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """``(T_gs, J)`` with ``J`` the (6, 7) spatial Jacobian, in one pass over the chain.

        Column ``i`` is the unit twist of joint ``i+1``: ``[p_i x z_i; z_i]`` where ``z_i`` and
        ``p_i`` are the axis and origin of DH frame ``i`` in the global frame.
        """
        chain = self._chain(self._check_q(q))
        cols = []
        for _, _, z, p in chain[:7]:
            cols.append((p[1] * z[2] - p[2] * z[1], p[2] * z[0] - p[0] * z[2], p[0] * z[1] - p[1] * z[0],
                         z[0], z[1], z[2]))
        J = np.array(cols).T
        return _homogeneous(chain[7]) @ self.mount, J

    def spatial_jacobian(self, q) -> np.ndarray:
        """Spatial Jacobian ``J`` (6x7): ``V_g = J(q) q_dot`` and ``tau = J(q)^T w_g``.

        Parameters
        ----------
        q : (7,) array
            Joint angles in rad.

        Returns
        -------
        (6, 7) ndarray
            Rows ``[vx, vy, vz, wx, wy, wz]`` of the spatial twist (global frame, linear part
            the velocity of the point at the global origin) per unit joint rate; m/rad and
            rad/rad.
        """
        return self.pose_and_jacobian(q)[1]

    def body_jacobian(self, q) -> np.ndarray:
        """Body Jacobian (6x7): the sensor-frame twist ``V_s = J_b(q) q_dot = Ad(T_gs^-1) J q_dot``."""
        T, J = self.pose_and_jacobian(q)
        return adjoint(invert(T)) @ J

    def hybrid_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """``(T_gs, J_h)``: ``[p_dot; w] = J_h q_dot`` with ``p`` the pad centre, global axes."""
        T, J = self.pose_and_jacobian(q)
        return T, _spatial_to_hybrid(J, T[:3, 3])

    def manipulability(self, q) -> float:
        """Yoshikawa's manipulability ``sqrt(det(J_h J_h^T))`` of the hybrid Jacobian."""
        _, Jh = self.hybrid_jacobian(q)
        return float(np.prod(np.linalg.svd(Jh, compute_uv=False)))

    def within_limits(self, q, tol: float = 0.0) -> bool:
        """True if every joint is inside ``[q_min - tol, q_max + tol]``."""
        q = np.asarray(q, float)
        return bool(np.all(q >= self.q_min - tol) and np.all(q <= self.q_max + tol))

    def clip(self, q) -> np.ndarray:
        """``q`` clipped into the joint limits."""
        return np.clip(np.asarray(q, float), self.q_min, self.q_max)

    # ------------------------------------------------------------------ resolved rate
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

        qd, lam, smin = _dls(Jh, Vh, damping, sigma_threshold, null)
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
                qd[free] = _dls(Jh[:, free], rest, damping, sigma_threshold,
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

    # ------------------------------------------------------------------ pose IK
    def ik_pose(
        self,
        T_target: np.ndarray,
        q0=None,
        q_rest=None,
        tol_pos: float = 1e-7,
        tol_rot: float = 1e-6,
        max_iter: int = 500,
        null_gain: float = 0.2,
        limit_margin: float = 5.0 * _DEG,
    ) -> np.ndarray:
        """Joint angles that put the sensor frame at ``T_target`` (iterative, damped Newton).

        The redundancy is resolved towards ``q_rest`` (default: the seed), so the posture
        found stays close to the seed's "elbow up" shape; joints are kept ``limit_margin``
        inside their limits.

        Parameters
        ----------
        T_target : (4, 4) array
            Desired ``T_gs`` (global frame, metres).
        q0 : (7,) array, optional
            Seed posture in rad; :data:`Q_READY` (elbow up, pad pointing down) if omitted.
        q_rest : (7,) array, optional
            Preferred posture for the null-space motion (default: ``q0``).
        tol_pos, tol_rot : float
            Convergence tolerances on the position (m) and orientation (rad) error.
        max_iter : int
            Iteration budget.
        null_gain : float
            Fraction of the posture error ``q_rest - q`` corrected per iteration in the null space.
        limit_margin : float
            Distance in rad kept from every joint limit.

        Returns
        -------
        (7,) ndarray
            The joint angles in rad.

        Raises
        ------
        ValueError
            If the target is not reached (out of the workspace, or blocked by joint limits);
            the message gives the remaining error.
        """
        T_target = _check_pose(T_target, "T_target")
        q = Q_READY.copy() if q0 is None else self._check_q(q0).copy()
        rest = q.copy() if q_rest is None else self._check_q(q_rest)
        lo, hi = self.q_min + limit_margin, self.q_max - limit_margin
        q = np.clip(q, lo, hi)
        err_p = err_r = np.inf
        for _ in range(max_iter):
            T, Jh = self.hybrid_jacobian(q)
            e_p = T_target[:3, 3] - T[:3, 3]
            e_r = Rotation.from_matrix(T_target[:3, :3] @ T[:3, :3].T).as_rotvec()
            err_p, err_r = float(np.linalg.norm(e_p)), float(np.linalg.norm(e_r))
            if err_p < tol_pos and err_r < tol_rot:
                return q
            e = np.concatenate((e_p, e_r))
            step_len = np.linalg.norm(e)
            if step_len > 0.1:  # stay in the region where the linearisation holds
                e *= 0.1 / step_len
            dq, _, _ = _dls(Jh, e, 1e-3, 1e-2, null_gain * (rest - q))
            biggest = np.max(np.abs(dq))
            if biggest > 0.2:
                dq *= 0.2 / biggest
            q = np.clip(q + dq, lo, hi)
        raise ValueError(
            f"ik_pose did not reach the target: position error {err_p:.3g} m, "
            f"orientation error {err_r:.3g} rad after {max_iter} iterations"
        )

    @staticmethod
    def pad_down_pose(position, yaw: float = 0.0) -> np.ndarray:
        """Sensor pose at ``position`` (m, global) with the normal ``+z_s`` pointing down (-z_g).

        ``yaw`` (rad) turns the pad about the vertical.  At 0 the pad is oriented as in
        :data:`Q_READY` (``x_s = -x_g``, ``y_s = +y_g``), so ``ik_pose`` from the default seed
        only needs small joint motions for targets in front of the robot.
        """
        R = Rotation.from_euler("z", yaw) * Rotation.from_euler("y", np.pi)
        return make_pose(R, position)


# ---------------------------------------------------------------------- helpers
def _check_pose(T, name: str) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ValueError(f"{name} must be a finite 4x4 homogeneous transform")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ValueError(f"{name} has no proper rotation in its upper-left 3x3 block")
    return T.copy()


def _spatial_to_hybrid(J: np.ndarray, p: np.ndarray) -> np.ndarray:  # noqa: D401
    """Rows ``[p_dot; w]`` from spatial rows ``[v_g; w]``: ``p_dot = v_g - p x w``."""
    Jh = J.copy()
    Jh[:3] -= skew(p) @ J[3:]
    return Jh


def _dls(J: np.ndarray, V: np.ndarray, lam_max: float, eps: float, null=None):
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
