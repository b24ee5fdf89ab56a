"""Kinematics of the 7-DOF KUKA LWR 4 with a tactile pad as fingertip.

Frames
------
* ``g``  -- the global (world) frame.  The arm's base frame ``0`` sits at ``T_g0`` (``base``,
  identity by default, so that ``g`` *is* the base frame unless a scene moves the robot).
* ``0..7`` -- the classic (distal, "standard") Denavit-Hartenberg frames; joint ``i`` (1-based)
  turns about ``z_{i-1}``.  Frame ``7`` is the flange ``e``.
* ``s``  -- the sensor frame O_s of docs/architecture.md (origin at the pad centre, ``+z_s`` the sensing
  normal pointing at the object), ``T_es`` (``mount``) from the flange.

``fk(q)`` returns ``T_gs = T_g0 . T_07(q) . T_es``.

Twists and wrenches
-------------------
Twists are ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s).  The *spatial* twist ``V_g`` of the sensor
is ``[v_g; w]`` with ``v_g = p_dot + p x w`` (the velocity of the body point passing through the
origin of ``g``), so that ``V_g = Ad(T_gs) V_s`` and ``d/dt T_gs = [V_g] T_gs``.  The spatial
Jacobian gives ``V_g = J(q) q_dot``; its dual wrench ``[f; tau_O]`` (N, N m, torque about the
origin of ``g``) maps to joint torques by ``tau = J(q)^T w``.

Where the rest lives
--------------------
The DH table (with its sources), the joint and velocity limits, the ready posture and the
default fingertip mount are :mod:`tactile_bt.robot.lwr4_params`; resolved-rate motion
(:meth:`LWR4Kinematics.resolved_rate`: damped least squares with joint-limit saturation in the
null space) is :mod:`tactile_bt.robot.resolved_rate`.  This module re-exports their names; it
holds the forward and differential kinematics and the pose IK :meth:`LWR4Kinematics.ik_pose`.

Layer: robot.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import adjoint, invert, make_pose, skew
from tactile_bt.robot.lwr4_params import (
    DEFAULT_MOUNT_OFFSET_M,
    DH_A,
    DH_ALPHA,
    DH_D,
    Q_MAX,
    Q_MIN,
    Q_READY,
    QD_MAX,
    default_mount,
)
from tactile_bt.robot.kernels import pack_kinematics
from tactile_bt.robot.resolved_rate import RateSolution, ResolvedRateMixin, damped_least_squares

__all__ = [
    "DH_D",
    "DH_A",
    "DH_ALPHA",
    "Q_MIN",
    "Q_MAX",
    "QD_MAX",
    "Q_READY",
    "DEFAULT_MOUNT_OFFSET_M",
    "default_mount",
    "RateSolution",
    "LWR4Kinematics",
]


def _homogeneous(frame) -> np.ndarray:
    """4x4 matrix from a chain frame ``(x, y, z, p)`` (axis and origin lists, global frame)."""
    x, y, z, p = frame
    return np.array([x + [0.0], y + [0.0], z + [0.0], p + [1.0]]).T


class LWR4Kinematics(ResolvedRateMixin):
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
        self._packed = None

    @property
    def packed(self) -> np.ndarray:
        """The model as the compiled kernels read it (:func:`tactile_bt.robot.kernels.pack_kinematics`),
        made at the first use and again when :attr:`base` is set; the DH table, mount and limits
        are read once (change them by making a new model)."""
        if self._packed is None:
            self._packed = pack_kinematics(self.d, self.a, self.alpha, self._base, self.mount, self.q_min,
                                           self.q_max, self.qd_max)
        return self._packed

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
        limit_margin: float = float(np.deg2rad(5.0)),
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
            dq, _, _ = damped_least_squares(Jh, e, 1e-3, 1e-2, null_gain * (rest - q))
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
