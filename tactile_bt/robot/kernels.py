"""Compiled kernels of the arm: kinematics, the resolved-rate step and the contact equilibrium.

numba ``nopython`` versions of the arm's hot path, for a contact model that is compiled too
(the simulated pad, :class:`tactile_bt.sim.pad.PadContact`, whose kernel
:class:`tactile_bt.robot.stepping.ArmStepper` alternates with :func:`arm_step`).  They compute what :mod:`tactile_bt.robot.kinematics`,
:mod:`tactile_bt.robot.resolved_rate`, :mod:`tactile_bt.robot.redundancy` and
:mod:`tactile_bt.robot.equilibrium` describe, with the same formulas, damping schedule and
safeguards, written out for the 7-joint arm.  Those Python implementations stay: they serve any
other contact model, and they take over the rare steps the kernels hand back (below).  The tests
check the kernels against them on random inputs (``tests/perception/test_kernels.py``).

The fast path and what it hands back
------------------------------------
:func:`rates_fast` and :func:`arm_step` (one contact evaluation per call) do what
:meth:`~tactile_bt.robot.arm.CompliantArm.move` does:

* resolved rates (:func:`rates_fast`): the hybrid Jacobian, the null-space objective of
  :class:`~tactile_bt.robot.redundancy.LimitAvoidance`, the damped least-squares solve with its
  damping schedule (singular values by a one-sided Jacobi sweep, :func:`jacobi_svd`) and the
  velocity scaling.  A step that would drive a joint past its limit needs the saturation loop,
  and one near a singularity (the damping on) the translation-first solve: those are handed back
  (``False``), and the Python solve does them;
* the implicit Euler step of the joint impedance against the contact (:func:`arm_step`):
  Newton with the contact's own stiffness ``K_x``, the per-iteration motion cap, the full step
  accepted when the energy's slope along it is small.  A step that needs the bracketing line
  search, or a singular Newton matrix, is handed back (:data:`STATUS_NEWTON`) to the Python
  solver, which redoes it from the same state.  (In the shipped scenes neither happens in
  thousands of steps; a joint saturates in about 2 % of the steps of the ellipsoid scan.)

Compilation
-----------
``cache=True`` keeps the machine code on disk (numba's ``NUMBA_CACHE_DIR``), IEEE semantics (no
``fastmath``) keep a seed's run the same every time.  Python
(:meth:`tactile_bt.robot.stepping.ArmStepper.run`) calls :func:`arm_step` and the contact
model's kernel in turn, so neither links the other's machine code: numba links and
optimises a function's whole call tree into it again, and one kernel calling both would pay the
compile of both a second time, in series, on a cold cache (:mod:`tactile_bt.sim.warmup`).  The
state is a few flat float64 arrays, so a call passes six arguments; each array's fields are
declared once, as a :class:`~tactile_bt.robot.layout.Layout` (:data:`KIN`, :data:`ARM`,
:data:`IO`, :data:`OUT`, :data:`WORK`, :data:`CONTACT`), whose offsets the kernels read as
module constants (``W_TT``, ...), and the work array's fields are views of it.  Small helpers with
one caller are inlined at numba's level (``inline="always"``: :func:`arm_begin`); larger ones are
called (numba's inlining retypes the inlined code in every caller, which costs more than a
call).  Loops run over sizes read from the arrays, and no helper takes a constant argument (each
constant would compile another copy).

Layer: robot.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from tactile_bt.robot.layout import Layout

__all__ = [
    "KIN",
    "ARM",
    "IO",
    "OUT",
    "WORK",
    "CONTACT",
    "KIN_SIZE",
    "ARM_SIZE",
    "IO_SIZE",
    "OUT_SIZE",
    "STATUS_OK",
    "STATUS_NONFINITE",
    "STATUS_NEWTON",
    "STATUS_EVALUATE",
    "pack_kinematics",
    "pack_arm",
    "pose_jacobian",
    "jacobi_svd",
    "dls_solve",
    "limit_avoidance",
    "rates_fast",
    "newton_matrix",
    "lu_solve",
    "WORK_SIZE",
    "BEGIN",
    "W_TT",
    "W_WT",
    "arm_begin",
    "arm_step",
]

#: Options of every kernel: machine code cached on disk, numpy's error model (1/0 = inf, no
#: exception checks), IEEE arithmetic (no fastmath).
OPTS = dict(cache=True, error_model="numpy", nogil=True)
#: Options of a small helper with one caller: inlined at numba's level.
INLINE = dict(OPTS, inline="always")

#: The packed kinematic model (:func:`pack_kinematics`): DH d, a, cos(alpha), sin(alpha); base
#: and mount (4x4); joint limits and speed limits.
KIN = Layout("kinematic model", ("d", 7), ("a", 7), ("cos_alpha", 7), ("sin_alpha", 7), ("base", (4, 4)),
             ("mount", (4, 4)), ("q_min", 7), ("q_max", 7), ("qd_max", 7))
K_D, K_A, K_CA, K_SA, K_BASE, K_MOUNT, K_QMIN, K_QMAX, K_QDMAX = map(KIN.offset, KIN.fields)
#: Length of the packed kinematic model.
KIN_SIZE = KIN.size
#: The packed arm (:func:`pack_arm`): joint stiffness and damping; limit avoidance: on/off, gain,
#: wrist band, wrist weight, speed cap, per-joint weights.
ARM = Layout("arm", ("stiffness", 7), ("damping", 7), ("avoid_on", 1), ("gain", 1), ("wrist_band", 1),
             ("wrist_weight", 1), ("speed_max", 1), ("weights", 7))
A_K, A_D, A_ON, A_GAIN, A_BAND, A_WRIST, A_SPEED, A_W = map(ARM.offset, ARM.fields)
#: Length of the packed arm.
ARM_SIZE = ARM.size
#: In/out state of :func:`arm_step`: q_eq, q, q_dot; the twist; commanded joint velocities; the
#: step (dt, rate mode, ik damping, sigma threshold, max step, tol, max iterations, pad radius).
IO = Layout("arm step state", ("q_eq", 7), ("q", 7), ("q_dot", 7), ("twist", 6), ("q_dot_cmd", 7), ("dt", 1),
            ("mode", 1), ("ik_damping", 1), ("sigma_threshold", 1), ("max_step", 1), ("tol", 1),
            ("max_iter", 1), ("pad_radius", 1))
(I_QEQ, I_Q, I_QDOT, I_TWIST, I_QDCMD, I_DT, I_MODE, I_DAMP, I_EPS, I_STEP, I_TOL, I_ITER,
 I_RADIUS) = map(IO.offset, IO.fields)
#: Length of arm_step's in/out state.
IO_SIZE = IO.size
#: Output of :func:`arm_step`: pose (4x4), Jacobian (6x7), wrench, residual, iterations, contact
#: evaluations, converged; resolved rates: q_dot, damping, sigma_min, scale, saturated, residual.
OUT = Layout("arm step output", ("T", (4, 4)), ("J", (6, 7)), ("wrench", 6), ("residual", 1), ("iterations", 1),
             ("evaluations", 1), ("converged", 1), ("rate_q_dot", 7), ("rate_damping", 1),
             ("rate_sigma_min", 1), ("rate_scale", 1), ("rate_saturated", 7), ("rate_residual", 6))
(O_T, O_J, O_W, O_RES, O_IT, O_EVAL, O_CONV, O_QD, O_LAM, O_SMIN, O_SCALE, O_SAT,
 O_RRES) = map(OUT.offset, OUT.fields)
#: Length of arm_step's output.
OUT_SIZE = OUT.size

#: The step is done.
STATUS_OK = 0
#: The contact model returned a non-finite wrench (the step stopped there).
STATUS_NONFINITE = 1
#: The equilibrium needs the bracketing line search or meets a singular Newton matrix: redo it
#: in Python (``q_eq`` and the resolved rates of the output are already updated).
STATUS_NEWTON = 2
#: :func:`arm_step` needs the contact at the trial pose.
STATUS_EVALUATE = 4

#: Closest ``1 - u^2`` the joint-limit barrier evaluates (as :mod:`tactile_bt.robot.redundancy`).
MIN_GAP = 1e-3


def pack_kinematics(d, a, alpha, base, mount, q_min, q_max, qd_max) -> np.ndarray:
    """The kinematic model as the float64 array of :data:`KIN_SIZE` numbers the kernels read
    (:data:`KIN`).

    ``cos(alpha)`` below 1e-15 is set to exactly 0 (the +-90 degree twists), as the Python chain does.
    """
    alpha = np.asarray(alpha, float)
    ca, sa = np.cos(alpha), np.sin(alpha)
    ca[np.abs(ca) < 1e-15] = 0.0
    parts = dict(d=d, a=a, cos_alpha=ca, sin_alpha=sa, base=base, mount=mount, q_min=q_min, q_max=q_max,
                 qd_max=qd_max)
    if any(np.size(v) != KIN.length(k) for k, v in parts.items()):
        raise ValueError("a 7-joint model needs 7 DH rows, 4x4 base and mount, 7 limits each")
    return KIN.pack(**parts)


def pack_arm(stiffness, damping, avoid) -> np.ndarray:
    """Joint stiffness and damping (7 each) and a
    :class:`~tactile_bt.robot.redundancy.LimitAvoidance` (None: off) as the kernels read them
    (:data:`ARM`)."""
    out = ARM.pack(stiffness=stiffness, damping=damping)
    if avoid is not None:
        ARM.pack(out, avoid_on=1.0, gain=avoid.gain, wrist_band=avoid.wrist_band_rad,
                 wrist_weight=avoid.wrist_weight, speed_max=avoid.speed_max, weights=avoid.weights)
    return out


# ---------------------------------------------------------------------- kinematics
@njit(**OPTS)
def pose_jacobian(q, kin, T, J):
    """Sensor pose ``T_gs`` (4x4, into ``T``) and spatial Jacobian (6x7, into ``J``) at ``q``.

    The plain-float recursion of the classic DH chain of
    :meth:`tactile_bt.robot.kinematics.LWR4Kinematics.pose_and_jacobian`: column ``i`` is
    ``[p_i x z_i; z_i]`` of DH frame ``i`` in the global frame.
    """
    F = np.empty((3, 4))  # columns x, y, z, p of the current frame
    for r in range(3):
        for col in range(4):
            F[r, col] = kin[K_BASE + 4 * r + col]
    for i in range(q.shape[0]):
        J[0, i] = F[1, 3] * F[2, 2] - F[2, 3] * F[1, 2]
        J[1, i] = F[2, 3] * F[0, 2] - F[0, 3] * F[2, 2]
        J[2, i] = F[0, 3] * F[1, 2] - F[1, 3] * F[0, 2]
        J[3, i] = F[0, 2]
        J[4, i] = F[1, 2]
        J[5, i] = F[2, 2]
        d = kin[K_D + i]
        a = kin[K_A + i]
        ca = kin[K_CA + i]
        sa = kin[K_SA + i]
        c = math.cos(q[i])
        s = math.sin(q[i])
        for r in range(3):
            x = c * F[r, 0] + s * F[r, 1]
            u = c * F[r, 1] - s * F[r, 0]
            z = F[r, 2]
            F[r, 3] = F[r, 3] + d * z + a * x
            F[r, 0] = x
            F[r, 1] = ca * u + sa * z
            F[r, 2] = ca * z - sa * u
    for r in range(3):
        for col in range(4):
            T[r, col] = (F[r, 0] * kin[K_MOUNT + col] + F[r, 1] * kin[K_MOUNT + 4 + col]
                         + F[r, 2] * kin[K_MOUNT + 8 + col] + F[r, 3] * kin[K_MOUNT + 12 + col])
    for col in range(4):
        T[3, col] = kin[K_MOUNT + 12 + col]


# ---------------------------------------------------------------------- resolved rates
@njit(**OPTS)
def jacobi_svd(B, V, rows, n, s, order):
    """One-sided Jacobi: rotate the ``n`` columns of ``B[:rows, :n]`` until they are orthogonal.

    On return ``B = A V`` with ``V`` (n x n, orthogonal) the right singular vectors: the column
    norms of ``B`` are the singular values (into ``s``; ``order`` lists them largest first, ties
    by index) and ``B[:, i] / sigma_i`` the left singular vectors.
    """
    for i in range(n):
        for j in range(n):
            V[i, j] = 0.0
        V[i, i] = 1.0
    # columns shorter than 1e-16 |A| are numerically zero: left alone (a relative test alone
    # would keep rotating them as they shrink)
    tiny = 0.0
    for k in range(rows):
        for j in range(n):
            tiny += B[k, j] * B[k, j]
    tiny *= 1e-32
    for _ in range(80):
        rotated = False
        for i in range(n - 1):
            for j in range(i + 1, n):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(rows):
                    alpha += B[k, i] * B[k, i]
                    beta += B[k, j] * B[k, j]
                    gamma += B[k, i] * B[k, j]
                if abs(gamma) <= 1e-15 * math.sqrt(alpha * beta) or alpha <= tiny or beta <= tiny:
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(1.0 + t * t)
                sn = c * t
                for k in range(rows):
                    bi = B[k, i]
                    B[k, i] = c * bi - sn * B[k, j]
                    B[k, j] = sn * bi + c * B[k, j]
                for k in range(n):
                    vi = V[k, i]
                    V[k, i] = c * vi - sn * V[k, j]
                    V[k, j] = sn * vi + c * V[k, j]
        if not rotated:
            break
    for j in range(n):
        acc = 0.0
        for k in range(rows):
            acc += B[k, j] * B[k, j]
        s[j] = math.sqrt(acc)
        order[j] = j
    for a in range(1, n):
        key = order[a]
        b = a - 1
        while b >= 0 and s[order[b]] < s[key]:
            order[b + 1] = order[b]
            b -= 1
        order[b + 1] = key


@njit(**OPTS)
def dls_solve(A, rhs, lam_max, eps, null, use_null, null_max, x):
    """Damped least squares ``x = A^T (A A^T + lambda^2 I)^-1 rhs`` for the 6 x n ``A``, plus
    ``null`` projected on the null space of ``A`` (right singular vectors beyond the rank) and
    scaled to at most ``null_max`` per joint (:func:`tactile_bt.robot.resolved_rate.damped_least_squares`:
    ``lambda^2 = lam_max^2 (1 - (sigma_min / eps)^2)`` below ``eps``, singular values at most
    1e-9 cut off).  Returns ``(lambda, sigma_min)``.
    """
    rows = A.shape[0]
    n = A.shape[1]
    B = A.copy()
    V = np.empty((n, n))
    s = np.empty(n)
    order = np.empty(n, np.int64)
    jacobi_svd(B, V, rows, n, s, order)
    m = rows if rows < n else n
    smin = s[order[m - 1]] if m == rows else 0.0
    lam2 = lam_max * lam_max * (1.0 - (smin / eps) ** 2) if smin < eps else 0.0
    for j in range(n):
        x[j] = 0.0
    rank = 0
    for ii in range(m):
        i = order[ii]
        si = s[i]
        if si > 1e-9:
            rank += 1
        denom = si * si + lam2
        if denom > 1e-24 and si > 1e-9:
            ub = 0.0
            for k in range(rows):
                ub += (B[k, i] / si) * rhs[k]
            coef = (si / denom) * ub
            for j in range(n):
                x[j] += V[j, i] * coef
    if use_null:
        xn = null.copy()
        for ii in range(rank):
            i = order[ii]
            dot = 0.0
            for j in range(n):
                dot += V[j, i] * null[j]
            for j in range(n):
                xn[j] -= V[j, i] * dot
        peak = 0.0
        for j in range(n):
            peak = max(peak, abs(xn[j]))
        if peak > null_max:
            f = null_max / peak
            for j in range(n):
                xn[j] *= f
        for j in range(n):
            x[j] += xn[j]
    return math.sqrt(lam2), smin


@njit(**OPTS)
def limit_avoidance(q, kin, arm, out):
    """``q_dot_null = -k dH/dq`` of :class:`tactile_bt.robot.redundancy.LimitAvoidance` into ``out``."""
    gain, band, ww = arm[A_GAIN], arm[A_BAND], arm[A_WRIST]
    for i in range(q.shape[0]):
        lo = kin[K_QMIN + i]
        hi = kin[K_QMAX + i]
        r = hi - lo
        u = (2.0 * q[i] - hi - lo) / r
        gap = max(1.0 - u * u, MIN_GAP)
        out[i] = arm[A_W + i] * (2.0 / r) * 2.0 * u / (gap * gap)
    q6 = q[5]
    if band > 0.0 and abs(q6) < band:
        side = 1.0 if q6 >= 0.0 else -1.0
        out[5] -= ww * 2.0 * side * (1.0 - abs(q6) / band) / band
    for i in range(q.shape[0]):
        out[i] = -gain * out[i]


@njit(**OPTS)
def rates_fast(q, twist, kin, arm, dt, damping, eps, out):
    """Resolved rates at the equilibrium posture ``q`` for the spatial twist, with the null-space
    objective of ``arm`` and the velocity limits, for a step of ``dt`` s
    (:meth:`tactile_bt.robot.arm.CompliantArm.joint_velocities`).

    Writes ``q_dot``, the damping, sigma_min, the speed scale, no saturated joint and the
    residual hybrid twist into ``out`` (the ``O_QD`` ... part of :func:`arm_step`'s output) and
    returns True; returns False, writing nothing, when a joint would pass its limit (the
    saturation loop of the Python solve is needed) or the damping acts (its translation-first
    solve is).
    """
    n = q.shape[0]
    T = np.empty((4, 4))
    J = np.empty((6, n))
    pose_jacobian(q, kin, T, J)
    px, py, pz = T[0, 3], T[1, 3], T[2, 3]
    for j in range(n):  # hybrid Jacobian: [p_dot; w] of the pad centre
        J[0, j] -= py * J[5, j] - pz * J[4, j]
        J[1, j] -= pz * J[3, j] - px * J[5, j]
        J[2, j] -= px * J[4, j] - py * J[3, j]
    Vh = twist.copy()
    Vh[0] -= py * twist[5] - pz * twist[4]
    Vh[1] -= pz * twist[3] - px * twist[5]
    Vh[2] -= px * twist[4] - py * twist[3]
    null = np.zeros(n)
    use_null = arm[A_ON] != 0.0
    if use_null:
        limit_avoidance(q, kin, arm, null)
    qd = np.empty(n)
    lam, smin = dls_solve(J, Vh, damping, eps, null, use_null, arm[A_SPEED], qd)
    if lam > 0.0:  # near a singularity: the Python solve makes the translation first
        return False
    peak = 1.0
    for i in range(n):
        peak = max(peak, abs(qd[i]) / kin[K_QDMAX + i])
    norm2 = 0.0
    for i in range(n):
        x = qd[i] / peak if peak > 1.0 else qd[i]
        lo = min((kin[K_QMIN + i] - q[i]) / dt, 0.0)
        hi = max((kin[K_QMAX + i] - q[i]) / dt, 0.0)
        if not (x >= lo and x <= hi):
            return False
    scale = 1.0 / peak
    for i in range(n):
        if scale < 1.0:
            qd[i] = qd[i] * scale
        norm2 += qd[i] * qd[i]
    if not math.isfinite(norm2):
        for i in range(n):
            qd[i] = 0.0
    for i in range(n):
        out[O_QD + i] = qd[i]
        out[O_SAT + i] = 0.0
    out[O_LAM] = lam
    out[O_SMIN] = smin
    out[O_SCALE] = scale
    for k in range(6):
        acc = 0.0
        for i in range(n):
            acc += J[k, i] * qd[i]
        out[O_RRES + k] = Vh[k] - acc
    return True


# ---------------------------------------------------------------------- contact equilibrium
@njit(**OPTS)
def newton_matrix(H, Kd, J, Kx, w):
    """``H = diag(Kd) + J^T K_x J - G(J, w)``, G the strictly lower geometric stiffness
    (:func:`tactile_bt.robot.equilibrium.bracket_stiffness`)."""
    n = Kd.shape[0]
    M = np.empty((6, n))
    for k in range(6):
        for j in range(n):
            acc = 0.0
            for m in range(6):
                acc += Kx[k, m] * J[m, j]
            M[k, j] = acc
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(6):
                acc += J[k, i] * M[k, j]
            H[i, j] = acc
        H[i, i] += Kd[i]
    f0, f1, f2, t0, t1, t2 = w[0], w[1], w[2], w[3], w[4], w[5]
    if f0 == 0.0 and f1 == 0.0 and f2 == 0.0 and t0 == 0.0 and t1 == 0.0 and t2 == 0.0:
        return
    for i in range(1, n):
        # G_ij = v_i . (f x w_j) - (f x w_i) . v_j + w_i . (tau x w_j)
        ai0 = f1 * J[5, i] - f2 * J[4, i]
        ai1 = f2 * J[3, i] - f0 * J[5, i]
        ai2 = f0 * J[4, i] - f1 * J[3, i]
        for j in range(i):
            aj0 = f1 * J[5, j] - f2 * J[4, j]
            aj1 = f2 * J[3, j] - f0 * J[5, j]
            aj2 = f0 * J[4, j] - f1 * J[3, j]
            bj0 = t1 * J[5, j] - t2 * J[4, j]
            bj1 = t2 * J[3, j] - t0 * J[5, j]
            bj2 = t0 * J[4, j] - t1 * J[3, j]
            H[i, j] -= ((J[0, i] * aj0 + J[1, i] * aj1 + J[2, i] * aj2) - (ai0 * J[0, j] + ai1 * J[1, j] + ai2 * J[2, j])
                        + (J[3, i] * bj0 + J[4, i] * bj1 + J[5, i] * bj2))


@njit(**OPTS)
def lu_solve(H, b, x):
    """``x = H^-1 b`` by LU with partial pivoting; False (x undefined) if ``H`` is singular."""
    n = b.shape[0]
    LU = H.copy()
    for i in range(n):
        x[i] = b[i]
    for k in range(n):
        p = k
        big = abs(LU[k, k])
        for i in range(k + 1, n):
            if abs(LU[i, k]) > big:
                big = abs(LU[i, k])
                p = i
        if big == 0.0:
            return False
        if p != k:
            for j in range(n):
                tmp = LU[k, j]
                LU[k, j] = LU[p, j]
                LU[p, j] = tmp
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
        for i in range(k + 1, n):
            f = LU[i, k] / LU[k, k]
            for j in range(k + 1, n):
                LU[i, j] -= f * LU[k, j]
            x[i] -= f * x[k]
    for i in range(n - 1, -1, -1):
        acc = x[i]
        for j in range(i + 1, n):
            acc -= LU[i, j] * x[j]
        x[i] = acc / LU[i, i]
    return True


#: The work array of :func:`arm_step`: the current iterate (q, T, J, w, K_x, r), the trial point
#: (q_t, T_t, J_t, w_t, K_xt, r_t), the Newton matrix, the step, c = D / dt, K + c, and the
#: scalars (iterations, evaluations, the initial slope, first, converged).  w_t is followed by
#: K_xt: the 42 numbers a contact model writes for the pose T_t (:data:`CONTACT`).
WORK = Layout("arm step work", ("q", 7), ("T", (4, 4)), ("J", (6, 7)), ("w", 6), ("Kx", (6, 6)), ("r", 7),
              ("q_t", 7), ("T_t", (4, 4)), ("J_t", (6, 7)), ("w_t", 6), ("Kx_t", (6, 6)), ("r_t", 7),
              ("H", (7, 7)), ("dq", 7), ("c", 7), ("Kd", 7), ("scalars", 5))
(W_Q, W_T, W_J, W_W, W_KX, W_R, W_QT, W_TT, W_JT, W_WT, W_KXT, W_RT, W_H, W_DQ, W_C, W_KD,
 W_SC) = map(WORK.offset, WORK.fields)
#: Length of :func:`arm_step`'s work array.
WORK_SIZE = WORK.size
#: What a contact model writes for a pose: the wrench ``[f; tau]`` and its stiffness ``K_x``
#: (row-major), 42 numbers.
CONTACT = Layout("contact", ("wrench", 6), ("stiffness", (6, 6)))
if WORK.offset("Kx_t") != WORK.end("w_t") or WORK.end("Kx_t") - WORK.offset("w_t") != CONTACT.size:
    raise AssertionError("the work array must hold w_t and K_xt as one contact record")
#: ``contact_status`` of :func:`arm_step` that starts a step.
BEGIN = -1


@njit(**INLINE)
def _work_views(W):
    """The arrays of the work array ``W`` (layout above), as views."""
    n = 7
    return (W[W_Q:W_Q + n], W[W_T:W_T + 16].reshape((4, 4)), W[W_J:W_J + 6 * n].reshape((6, n)), W[W_W:W_W + 6],
            W[W_KX:W_KX + 36].reshape((6, 6)), W[W_R:W_R + n],
            W[W_QT:W_QT + n], W[W_TT:W_TT + 16].reshape((4, 4)), W[W_JT:W_JT + 6 * n].reshape((6, n)),
            W[W_WT:W_WT + 6], W[W_KXT:W_KXT + 36].reshape((6, 6)), W[W_RT:W_RT + n],
            W[W_H:W_H + n * n].reshape((n, n)), W[W_DQ:W_DQ + n], W[W_C:W_C + n], W[W_KD:W_KD + n],
            W[W_SC:W_SC + 5])


@njit(**INLINE)
def arm_begin(kin, arm, io, out, work):
    """Start one quasi-static step of :class:`tactile_bt.robot.arm.CompliantArm` (see
    :func:`arm_step`).

    ``io`` (:data:`IO_SIZE`) holds the arm's state and the step's inputs; its rate mode is 2:
    the resolved rates :func:`rates_fast` has put into ``out`` (the caller calls it first, and
    hands a step it refuses to the Python solver), 1: the commanded joint velocities, 0: hold.
    The equilibrium posture moves and is clipped into the limits, and the previous posture
    becomes the first trial point.  Returns :data:`STATUS_EVALUATE` (a contact model must fill
    ``w_t`` and ``K_xt`` of ``work`` for its ``T_t``).
    """
    n = 7
    q, T, J, w, Kx, r, qt, Tt, Jt, wt, Kxt, rt, H, dq, c, Kd, sc = work
    dt = io[I_DT]
    mode = io[I_MODE]
    if mode == 2.0:  # the resolved rates of rates_fast, in out
        for i in range(n):
            io[I_QDCMD + i] = out[O_QD + i]
    for i in range(n):
        if mode != 0.0:
            io[I_QEQ + i] = min(max(io[I_QEQ + i] + dt * io[I_QDCMD + i], kin[K_QMIN + i]), kin[K_QMAX + i])
        c[i] = arm[A_D + i] / dt
        Kd[i] = arm[A_K + i] + c[i]
        qt[i] = io[I_Q + i]
        dq[i] = 0.0
    sc[0] = 0.0  # iterations
    sc[1] = 1.0  # contact evaluations
    sc[2] = 0.0  # initial slope of the step
    sc[3] = 1.0  # first evaluation
    sc[4] = 0.0  # converged
    pose_jacobian(qt, kin, Tt, Jt)
    return STATUS_EVALUATE


@njit(**OPTS)
def arm_step(contact_status, kin, arm, io, out, W):
    """One quasi-static step of :class:`tactile_bt.robot.arm.CompliantArm` against a contact
    model, one contact evaluation per call.

    ``contact_status`` :data:`BEGIN` starts the step (:func:`arm_begin`).  Every call that
    returns :data:`STATUS_EVALUATE` asks for the contact at the trial pose ``T_t`` of the work
    array ``W`` (:data:`WORK_SIZE` numbers): the contact model writes the wrench ``w_t`` and its
    stiffness ``K_xt`` (the 42 numbers from :data:`W_WT`), and the next call continues with its
    status (non-zero: the contact model failed).

    The implicit Euler step ``K (q - q_eq) + c (q - q_prev) - J^T w = 0`` (``c = D / dt``) is
    solved as :meth:`tactile_bt.robot.equilibrium.EquilibriumSolverMixin._solve` does for a
    contact model that returns its stiffness ``K_x``: Newton from the previous posture, each step
    capped so no pad point moves more than the step limit and no joint more than 0.1 rad, the
    full step accepted when the energy's slope along it is at most half its initial value.

    Returns :data:`STATUS_EVALUATE` (evaluate the contact at the new trial pose and call again)
    or the step's end: :data:`STATUS_OK` (``io``'s posture and joint velocities updated, ``out``
    holds the pose, Jacobian, wrench and diagnostics), :data:`STATUS_NEWTON` (a step that needs
    the bracketing line search or meets a singular Newton matrix: ``q_eq`` is updated, the Python
    solver redoes the equilibrium) or :data:`STATUS_NONFINITE`.
    """
    work = _work_views(W)
    if contact_status == BEGIN:
        return arm_begin(kin, arm, io, out, work)
    n = 7
    q, T, J, w, Kx, r, qt, Tt, Jt, wt, Kxt, rt, H, dq, c, Kd, sc = work
    status = STATUS_EVALUATE
    finite = contact_status == 0
    for i in range(6):
        finite = finite and math.isfinite(wt[i])
    if not finite:
        status = STATUS_NONFINITE
    else:
        g1 = 0.0
        for i in range(n):
            acc = 0.0
            for k in range(6):
                acc += Jt[k, i] * wt[k]
            rt[i] = arm[A_K + i] * (qt[i] - io[I_QEQ + i]) + c[i] * (qt[i] - io[I_Q + i]) - acc
            g1 += rt[i] * dq[i]
        if sc[3] == 0.0 and not (g1 <= 0.5 * abs(sc[2])):
            status = STATUS_NEWTON  # not small enough (or not finite): bracketing needed
    if status == STATUS_EVALUATE:
        sc[3] = 0.0
        # accept the trial point
        for i in range(n):
            q[i] = qt[i]
            r[i] = rt[i]
            for k in range(6):
                J[k, i] = Jt[k, i]
        for i in range(6):
            w[i] = wt[i]
            for k in range(6):
                Kx[i, k] = Kxt[i, k]
        for i in range(4):
            for k in range(4):
                T[i, k] = Tt[i, k]
        newton_matrix(H, Kd, J, Kx, w)
        rmax = 0.0
        for i in range(n):
            rmax = max(rmax, abs(r[i]))
        if rmax <= io[I_TOL]:
            sc[4] = 1.0
            status = STATUS_OK
        elif sc[0] >= io[I_ITER]:
            status = STATUS_OK
        else:
            sc[0] += 1.0
            for i in range(n):
                rt[i] = -r[i]
            if not lu_solve(H, rt, dq):
                status = STATUS_NEWTON
    if status == STATUS_EVALUATE:
        dd = 0.0
        g0 = 0.0
        for i in range(n):
            dd += dq[i] * dq[i]
            g0 += r[i] * dq[i]
        if not (math.isfinite(dd) and g0 < 0.0):
            for i in range(n):
                dq[i] = -r[i] / Kd[i]  # not a descent direction of the energy: K^-1 r
        # cap: no pad point moves more than max_step, no joint more than 0.1 rad
        v0 = 0.0
        v1 = 0.0
        v2 = 0.0
        o0 = 0.0
        o1 = 0.0
        o2 = 0.0
        big = 0.0
        for i in range(n):
            v0 += J[0, i] * dq[i]
            v1 += J[1, i] * dq[i]
            v2 += J[2, i] * dq[i]
            o0 += J[3, i] * dq[i]
            o1 += J[4, i] * dq[i]
            o2 += J[5, i] * dq[i]
            big = max(big, abs(dq[i]))
        px, py, pz = T[0, 3], T[1, 3], T[2, 3]
        d0 = v0 - (py * o2 - pz * o1)
        d1 = v1 - (pz * o0 - px * o2)
        d2 = v2 - (px * o1 - py * o0)
        reach = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) + io[I_RADIUS] * math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
        scale = min(1.0, min(io[I_STEP] / max(reach, 1e-300), 0.1 / max(big, 1e-300)))
        g0 = 0.0
        for i in range(n):
            dq[i] = dq[i] * scale
            g0 += r[i] * dq[i]
            qt[i] = q[i] + dq[i]
        sc[2] = g0
        sc[1] += 1.0
        pose_jacobian(qt, kin, Tt, Jt)
        return STATUS_EVALUATE
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, abs(r[i]))
        for k in range(6):
            out[O_J + 7 * k + i] = J[k, i]
    for i in range(4):
        for k in range(4):
            out[O_T + 4 * i + k] = T[i, k]
    for i in range(6):
        out[O_W + i] = w[i]
    out[O_RES] = rmax
    out[O_IT] = sc[0]
    out[O_EVAL] = sc[1]
    out[O_CONV] = sc[4]
    if status == STATUS_OK:
        dt = io[I_DT]
        for i in range(n):
            io[I_QDOT + i] = (q[i] - io[I_Q + i]) / dt
            io[I_Q + i] = q[i]
    return status
