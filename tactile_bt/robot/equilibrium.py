"""Contact equilibrium of the compliant arm: the safeguarded quasi-Newton solver and its parts.

:class:`~tactile_bt.robot.arm.CompliantArm` solves, in every quasi-static step and in
:meth:`~tactile_bt.robot.arm.CompliantArm.settle`, for the posture ``q`` where the joint springs
balance the contact (see :mod:`tactile_bt.robot.arm` for the model).  This module holds that
solver (:class:`EquilibriumSolverMixin`, mixed into the arm), the contact model interface
(:data:`WrenchFn`), the result (:class:`SettleResult`) and the geometric helpers
(:func:`point_wrench`, :func:`bracket_stiffness`); :mod:`tactile_bt.robot.arm` re-exports them.

Equilibrium solver
------------------
Residual ``r(q) = K (q - q_eq) + c (q - q_ref) - J(q)^T w(q)`` (``c = D/dt`` in a step, 0 in
:meth:`~tactile_bt.robot.arm.CompliantArm.settle`), Jacobian

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
rigid table (``tests/robot/test_arm.py``).

Layer: robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Union

import numpy as np

from tactile_bt.control.spatial import skew

__all__ = [
    "WrenchFn",
    "SettleResult",
    "EquilibriumSolverMixin",
    "point_wrench",
    "bracket_stiffness",
]

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


class WrenchSource:
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


class EquilibriumSolverMixin:
    """The equilibrium solver of :class:`~tactile_bt.robot.arm.CompliantArm` (module docstring).

    Mixed into the arm, whose attributes it uses: ``kin`` (the kinematic model), ``K`` (joint
    stiffness), ``max_step_m``, ``pad_radius`` and ``fd_step`` (see the arm), and the state it
    carries between solves, ``_H`` and ``_H_Kd`` (quasi-Newton matrix and the damping term it
    was built with) and ``_kin_cache`` (pose and Jacobian of the last posture).
    """

    def _fd_stiffness(self, src: WrenchSource, T: np.ndarray, w: np.ndarray, widen: float = 1.0) -> np.ndarray:
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

    def _solve(self, src: WrenchSource, q_eq, q_start, c, q_ref, tol: float, max_iter: int) -> SettleResult:
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
