"""The KUKA LWR 4's numbers: DH table, joint and velocity limits, ready posture, fingertip mount.

:class:`~tactile_bt.robot.kinematics.LWR4Kinematics` is built from these constants, and
:mod:`tactile_bt.robot.kinematics` re-exports all of them (see there for the frames).

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
  stretched straight up; ``tests/robot/test_arm.py`` checks it).  KUKA's data sheet rounds the
  shoulder height to 310 mm.

The classic convention is used, not the modified (Craig) one: both give the same flange pose,
they only attach the intermediate frames differently.

Layer: robot.
"""

from __future__ import annotations

import numpy as np

from tactile_bt.control.spatial import make_pose

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

    The pad (80 x 80 mm by default) is centred on the flange axis, ``offset`` metres
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

