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
Residual ``r(q) = K (q - q_eq) + c (q - q_ref) - J(q)^T w(q)`` (``c = D/dt`` in a step, 0 in
:meth:`CompliantArm.settle`), Jacobian

    dr/dq = K + c - G(q, w) + J^T K_x J,

where ``G_ij = w . [xi_j, xi_i]`` (``j < i``, Lie brackets of the joint twists) is the exact
derivative of ``J^T`` at fixed ``w`` (:func:`bracket_stiffness`) and ``K_x = -dw/d xi`` the 6x6
Cartesian stiffness of the contact (w.r.t. a spatial displacement twist ``xi`` of the sensor).
The contact model may return ``K_x`` with the wrench; otherwise it is estimated by finite
differences (6 extra evaluations), and the matrix is refined by Broyden updates and carried over
to the next step, so a step in steady contact costs about two contact evaluations.  Safeguards:

* each step is capped so that no point of the pad moves more than ``max_step_m`` (1 mm) per
  iteration: an equilibrium posture far behind a thin object cannot pull the pad through it;
* for a conservative contact ``r`` is the gradient of the total energy, so the step length is
  found where the energy stops decreasing along the Newton direction (sign change of
  ``r . dq``, bracketed and found by Illinois regula falsi).  Unlike a residual-norm line search
  this does not stall on the kinks of penalty contacts, and it never overshoots: the solution
  is approached from inside the bracket;
* a direction that is not a descent direction (stale ``K_x``) triggers a fresh linearisation,
  then falls back to ``-K^-1 r``; non-finite trials are rejected, so the returned posture is
  always finite (at worst the best iterate, flagged ``converged=False``);
* when the steps stall on a kink (a corner or tactel a fraction of a micrometre from touching
  a 1e7 N/m object), the finite differences are widened and made central, so the linearisation
  sees both sides of the kink.

A contact model that returns its own ``K_x`` (for a penalty model: the sum over the touching
points of their stiffness, the active set of the current pose) makes the iteration a
semismooth Newton method and spares the finite differences: 1-2 iterations per step.

Tested from 1e2 to 1e7 N/m, from a warm start and from an equilibrium posture 10-50 mm inside a
rigid table (``tests/test_arm.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Union

import numpy as np

from tactile_bt.spatial import skew
from tactile_bt.sim.kinematics import LWR4Kinematics, PAD_SIZE_M, Q_READY

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
DEFAULT_STIFFNESS = 200.0
#: Joint damping of the compliance mode in N m s/rad (paper Sec. V).
DEFAULT_DAMPING = 0.2
#: Diagonal joint-space inertia in kg m^2 for ``mode="dynamic"``: a rough guess of the link-side
#: inertia of the LWR in a bent posture (no published value); the quasi-static mode ignores it.
DEFAULT_INERTIA = np.array([1.0, 1.0, 0.3, 0.3, 0.05, 0.05, 0.01])

#: A contact model: sensor pose ``T_gs`` -> wrench ``[f; tau_O]`` (global frame, N and N m about
#: the global origin), or ``(wrench, K_x)`` with the 6x6 Cartesian stiffness
#: ``K_x = -d wrench / d xi`` (``xi`` a spatial displacement twist of the sensor, ``T -> exp(xi) T``).
WrenchFn = Callable[[np.ndarray], Union[np.ndarray, tuple]]


def point_wrench(point_g, force_g, torque_g=None) -> np.ndarray:
    """Wrench of a force applied at a point, in the spatial convention.

    Parameters
    ----------
    point_g : (3,) array
        Application point in the global frame (m).
    force_g : (3,) array
        Force in the global frame (N).
    torque_g : (3,) array, optional
        Additional pure torque (N m).

    Returns
    -------
    (6,) ndarray
        ``[f; p x f + torque]``: torque taken about the global origin.
    """
    f = np.asarray(force_g, float)
    tau = skew(np.asarray(point_g, float)) @ f
    if torque_g is not None:
        tau = tau + np.asarray(torque_g, float)
    return np.concatenate((f, tau))


def bracket_stiffness(J: np.ndarray, wrench_g: np.ndarray) -> np.ndarray:
    """``G_ij = d(J^T w)_i / d q_j`` at fixed ``w`` for a spatial Jacobian (the geometric stiffness).

    Column ``xi_i`` of the spatial Jacobian depends on ``q_j`` for ``j < i`` only, through
    ``d xi_i / d q_j = ad(xi_j) xi_i = [w_j x v_i - w_i x v_j; w_j x w_i]``.

    Parameters
    ----------
    J : (6, n) array
        Spatial Jacobian.
    wrench_g : (6,) array
        Wrench ``[f; tau_O]`` (N, N m).

    Returns
    -------
    (n, n) ndarray
        Strictly lower triangular, in N m/rad.
    """
    v, w = J[:3], J[3:]
    fxw = skew(wrench_g[:3]) @ w  # (3, n): column j is f x w_j
    txw = skew(wrench_g[3:]) @ w  # (3, n): tau x w_j
    G = v.T @ fxw - fxw.T @ v + w.T @ txw
    return np.tril(G, k=-1)


@dataclass
class SettleResult:
    """Outcome of an equilibrium solve.

    Attributes
    ----------
    q : (7,) ndarray
        Actual joint angles (rad), always finite.
    T_gs : (4, 4) ndarray
        Sensor pose at ``q``.
    wrench_g : (6,) ndarray
        Contact wrench at ``q`` (N, N m about the global origin).
    residual : float
        Largest joint-torque imbalance left (N m).
    iterations : int
        Newton iterations.
    evaluations : int
        Calls of the contact model (finite differences included).
    converged : bool
        ``residual <= tol``.
    """

    q: np.ndarray
    T_gs: np.ndarray
    wrench_g: np.ndarray
    residual: float
    iterations: int
    evaluations: int
    converged: bool


class _Source:
    """Uniform access to a constant wrench or a contact model, with validation and counting."""

    def __init__(self, wrench_fn: WrenchFn | None, wrench_g) -> None:
        self.fn = wrench_fn
        self.const = np.zeros(6) if wrench_g is None else np.asarray(wrench_g, float)
        if self.const.shape != (6,) or not np.all(np.isfinite(self.const)):
            raise ValueError(f"wrench_g must be 6 finite numbers, got {wrench_g!r}")
        self.calls = 0

    def __call__(self, T: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        if self.fn is None:
            return self.const, np.zeros((6, 6))
        self.calls += 1
        out = self.fn(T)
        Kx = None
        if isinstance(out, tuple):
            out, Kx = out
        w = np.asarray(out, float)
        if w.shape != (6,):
            raise ValueError(f"wrench_fn must return a (6,) wrench, got shape {w.shape}")
        if not np.all(np.isfinite(w)):
            raise FloatingPointError(f"wrench_fn returned a non-finite wrench {w} at T_gs=\n{T}")
        if Kx is not None:
            Kx = np.asarray(Kx, float)
            if Kx.shape != (6, 6) or not np.all(np.isfinite(Kx)):
                raise ValueError("wrench_fn's stiffness must be a finite 6x6 matrix")
        return w + self.const, Kx


class CompliantArm:
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
    null_gain : float
        Rate (1/s) at which the redundancy pulls the equilibrium posture back to ``q_rest``
        (the initial posture), inside the null space of the task.
    ik_damping, sigma_threshold : float
        Damped-least-squares parameters of :meth:`LWR4Kinematics.resolved_rate` (m/rad).
    max_step_m : float
        Largest motion of any point of the pad per Newton iteration of the equilibrium solver (m).
    tol : float
        Joint-torque residual (N m) at which the equilibrium solver stops.
    max_iter : int
        Newton iteration budget per step.
    """

    def __init__(
        self,
        kinematics: LWR4Kinematics | None = None,
        q0=None,
        stiffness=DEFAULT_STIFFNESS,
        damping=DEFAULT_DAMPING,
        mode: str = "quasi_static",
        inertia=None,
        null_gain: float = 0.5,
        ik_damping: float = 0.05,
        sigma_threshold: float = 0.05,
        max_step_m: float = 1e-3,
        tol: float = 1e-4,
        max_iter: int = 60,
    ) -> None:
        self.kin = LWR4Kinematics() if kinematics is None else kinematics
        self.K = _per_joint(stiffness, "stiffness", positive=True)
        self.D = _per_joint(damping, "damping", positive=False)
        self.M = _per_joint(DEFAULT_INERTIA if inertia is None else inertia, "inertia", positive=True)
        if mode not in ("quasi_static", "dynamic"):
            raise ValueError(f"mode must be 'quasi_static' or 'dynamic', got {mode!r}")
        self.mode = mode
        self.null_gain = float(null_gain)
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
        self.pad_radius = float(np.sqrt(2.0)) * 0.5 * PAD_SIZE_M
        self._H: np.ndarray | None = None  # quasi-Newton matrix carried between solves
        self._H_Kd = np.zeros(7)
        self._kin_cache: tuple | None = None
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
        self.q_rest = q0.copy()
        self.q_dot = np.zeros(7)
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
        """
        null = self.null_gain * (self.q_rest - self.q_eq)
        return self.kin.resolved_rate(
            self.q_eq, twist_g, dt=dt, damping=self.ik_damping,
            sigma_threshold=self.sigma_threshold, q_dot_null=null,
        )

    def move(self, twist_g, dt: float, wrench_fn: WrenchFn | None = None, wrench_g=None) -> np.ndarray:
        """Follow a spatial twist for ``dt`` s: :meth:`joint_velocities` then :meth:`step`.

        Same call as the ideal ``CartesianMount.move(twist_g, dt)`` of :mod:`tactile_bt.sim.world`,
        so the arm can stand in for it (with :attr:`contact` set, contact forces deflect it).

        Returns
        -------
        (4, 4) ndarray
            The new actual sensor pose ``T_gs``.
        """
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
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        if q_dot_cmd is not None:
            qd = np.asarray(q_dot_cmd, float)
            if qd.shape != (7,) or not np.all(np.isfinite(qd)):
                raise ValueError(f"q_dot_cmd must be 7 finite numbers, got {q_dot_cmd!r}")
            self.q_eq = self.kin.clip(self.q_eq + dt * qd)
        src = _Source(self.contact if wrench_fn is None else wrench_fn, wrench_g)
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
        combined arm + contact stiffness (module docstring).

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
        src = _Source(self.contact if wrench_fn is None else wrench_fn, wrench_g)
        res = self._solve(src, q_eq, start, np.zeros(7), start,
                          self.tol if tol is None else float(tol),
                          200 if max_iter is None else int(max_iter))
        if update_state:
            self.q_eq = q_eq
            self._accept(res)
            self.q_dot = np.zeros(7)
        return res

    # ------------------------------------------------------------------ internals
    def _accept(self, res: SettleResult) -> None:
        self.q = res.q
        self._T = res.T_gs
        self.wrench_g = res.wrench_g
        self.last_solve = res

    def _fd_stiffness(self, src: _Source, T: np.ndarray, w: np.ndarray, widen: float = 1.0) -> np.ndarray:
        """``K_x = -dw/dxi`` by finite differences along the six spatial unit twists.

        Forward differences with :attr:`fd_step`; with ``widen > 1``, central differences over
        ``widen`` times the step, which average the stiffness across a nearby kink of the
        contact (a tactel or corner about to touch) instead of seeing one side of it only.
        """
        Kx = np.empty((6, 6))
        h_lin, h_ang = self.fd_step[0] * widen, self.fd_step[1] * widen
        central = widen > 1.0
        for i in range(6):
            h = h_lin if i < 3 else h_ang
            Tp = self._perturbed(T, i, h)
            wp = src(Tp)[0]
            if central:
                Kx[:, i] = -(wp - src(self._perturbed(T, i, -h))[0]) / (2.0 * h)
            else:
                Kx[:, i] = -(wp - w) / h
        return Kx

    @staticmethod
    def _perturbed(T: np.ndarray, i: int, h: float) -> np.ndarray:
        """``exp(h e_i) T``: translated along global axis ``i`` (i < 3) or turned about global
        axis ``i - 3`` through the global origin."""
        if i < 3:
            Ti = T.copy()
            Ti[i, 3] += h
            return Ti
        j, k = (i - 2) % 3, (i - 1) % 3
        c, s = math.cos(h), math.sin(h)
        R = np.eye(4)
        R[j, j] = R[k, k] = c
        R[k, j], R[j, k] = s, -s
        return R @ T

    def _solve(self, src: _Source, q_eq, q_start, c, q_ref, tol: float, max_iter: int) -> SettleResult:
        """Safeguarded quasi-Newton on ``K (q - q_eq) + c (q - q_ref) - J^T w = 0``.

        The Jacobian ``H = K + c - G + J^T K_x J`` is built from the contact stiffness (given,
        cached from the previous solve, or finite differences) and refined by Broyden updates
        while the steps succeed; it is rebuilt from a fresh ``K_x`` when a step needs the line
        search, is not a descent direction, or converges slowly.
        """
        kin, K, Kd = self.kin, self.K, self.K + c
        const = src.fn is None

        def evaluate(q):
            cache = self._kin_cache
            if cache is not None and np.array_equal(cache[0], q):
                T, J = cache[1], cache[2]
            else:
                T, J = kin.pose_and_jacobian(q)
            w, Kx = src(T)
            r = K * (q - q_eq) + c * (q - q_ref) - J.T @ w
            return T, J, w, Kx, r

        def build(Kx):
            H = np.diag(Kd) + J.T @ Kx @ J
            return H - bracket_stiffness(J, w) if w.any() else H

        zero = np.zeros((6, 6))
        if const and not src.const.any():
            # Unloaded: the implicit step is linear, q = (K q_eq + c q_ref) / (K + c).
            q = (K * q_eq + c * q_ref) / Kd
            T, J = kin.pose_and_jacobian(q)
            self._kin_cache = (q.copy(), T, J)
            return SettleResult(q, T.copy(), np.zeros(6), 0.0, 0, 0, True)
        q = q_start.copy()
        T, J, w, Kx_given, r = evaluate(q)
        if Kx_given is not None or const:
            H, fresh = build(zero if const else Kx_given), True
        elif self._H is not None:  # quasi-Newton matrix of the previous solve, new damping term
            H, fresh = self._H + np.diag(Kd - self._H_Kd), False
        else:
            H, fresh = None, False
        it, converged = 0, False
        widen = 1.0  # finite-difference widening, grows while the steps stall on a kink
        rn = float(np.linalg.norm(r))
        while True:
            if float(np.max(np.abs(r))) <= tol:
                converged = True
                break
            if it >= max_iter:
                break
            it += 1
            if H is None:
                H, fresh = build(zero if const else self._fd_stiffness(src, T, w, widen)), True
            try:
                dq = np.linalg.solve(H, -r)
            except np.linalg.LinAlgError:
                dq = np.linalg.lstsq(H, -r, rcond=None)[0]
            if not (math.isfinite(float(dq @ dq)) and float(r @ dq) < 0.0):
                if not fresh:
                    H = None  # stale linearisation: refresh and retry
                    continue
                dq = -r / Kd  # not a descent direction of the energy: fall back to K^-1 r
            dq, scale = self._cap(dq, T, J)
            alpha, trial = self._line_search(evaluate, q, dq, float(r @ dq))
            if trial is None:
                if not fresh:
                    H = None
                    continue
                break  # stalled at the best point found (finite, reported as not converged)
            step = alpha * dq
            r_old = r
            q = q + step
            T, J, w, Kx_new, r = trial
            cn = float(np.linalg.norm(r))
            ratio, rn = cn / rn, cn
            if const:
                H = None  # exact, rebuilt at the new posture if another iteration is needed
            elif Kx_new is not None:
                H, fresh = build(Kx_new), True
            else:
                if fresh and alpha < 0.01:
                    widen = min(widen * 10.0, 1e4)  # stuck on a kink: look further around it
                fresh = False
                if alpha != 1.0 or (scale == 1.0 and ratio > 0.5):
                    H = None  # the model predicted the step poorly: re-linearise
                else:  # Broyden's update of the Jacobian along the step
                    H = H + np.outer((r - r_old) - H @ step, step / float(step @ step))
        if Kx_given is None and not const and H is not None:
            self._H, self._H_Kd = H, Kd
        self._kin_cache = (q.copy(), T, J)
        return SettleResult(q, T.copy(), w.copy(), float(np.max(np.abs(r))), it, src.calls, converged)

    def _cap(self, dq: np.ndarray, T: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, float]:
        """Scale ``dq`` so no point of the pad moves more than ``max_step_m`` (and no joint > 0.1 rad).

        The motion of a pad point is bounded by ``|p_dot| + pad_radius |w|`` (centre velocity
        plus rotation times the half diagonal of the pad).
        """
        V = J @ dq
        dp = V[:3] - skew(T[:3, 3]) @ V[3:]
        reach = float(np.linalg.norm(dp)) + self.pad_radius * float(np.linalg.norm(V[3:]))
        scale = min(1.0, self.max_step_m / max(reach, 1e-300),
                    0.1 / max(float(np.max(np.abs(dq))), 1e-300))
        return dq * scale, scale

    @staticmethod
    def _line_search(evaluate, q, dq, g0):
        """Step length along ``dq`` where the energy stops decreasing: ``r(q + a dq) . dq ~ 0``.

        ``r`` is the gradient of the total (spring + contact) energy, so ``g(a) = r(q + a dq) . dq``
        is its slope along the line; ``g(0) = g0 < 0``.  The full step is taken when the slope
        is still negative or small at ``a = 1``; otherwise the sign change is bracketed and
        found by Illinois regula falsi (robust on the kinks of penalty contacts, never leaves
        the bracket, rejects non-finite trials).  Returns ``(alpha, evaluation)`` or
        ``(0, None)`` if nothing better than ``q`` was found.
        """
        eta = 0.5
        cand = evaluate(q + dq)
        g1 = float(cand[4] @ dq) if np.all(np.isfinite(cand[4])) else np.inf
        if g1 <= eta * abs(g0):
            return 1.0, cand
        lo, glo, hi, ghi = 0.0, g0, 1.0, g1
        best = None
        side = 0
        for _ in range(60):
            if np.isfinite(ghi):
                a = hi - ghi * (hi - lo) / (ghi - glo)
                if not (lo < a < hi):
                    a = 0.5 * (lo + hi)
            else:
                a = 0.5 * (lo + hi)
            cand = evaluate(q + a * dq)
            g = float(cand[4] @ dq) if np.all(np.isfinite(cand[4])) else np.inf
            if abs(g) <= eta * abs(g0):
                return a, cand
            if g < 0.0:
                lo, glo, best = a, g, (a, cand)
                if side == -1:
                    ghi *= 0.5
                side = -1
            else:
                hi, ghi = a, g
                if side == 1:
                    glo *= 0.5
                side = 1
            if hi - lo <= 1e-14:
                break
        return best if best is not None else (0.0, None)

    def _dynamic_step(self, src: _Source, dt: float) -> SettleResult:
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


def _per_joint(value, name: str, positive: bool) -> np.ndarray:
    """A scalar or 7 values as a (7,) array, validated."""
    arr = np.broadcast_to(np.asarray(value, float), (7,)).copy()
    bad = np.any(arr <= 0.0) if positive else np.any(arr < 0.0)
    if not np.all(np.isfinite(arr)) or bad:
        kind = "positive" if positive else "non-negative"
        raise ValueError(f"{name} must be {kind} and finite, got {value!r}")
    return arr
