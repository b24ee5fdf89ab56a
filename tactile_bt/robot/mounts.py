"""What carries the pad: an ideal Cartesian mount, or the compliant KUKA LWR 4 of the paper.

Scene section ``mount:``

=============  ========================================  =====================================
field          meaning                                   default
=============  ========================================  =====================================
``type``       ``cartesian`` (ideal) or ``lwr4`` (arm)    ``cartesian``
``position``   start position of the pad centre (m)       ``[0, 0, 0.05]``
``rpy_deg``    start orientation, extrinsic x-y-z (deg);  ``[180, 0, 0]``
               ``[180, 0, yaw]`` points the pad down
``base``       lwr4: arm base position (m); by default    start position minus the pad's
               placed so the start is the arm's ready      offset in the ready posture
               posture
``stiffness``  lwr4: joint stiffness (N m/rad)            200 (paper Sec. V)
``damping``    lwr4: joint damping (N m s/rad)            0.2 (paper Sec. V)
=============  ========================================  =====================================

Both satisfy the :class:`~tactile_bt.robot.interface.Robot` protocol (``pad_pose``,
``send_twist``, ``stop``, ``joint_state``; ``step(dt)`` moves by the twist sent), so a mission
loop drives them as it drives a real arm.

The ideal mount follows the commanded twist exactly. The arm turns it into joint velocities by
damped resolved rates; they move its equilibrium posture, and contact forces deflect it
through the joint stiffness (:class:`tactile_bt.robot.arm.CompliantArm`). Its seventh joint
keeps the others off their limits (:mod:`tactile_bt.robot.redundancy`); what the last step
could not do (joints held on a limit, the unrealised twist) is :meth:`ArmMount.saturation`,
which the mission logs every cycle and reports.

Layer: robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.errors import MountError
from tactile_bt.control.spatial import integrate_spatial, make_pose
from tactile_bt.robot.interface import JointState, SimulatedRobot
from tactile_bt.sense.geometry import PadGeometry

__all__ = ["MountSpec", "CartesianMount", "ArmMount", "MountError", "MOUNT_TYPES"]

#: The pad normal lies along joint 7's axis when their directions' cosine is at least this (10°).
_ALONG_COS = 0.985

MOUNT_TYPES = ("cartesian", "lwr4")

class CartesianMount(SimulatedRobot):
    """An ideal Cartesian mount: the pad follows the commanded base-frame twist exactly.

    Parameters
    ----------
    pose : (4, 4) array
        Initial ``T_gs`` (sensor frame in the base frame).
    """

    def __init__(self, pose: np.ndarray) -> None:
        self.pose = np.array(pose, dtype=float)

    def attach(self, contact) -> None:
        """An ideal mount feels no contact force."""

    def move(self, twist_g: np.ndarray, dt: float) -> None:
        """Integrate the spatial twist ``twist_g`` ([v; ω], m/s, rad/s) for ``dt`` seconds."""
        self.pose = integrate_spatial(self.pose, twist_g, dt)


class ArmMount(SimulatedRobot):
    """The pad on a compliant KUKA LWR 4: same interface as :class:`CartesianMount`.

    Parameters
    ----------
    pose : (4, 4) array
        Start pose ``T_gs`` of the pad; the arm is put there by inverse kinematics.
    base : (3,) array or None
        Arm base position in the world (m); None places it so that ``pose`` is reached from
        the ready posture.
    stiffness, damping : float
        Joint stiffness (N m/rad) and damping (N m s/rad).
    pad : PadGeometry, optional
        The pad on the flange (its half diagonal bounds the arm's equilibrium steps); default
        ``PadGeometry()``.
    """

    def __init__(self, pose: np.ndarray, base=None, stiffness: float = defaults.ARM_STIFFNESS_NM_PER_RAD,
                 damping: float = defaults.ARM_DAMPING_NMS_PER_RAD,
                 pad: PadGeometry | None = None) -> None:
        from tactile_bt.robot.arm import CompliantArm
        from tactile_bt.robot.kinematics import Q_READY, LWR4Kinematics

        kin = LWR4Kinematics()
        if base is None:
            base = np.asarray(pose[:3, 3]) - kin.fk(Q_READY)[:3, 3]
        kin.base = make_pose(None, base)
        try:
            q0 = kin.ik_pose(np.asarray(pose, dtype=float), q0=Q_READY)
        except ValueError as exc:
            raise MountError(f"mount: the arm cannot reach the start pose: {exc}") from None
        # tol: joint-torque residual of the contact solve, 1e-3 N m ≈ a few µm at the pad.
        self.arm = CompliantArm(kin, q0=q0, stiffness=stiffness, damping=damping, tol=1e-3,
                                pad_radius=(pad if pad is not None else PadGeometry()).half_diagonal_m)
        # joint 7 turns the flange about its z: the pad about its normal when that lies along it
        along = float(kin.fk_flange(q0)[:3, 2] @ kin.fk(q0)[:3, 2])
        self._turn_sign = int(np.sign(along)) if abs(along) > _ALONG_COS else 0
        self._q7_range = (float(kin.q_min[6]), float(kin.q_max[6]))  # read every cycle: no copies

    @property
    def pose(self) -> np.ndarray:
        """Actual ``T_gs`` (deflected by contact forces)."""
        return self.arm.pose

    @property
    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q_min, q_max)``: the arm's joint limits (rad)."""
        return self.arm.kin.q_min.copy(), self.arm.kin.q_max.copy()

    def joint_angles(self) -> np.ndarray:
        """Actual joint angles (rad), logged by the mission as ``joints_rad``."""
        return self.arm.q.copy()

    def saturation(self) -> tuple[np.ndarray, np.ndarray]:
        """What the last :meth:`move` could not do, logged by the mission every cycle.

        Returns
        -------
        saturated : (7,) bool ndarray
            Joints the resolved-rate solve held on a position limit (all False before a move).
        residual : (6,) ndarray
            Commanded minus realised hybrid twist of the pad centre (m/s, rad/s, global
            frame; :attr:`tactile_bt.robot.resolved_rate.RateSolution.residual`).
        """
        sol = self.arm.last_rate
        if sol is None:
            return np.zeros(7, dtype=bool), np.zeros(6)
        return sol.saturated.copy(), sol.residual.copy()

    def turn_room(self) -> tuple[int, float, float] | None:
        """How far (rad) the pad can still turn about its normal each way before joint 7, whose
        axis is the flange's (and so the pad normal's, the pad being mounted flat on the flange),
        reaches a limit: ``(7, about +z, about -z)``; None where the pad normal does not lie along
        that axis."""
        if self._turn_sign == 0:
            return None
        q, (q_min, q_max) = float(self.arm.q[6]), self._q7_range
        up, down = max(q_max - q, 0.0), max(q - q_min, 0.0)
        return (7, up, down) if self._turn_sign > 0 else (7, down, up)

    def joint_state(self) -> JointState:
        """Joint angles, limits and the joints the last :meth:`move` held on a limit, stamped
        with the mount's clock (the :class:`~tactile_bt.robot.interface.Robot` protocol)."""
        q_min, q_max = self.limits
        return JointState(self.joint_angles(), q_min, q_max, self._clock_s, self.saturation()[0])

    def attach(self, contact) -> None:
        """Let ``contact(T_gs) -> (wrench_g, K_x)`` deflect the arm."""
        self.arm.contact = contact

    def move(self, twist_g: np.ndarray, dt: float) -> None:
        """Resolved rates for ``twist_g``, then one compliant step of ``dt`` seconds."""
        self.arm.move(twist_g, dt)


@dataclass
class MountSpec:
    """A validated ``mount:`` section; :meth:`build` makes a fresh mount for each world."""

    type: str = "cartesian"
    position: tuple = (0.0, 0.0, 0.05)
    rpy_deg: tuple = (180.0, 0.0, 0.0)
    base: tuple | None = None
    stiffness: float = defaults.ARM_STIFFNESS_NM_PER_RAD
    damping: float = defaults.ARM_DAMPING_NMS_PER_RAD
    pose: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        if self.type not in MOUNT_TYPES:
            raise ValueError(f"mount.type: unknown mount {self.type!r}; valid: {', '.join(MOUNT_TYPES)}")
        self.pose = make_pose(Rotation.from_euler("xyz", self.rpy_deg, degrees=True), self.position)

    def build(self, pad: PadGeometry | None = None):
        """A fresh mount at the start pose, carrying ``pad`` (the scene's pad geometry; default
        ``PadGeometry()``).

        Raises
        ------
        MountError
            When the arm cannot reach the start pose; the message gives the pose, the base and
            the fields to change.
        """
        if self.type == "lwr4":
            try:
                return ArmMount(self.pose, self.base, self.stiffness, self.damping, pad)
            except MountError as exc:
                raise self._unreachable(exc) from None
        return CartesianMount(self.pose)

    def _unreachable(self, exc: MountError) -> MountError:
        from tactile_bt.robot.kinematics import Q_READY, LWR4Kinematics

        base = np.asarray(self.pose[:3, 3]) - LWR4Kinematics().fk(Q_READY)[:3, 3] if self.base is None else self.base
        reason = str(exc).split(": ", 2)[-1]
        where_ = (f"the arm cannot reach the start pose (mount.position {_fmt(self.position)} m, "
                  f"mount.rpy_deg {_fmt(self.rpy_deg)}) from its base at {_fmt(base)} m, "
                  f"{np.linalg.norm(np.subtract(self.position, base)):.3g} m away ({reason})")
        if self.base is not None:
            return MountError(f"mount.base: {where_}; move mount.base within reach of mount.position, or leave "
                              f"mount.base out to place the arm so that the start pose is its ready posture",
                              "base")
        return MountError(f"mount.rpy_deg: {where_}; change mount.rpy_deg ([180, 0, yaw] points the pad down)",
                          "rpy_deg")


def _fmt(v) -> str:
    return "[" + ", ".join(f"{float(x):.4g}" for x in v) + "]"
