"""The KUKA LWR 4 in joint-space compliance mode, carrying the tactile pad (paper Sec. V).

The paper runs the arm "in joint-space compliance mode using a stiffness parameter of
200 Nm/rad and a damping parameter of 0.2 Nm s/rad"; "the control basis framework maps
Cartesian-space twists into joint-angle velocities, thus changing the equilibrium posture of the
robot controller".  :class:`CompliantArm` models exactly that: the servo twist is turned into
joint velocities (:meth:`LWR4Kinematics.resolved_rate`) that integrate the *equilibrium* posture
``q_eq``, and the *actual* posture ``q`` obeys the joint impedance law

    tau = K (q_eq - q) - D q_dot + J(q)^T w_ext = M(q) q_ddot,

with ``w_ext`` the contact wrench ``[f; tau_O]`` in the global frame, torque about the global
origin (the dual of the spatial twist: power ``= w . V_g``).

Two ways to integrate it
------------------------
``mode="quasi_static"`` (default).  The link inertias of the real arm are unknown and contact
stiffnesses reach 1e7 N/m, so the inertia is neglected: each step solves the *implicit Euler*
step of the massless spring-damper,

    K (q - q_eq) + (D / dt) (q - q_prev) - J(q)^T w(T_gs(q)) = 0,

a nonlinear equation in ``q`` that is solved by a safeguarded Newton iteration (below).  With
``D = 0`` this is the static equilibrium ``q = q_eq + K^-1 J^T w`` (:meth:`CompliantArm.settle`).
Implicit Euler of a first-order system is unconditionally stable, whatever the contact stiffness
and the step.

``mode="dynamic"``.  Linearly implicit Euler of the second-order law with a diagonal joint-space
inertia ``M`` (a rough guess by default, see :data:`DEFAULT_INERTIA`), the contact stiffness
included in the implicit matrix.  Useful to study oscillations; note that with the paper's
``D = 0.2 Nm s/rad`` the joints are almost undamped.  (KUKA's FRI specifies the joint damping as
a dimensionless damping ratio; we take the paper's numbers at face value.)

Equilibrium solver
------------------
The implicit step and :meth:`CompliantArm.settle` are solved by a safeguarded quasi-Newton
iteration on the combined arm and contact stiffness, stable from 1e2 to 1e7 N/m; it lives in
:mod:`tactile_bt.robot.equilibrium` (with :data:`WrenchFn`, :class:`SettleResult`,
:func:`point_wrench` and :func:`bracket_stiffness`, which this module re-exports) and is
described there.

Compiled step
-------------
When the contact model offers a compiled kernel (:class:`~tactile_bt.robot.stepping.CompiledContact`;
the simulated pad does, :class:`tactile_bt.sim.pad.PadContact`), :meth:`CompliantArm.move` and
the quasi-static :meth:`CompliantArm.step` run in compiled kernels
(:mod:`tactile_bt.robot.kernels`, driven by :class:`~tactile_bt.robot.stepping.ArmStepper`):
resolved rates, then the equilibrium posture's motion and the contact equilibrium, which
alternates with the contact model's own kernel.  The rare steps it hands back (a joint that
saturates, a step that needs the bracketing line search) are finished by the Python solvers
described here, from the same state.  Any other contact model (a Python callable) uses the
Python solvers throughout.

Redundancy
----------
The seventh joint is used: :meth:`CompliantArm.joint_velocities` adds the null-space motion of
:class:`~tactile_bt.robot.redundancy.LimitAvoidance` (joints away from their limits, the wrist
away from its singularity, without disturbing the pad twist), and keeps the diagnostics of the
solve (:attr:`CompliantArm.last_rate`: which joints it held on a limit, what it could not do).

Layer: robot.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_bt import defaults
from tactile_bt.robot.equilibrium import (
    EquilibriumSolverMixin,
    SettleResult,
    WrenchFn,
    WrenchSource,
    bracket_stiffness,
    point_wrench,
)
from tactile_bt.robot import kernels
from tactile_bt.robot.kinematics import LWR4Kinematics, Q_READY, RateSolution
from tactile_bt.robot.stepping import HOLD, JOINT_VELOCITIES, RATES, ArmStepper, CompiledContact
from tactile_bt.robot.redundancy import LimitAvoidance
from tactile_bt.sense.geometry import PadGeometry

__all__ = [
    "DEFAULT_STIFFNESS",
    "DEFAULT_DAMPING",
    "DEFAULT_INERTIA",
    "WrenchFn",
    "SettleResult",
    "CompliantArm",
    "point_wrench",
    "bracket_stiffness",
]

#: Joint stiffness of the compliance mode in N m/rad (paper Sec. V).
DEFAULT_STIFFNESS = defaults.ARM_STIFFNESS_NM_PER_RAD
#: Joint damping of the compliance mode in N m s/rad (paper Sec. V).
DEFAULT_DAMPING = defaults.ARM_DAMPING_NMS_PER_RAD
#: Diagonal joint-space inertia in kg m^2 for ``mode="dynamic"``: a rough guess of the link-side
#: inertia of the LWR in a bent posture (no published value); the quasi-static mode ignores it.
DEFAULT_INERTIA = np.array([1.0, 1.0, 0.3, 0.3, 0.05, 0.05, 0.01])


class CompliantArm(EquilibriumSolverMixin):
    """KUKA LWR 4 under joint impedance control, with the tactile pad as fingertip.

    Parameters
    ----------
    kinematics : LWR4Kinematics, optional
        Kinematic model (default mount, base at the global origin if omitted).
    q0 : (7,) array, optional
        Initial posture in rad, both equilibrium and actual (default :data:`Q_READY`).
    stiffness, damping : float or (7,) array
        Joint stiffness ``K`` (N m/rad) and damping ``D`` (N m s/rad); paper: 200 and 0.2.
    mode : {"quasi_static", "dynamic"}
        How :meth:`step` integrates the compliance (module docstring).
    inertia : (7,) array, optional
        Diagonal joint inertia in kg m^2 for ``mode="dynamic"`` (:data:`DEFAULT_INERTIA`).
    redundancy : LimitAvoidance or None
        Null-space objective of the resolved-rate motion (default ``LimitAvoidance()``: joint
        limits and wrist singularity, :mod:`tactile_bt.robot.redundancy`); ``None``: the
        minimum-norm solution, no null-space motion.
    ik_damping, sigma_threshold : float
        Damped-least-squares parameters of :meth:`LWR4Kinematics.resolved_rate` (m/rad).
    max_step_m : float
        Largest motion of any point of the pad per Newton iteration of the equilibrium solver (m).
    tol : float
        Joint-torque residual (N m) at which the equilibrium solver stops.
    max_iter : int
        Newton iteration budget per step.
    pad_radius : float, optional
        Distance from the pad centre to its farthest point (m), for the per-iteration motion
        cap: the half diagonal of the pad the world puts on the arm (default: that of the
        default :class:`~tactile_bt.sense.geometry.PadGeometry`, 16 x 16 at 5 mm).
    """

    def __init__(
        self,
        kinematics: LWR4Kinematics | None = None,
        q0=None,
        stiffness=DEFAULT_STIFFNESS,
        damping=DEFAULT_DAMPING,
        mode: str = "quasi_static",
        inertia=None,
        redundancy: LimitAvoidance | None = LimitAvoidance(),
        ik_damping: float = 0.05,
        sigma_threshold: float = 0.05,
        max_step_m: float = 1e-3,
        tol: float = 1e-4,
        max_iter: int = 60,
        pad_radius: float | None = None,
    ) -> None:
        self.kin = LWR4Kinematics() if kinematics is None else kinematics
        self.K = _per_joint(stiffness, "stiffness", positive=True)
        self.D = _per_joint(damping, "damping", positive=False)
        self.M = _per_joint(DEFAULT_INERTIA if inertia is None else inertia, "inertia", positive=True)
        if mode not in ("quasi_static", "dynamic"):
            raise ValueError(f"mode must be 'quasi_static' or 'dynamic', got {mode!r}")
        self.mode = mode
        if redundancy is not None and not isinstance(redundancy, LimitAvoidance):
            raise TypeError(f"redundancy must be a LimitAvoidance or None, got {type(redundancy).__name__}")
        self.redundancy = redundancy
        self.ik_damping = float(ik_damping)
        self.sigma_threshold = float(sigma_threshold)
        self.max_step_m = float(max_step_m)
        self.tol = float(tol)
        self.max_iter = int(max_iter)
        #: Steps (m, rad) of the finite-difference contact stiffness, used when the contact
        #: model does not return ``K_x``.  Small, so that the difference rarely straddles a kink
        #: of a penalty contact (at 1e7 N/m a few newtons are a fraction of a micrometre).
        self.fd_step = (1e-8, 1e-8)
        #: Half diagonal of the pad (m), for the per-iteration motion cap.
        self.pad_radius = PadGeometry().half_diagonal_m if pad_radius is None else float(pad_radius)
        if not (np.isfinite(self.pad_radius) and self.pad_radius > 0):
            raise ValueError(f"pad_radius must be a finite length > 0 m, got {pad_radius!r}")
        self._H: np.ndarray | None = None  # quasi-Newton matrix carried between solves
        self._H_Kd = np.zeros(7)
        self._kin_cache: tuple | None = None
        self._stepper = ArmStepper()  # the compiled step's packed arrays
        #: Default contact model of :meth:`step` and :meth:`move` (a :data:`WrenchFn`), e.g. set
        #: by the world to the pad-object contact; ``None``: no contact.
        self.contact: WrenchFn | None = None
        self.reset(Q_READY if q0 is None else q0)

    # ------------------------------------------------------------------ state
    def reset(self, q0) -> None:
        """Put the arm at rest at posture ``q0`` (rad, clipped into the limits), unloaded."""
        q0 = self.kin.clip(self.kin._check_q(q0))
        self.q_eq = q0.copy()
        self.q = q0.copy()
        self.q_dot = np.zeros(7)
        #: Diagnostics of the last :meth:`joint_velocities` solve (None before the first).
        self.last_rate: RateSolution | None = None
        self.wrench_g = np.zeros(6)
        self.last_solve: SettleResult | None = None
        self._H = None
        self._kin_cache = None
        self._T = self.kin.fk(self.q)

    @property
    def T_gs(self) -> np.ndarray:
        """Actual sensor pose (4x4, global frame): what forward kinematics of the measured joints gives."""
        return self._T.copy()

    @property
    def pose(self) -> np.ndarray:
        """Alias of :attr:`T_gs` (the interface of the ideal ``CartesianMount``)."""
        return self._T.copy()

    @property
    def T_gs_eq(self) -> np.ndarray:
        """Sensor pose of the equilibrium posture (where the pad would be without contact)."""
        return self.kin.fk(self.q_eq)

    @property
    def joint_torque(self) -> np.ndarray:
        """Spring torque ``K (q_eq - q)`` in N m (what the joint torque sensors would read, minus damping)."""
        return self.K * (self.q_eq - self.q)

    # ------------------------------------------------------------------ commands
    def joint_velocities(self, twist_g, dt: float | None = None) -> np.ndarray:
        """Resolved-rate joint velocities (rad/s) for a spatial sensor twist, at the equilibrium posture.

        Parameters
        ----------
        twist_g : (6,) array
            ``V_g = Ad(T_gs) V_s`` (m/s, rad/s).
        dt : float, optional
            Step length (s) for the joint-limit check.

        The null-space motion of :attr:`redundancy` is added; the solve's diagnostics are kept
        in :attr:`last_rate`.
        """
        kin, avoid = self.kin, self.redundancy
        null = None if avoid is None else avoid.q_dot(self.q_eq, kin.q_min, kin.q_max)
        sol = kin.resolved_rate(
            self.q_eq, twist_g, dt=dt, damping=self.ik_damping,
            sigma_threshold=self.sigma_threshold, q_dot_null=null,
            null_speed_max=None if avoid is None else avoid.speed_max, return_info=True,
        )
        self.last_rate = sol
        return sol.q_dot

    def move(self, twist_g, dt: float, wrench_fn: WrenchFn | None = None, wrench_g=None) -> np.ndarray:
        """Follow a spatial twist for ``dt`` s: :meth:`joint_velocities` then :meth:`step`.

        Same call as the ideal ``CartesianMount.move(twist_g, dt)`` of :mod:`tactile_bt.sim.world`,
        so the arm can stand in for it (with :attr:`contact` set, contact forces deflect it).

        Returns
        -------
        (4, 4) ndarray
            The new actual sensor pose ``T_gs``.
        """
        compiled = self._compiled_contact(wrench_fn, wrench_g)
        if compiled is not None:
            V = np.asarray(twist_g, dtype=float)
            if V.shape != (6,) or not math.isfinite(float(V @ V)):
                raise ValueError(f"twist_g must be 6 finite numbers, got {twist_g!r}")
            _check_dt(dt)
            if self._compiled_step(compiled, dt, twist=V):
                return self.T_gs
        return self.step(dt, self.joint_velocities(twist_g, dt), wrench_g=wrench_g, wrench_fn=wrench_fn)

    def step(self, dt: float, q_dot_cmd=None, wrench_g=None, wrench_fn: WrenchFn | None = None) -> np.ndarray:
        """Advance the arm by ``dt`` seconds.

        Parameters
        ----------
        dt : float
            Step in s (> 0).
        q_dot_cmd : (7,) array, optional
            Commanded joint velocities (rad/s) that move the equilibrium posture; clipped so
            ``q_eq`` stays inside the joint limits.  ``None``: hold.
        wrench_g : (6,) array, optional
            Constant external wrench ``[f; tau_O]`` (N, N m about the global origin).
        wrench_fn : callable, optional
            Contact model ``T_gs -> wrench`` or ``(wrench, K_x)`` (see :data:`WrenchFn`),
            evaluated at the *new* pose (implicit); :attr:`contact` if omitted.  Added to
            ``wrench_g`` if both are given.

        Returns
        -------
        (4, 4) ndarray
            The new actual sensor pose ``T_gs``.
        """
        _check_dt(dt)
        qd = None
        if q_dot_cmd is not None:
            qd = np.asarray(q_dot_cmd, float)
            if qd.shape != (7,) or not np.all(np.isfinite(qd)):
                raise ValueError(f"q_dot_cmd must be 7 finite numbers, got {q_dot_cmd!r}")
        compiled = self._compiled_contact(wrench_fn, wrench_g)
        if compiled is not None:
            self._compiled_step(compiled, dt, q_dot=qd)
            return self.T_gs
        if qd is not None:
            self.q_eq = self.kin.clip(self.q_eq + dt * qd)
        src = WrenchSource(self.contact if wrench_fn is None else wrench_fn, wrench_g)
        q_prev = self.q.copy()
        if self.mode == "quasi_static":
            res = self._solve(src, self.q_eq, q_prev, self.D / dt, q_prev, self.tol, self.max_iter)
        else:
            res = self._dynamic_step(src, dt)
        self._accept(res)
        self.q_dot = (self.q - q_prev) / dt
        return self.T_gs

    def settle(
        self,
        q_eq=None,
        wrench_fn: WrenchFn | None = None,
        tol: float | None = None,
        max_iter: int | None = None,
        q0=None,
        wrench_g=None,
        update_state: bool = True,
    ) -> SettleResult:
        """Static equilibrium ``K (q - q_eq) = J(q)^T w(T_gs(q))`` under a contact model.

        Stable for any contact stiffness (tested 1e2 to 1e7 N/m): safeguarded Newton on the
        combined arm + contact stiffness (:mod:`tactile_bt.robot.equilibrium`).

        Parameters
        ----------
        q_eq : (7,) array, optional
            Equilibrium posture in rad (default: the arm's).
        wrench_fn : callable, optional
            Contact model, see :data:`WrenchFn` (default :attr:`contact`; both ``None``: unloaded).
        tol : float, optional
            Joint-torque residual in N m (default: the arm's ``tol``).
        max_iter : int, optional
            Newton iteration budget (default: 200, enough to push a pad that starts 5 cm
            deep in a rigid object back out in 1 mm steps).
        q0 : (7,) array, optional
            Initial guess (default: the current actual posture, a warm start).
        wrench_g : (6,) array, optional
            Extra constant wrench (N, N m about the global origin).
        update_state : bool
            Store the result as the arm's actual posture (and ``q_eq``).

        Returns
        -------
        SettleResult
        """
        q_eq = self.q_eq.copy() if q_eq is None else self.kin.clip(self.kin._check_q(q_eq))
        start = self.q.copy() if q0 is None else self.kin._check_q(q0).copy()
        src = WrenchSource(self.contact if wrench_fn is None else wrench_fn, wrench_g)
        res = self._solve(src, q_eq, start, np.zeros(7), start,
                          self.tol if tol is None else float(tol),
                          200 if max_iter is None else int(max_iter))
        if update_state:
            self.q_eq = q_eq
            self._accept(res)
            self.q_dot = np.zeros(7)
        return res

    # ------------------------------------------------------------------ internals
    def _compiled_contact(self, wrench_fn, wrench_g) -> CompiledContact | None:
        """The contact model whose kernel the compiled step alternates with, or None (Python solvers)."""
        if wrench_g is not None or self.mode != "quasi_static":
            return None
        contact = self.contact if wrench_fn is None else wrench_fn
        return contact if hasattr(contact, "contact_kernel") else None

    def _compiled_step(self, contact: CompiledContact, dt: float, twist=None, q_dot=None) -> bool:
        """One quasi-static step in the compiled kernels (module docstring).

        With ``twist``: resolved rates too; False when they need the Python saturation loop
        (nothing was changed).  With ``q_dot`` (or neither: hold): always True.  A step whose
        equilibrium the kernel hands back is finished by the Python solver.
        """
        stepper = self._stepper
        stepper.set_arm(self.K, self.D, self.redundancy)
        mode = RATES if twist is not None else JOINT_VELOCITIES if q_dot is not None else HOLD
        stepper.load(self.q_eq, self.q, dt, mode, twist if twist is not None else q_dot,
                     ik_damping=self.ik_damping, sigma_threshold=self.sigma_threshold, max_step=self.max_step_m,
                     tol=self.tol, max_iter=self.max_iter, pad_radius=self.pad_radius)
        kin = self.kin.packed
        if mode == RATES and not stepper.rates(kin):
            return False  # (the Python solve's saturation loop)
        status = stepper.run(contact, kin)
        if mode == RATES:
            self.last_rate = stepper.rate_solution()
        q_prev = self.q
        self.q_eq = stepper.q_eq()
        if status == kernels.STATUS_NONFINITE:
            raise FloatingPointError(f"the contact model returned a non-finite wrench near T_gs=\n{self._T}")
        if status == kernels.STATUS_NEWTON:
            res = self._solve(WrenchSource(contact, None), self.q_eq, q_prev, self.D / dt, q_prev, self.tol,
                              self.max_iter)
            self._accept(res)
            self.q_dot = (self.q - q_prev) / dt
            return True
        q, q_dot = stepper.state()
        T, J = stepper.pose_jacobian()
        wrench, residual, iterations, evaluations, converged = stepper.solve()
        res = SettleResult(q, T, wrench, residual, iterations, evaluations, converged)
        self.q, self._T, self.wrench_g, self.last_solve = q, T.copy(), res.wrench_g, res
        self._kin_cache = (q.copy(), self._T, J)
        self.q_dot = q_dot
        return True

    def _accept(self, res: SettleResult) -> None:
        self.q = res.q
        self._T = res.T_gs
        self.wrench_g = res.wrench_g
        self.last_solve = res

    def _dynamic_step(self, src: WrenchSource, dt: float) -> SettleResult:
        """Linearly implicit Euler of ``M q_ddot = K (q_eq - q) - D q_dot + J^T w``."""
        q, qd = self.q, self.q_dot
        T, J = self.kin.pose_and_jacobian(q)
        w, Kx = src(T)
        if Kx is None:
            Kx = self._fd_stiffness(src, T, w)
        H = np.diag(self.K) - bracket_stiffness(J, w) + J.T @ Kx @ J
        A = np.diag(self.M + dt * self.D) + dt * dt * H
        b = self.M * qd + dt * (self.K * (self.q_eq - q) + J.T @ w)
        try:
            qd_new = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            qd_new = np.linalg.lstsq(A, b, rcond=None)[0]
        if not np.all(np.isfinite(qd_new)):
            qd_new = np.zeros(7)
        q_new = q + dt * qd_new
        T_new, J_new = self.kin.pose_and_jacobian(q_new)
        w_new, _ = src(T_new)
        r = self.K * (q_new - self.q_eq) - J_new.T @ w_new
        return SettleResult(q_new, T_new, w_new, float(np.max(np.abs(r))), 1, src.calls, True)


def _check_dt(dt) -> None:
    if not (np.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")


def _per_joint(value, name: str, positive: bool) -> np.ndarray:
    """A scalar or 7 values as a (7,) array, validated."""
    arr = np.broadcast_to(np.asarray(value, float), (7,)).copy()
    bad = np.any(arr <= 0.0) if positive else np.any(arr < 0.0)
    if not np.all(np.isfinite(arr)) or bad:
        kind = "positive" if positive else "non-negative"
        raise ValueError(f"{name} must be {kind} and finite, got {value!r}")
    return arr
