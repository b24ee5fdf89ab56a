"""Rigid-body transforms, twists and the adjoint map (paper Eq. 4).

Conventions
-----------
* A pose is a 4x4 homogeneous matrix ``T_ab`` mapping coordinates in frame ``b`` to frame ``a``.
* A twist is ``[vx, vy, vz, wx, wy, wz]``: linear part first, in m/s and rad/s.
* A *body* twist of the sensor is expressed in the sensor frame O_s (what the servo controller
  computes); ``Ad(T_gs)`` maps it to the *spatial* twist ``V_g`` in the base frame O_g
  (paper Eq. 4), which is what resolved-rate inverse kinematics consumes.

Rotations go through :mod:`scipy.spatial.transform`; only the translational part of the
SE(3) exponential is written here.

Layer: control.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "spatial_to_point",
    "point_to_spatial",
    "make_pose",
    "invert",
    "skew",
    "adjoint",
    "body_to_spatial",
    "exp_twist",
    "integrate_spatial",
    "pad_point",
    "transform_points",
]


def make_pose(rotation: Rotation | np.ndarray | None = None, translation=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Build a 4x4 pose from a rotation (``Rotation`` or 3x3 matrix) and a translation in metres."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation.as_matrix() if isinstance(rotation, Rotation) else np.asarray(rotation, float)
    T[:3, 3] = np.asarray(translation, float)
    return T


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of a homogeneous transform, ``T_ba`` from ``T_ab``."""
    R = T[:3, :3]
    Ti = np.eye(4)
    Ti[:3, :3] = R.T
    Ti[:3, 3] = -R.T @ T[:3, 3]
    return Ti


def skew(p: np.ndarray) -> np.ndarray:
    """The 3x3 matrix ``[p]x`` with ``[p]x @ q == cross(p, q)``."""
    x, y, z = p
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def adjoint(T: np.ndarray) -> np.ndarray:
    """Adjoint of ``T = (R, p)`` for ``[v; w]`` twists: ``[[R, [p]x R], [0, R]]`` (paper Eq. 4)."""
    R = T[:3, :3]
    Ad = np.zeros((6, 6))
    Ad[:3, :3] = R
    Ad[3:, 3:] = R
    Ad[:3, 3:] = skew(T[:3, 3]) @ R
    return Ad


def body_to_spatial(T_gs: np.ndarray, twist_s: np.ndarray) -> np.ndarray:
    """Map a sensor-frame (body) twist to the base-frame (spatial) twist: ``V_g = Ad(T_gs) V_s``.

    Equivalent to ``adjoint(T_gs) @ twist_s`` without building the 6x6 matrix; it runs once per
    control cycle, so the cross product is taken on Python floats.
    """
    R = T_gs[:3, :3]
    wx, wy, wz = (R @ twist_s[3:]).tolist()
    vx, vy, vz = (R @ twist_s[:3]).tolist()
    px, py, pz = T_gs[:3, 3].tolist()
    return np.array((vx + py * wz - pz * wy, vy + pz * wx - px * wz, vz + px * wy - py * wx, wx, wy, wz))


def spatial_to_point(twist_g: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The spatial twist ``[v; w]`` (base frame) as the velocity of ``point`` (base frame, m) and
    the angular velocity: ``[v + w x point; w]``, the form a Cartesian twist controller (MoveIt
    Servo, a twist controller) takes for its end-effector frame whose origin is ``point``."""
    v, w = np.asarray(twist_g[:3], dtype=float), np.asarray(twist_g[3:], dtype=float)
    return np.concatenate([v + np.cross(w, point), w])


def point_to_spatial(twist_point: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The inverse of :func:`spatial_to_point`: ``[v_point - w x point; w]``."""
    v, w = np.asarray(twist_point[:3], dtype=float), np.asarray(twist_point[3:], dtype=float)
    return np.concatenate([v - np.cross(w, point), w])


def exp_twist(twist: np.ndarray, dt: float) -> np.ndarray:
    """SE(3) exponential ``exp([twist] dt)`` as a 4x4 matrix.

    Parameters
    ----------
    twist : (6,) array
        ``[v; w]`` in m/s and rad/s.
    dt : float
        Duration in seconds.

    Notes
    -----
    This runs once per control cycle, so it is the closed-form Rodrigues formula on Python
    floats rather than ``Rotation.from_rotvec(...).as_matrix()`` (about 10x the cost for one
    vector); ``tests/control/test_spatial.py`` checks both agree.
    """
    vx, vy, vz, wx, wy, wz = (float(c) * dt for c in twist)
    theta2 = wx * wx + wy * wy + wz * wz
    if theta2 < 1e-24:
        return np.array(((1.0, 0.0, 0.0, vx), (0.0, 1.0, 0.0, vy), (0.0, 0.0, 1.0, vz), (0.0, 0.0, 0.0, 1.0)))
    theta = math.sqrt(theta2)
    s, c = math.sin(theta), math.cos(theta)
    a, b = s / theta, (1.0 - c) / theta2  # R = I + a W + b W²
    d = (theta - s) / (theta2 * theta)  # V = I + b W + d W²
    # W² = w wᵀ − θ² I
    xx, yy, zz, xy, xz, yz = wx * wx, wy * wy, wz * wz, wx * wy, wx * wz, wy * wz
    R = (
        (1.0 - b * (yy + zz), -a * wz + b * xy, a * wy + b * xz),
        (a * wz + b * xy, 1.0 - b * (xx + zz), -a * wx + b * yz),
        (-a * wy + b * xz, a * wx + b * yz, 1.0 - b * (xx + yy)),
    )
    V = (
        (1.0 - d * (yy + zz), -b * wz + d * xy, b * wy + d * xz),
        (b * wz + d * xy, 1.0 - d * (xx + zz), -b * wx + d * yz),
        (-b * wy + d * xz, b * wx + d * yz, 1.0 - d * (xx + yy)),
    )
    t = [V[i][0] * vx + V[i][1] * vy + V[i][2] * vz for i in range(3)]
    return np.array((
        (R[0][0], R[0][1], R[0][2], t[0]),
        (R[1][0], R[1][1], R[1][2], t[1]),
        (R[2][0], R[2][1], R[2][2], t[2]),
        (0.0, 0.0, 0.0, 1.0),
    ))


def integrate_spatial(T: np.ndarray, twist_g: np.ndarray, dt: float) -> np.ndarray:
    """Move pose ``T`` (base frame) by the spatial twist ``twist_g`` for ``dt`` seconds."""
    return exp_twist(twist_g, dt) @ T


def pad_point(T: np.ndarray, x: float, y: float) -> np.ndarray:
    """World position (m) of the point ``(x, y)`` (m) in the plane of the pad whose pose is ``T``
    (sensor frame, e.g. a centre of pressure)."""
    return T[:3, 0] * x + T[:3, 1] * y + T[:3, 3]


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply ``T`` to an ``(N, 3)`` array of points."""
    return points @ T[:3, :3].T + T[:3, 3]
