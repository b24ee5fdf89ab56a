"""The compliant arm's compiled step against a compiled contact model.

:class:`~tactile_bt.robot.arm.CompliantArm` takes a quasi-static step in the kernels of
:mod:`tactile_bt.robot.kernels` when its contact model offers a compiled kernel of its own
(:class:`CompiledContact`; the simulated pad does, :class:`tactile_bt.sim.pad.PadContact`):
resolved rates (:func:`~tactile_bt.robot.kernels.rates_fast`), then the contact equilibrium
(:func:`~tactile_bt.robot.kernels.arm_step`), which asks for the contact at a trial pose once
per call.  :class:`ArmStepper` runs that exchange from Python: the arm's kernel and the contact
model's kernel are called in turn, so that neither links the other's machine code (numba would
compile the whole call tree of a kernel that called both again, in series, on a cold cache; see
:mod:`tactile_bt.sim.warmup`).

:class:`ArmStepper` is also the one adapter between the arm and the kernels' packed arrays
(:data:`~tactile_bt.robot.kernels.IO`, :data:`~tactile_bt.robot.kernels.OUT`,
:data:`~tactile_bt.robot.kernels.WORK`): it owns them, packs the arm's state and step
parameters in, and reads the results out by field name.

Layer: robot.
"""

from __future__ import annotations

from typing import Any, Callable, Protocol, runtime_checkable

import numpy as np

from tactile_bt.robot import kernels as rk
from tactile_bt.robot.kinematics import RateSolution

__all__ = ["CompiledContact", "ArmStepper", "RATES", "JOINT_VELOCITIES", "HOLD"]

#: Rate modes of :meth:`ArmStepper.load`: resolved rates of a twist, commanded joint
#: velocities, hold the equilibrium posture.
RATES, JOINT_VELOCITIES, HOLD = 2.0, 1.0, 0.0


@runtime_checkable
class CompiledContact(Protocol):
    """A contact model with a compiled kernel the arm's step can alternate with.

    :meth:`contact_kernel` returns ``(kernel, data)``: ``kernel(T, data, wK)`` is a numba
    dispatcher that writes the contact wrench ``[f; tau]`` (N, N m about the global origin) and
    its stiffness ``K_x`` (row-major) for the pad pose ``T`` (4x4, global frame) into the 42
    numbers ``wK`` (:data:`~tactile_bt.robot.kernels.CONTACT`).  The model is also a plain
    :data:`~tactile_bt.robot.equilibrium.WrenchFn` (called with a pose), for the steps the
    kernels hand back to the Python solvers.
    """

    def contact_kernel(self) -> tuple[Callable[..., Any], Any]:
        ...  # pragma: no cover

    def __call__(self, T_gs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ...  # pragma: no cover


class ArmStepper:
    """The packed arrays of the arm's compiled step and the loop that runs it.

    The packed kinematic model (:data:`~tactile_bt.robot.kernels.KIN`,
    :attr:`~tactile_bt.robot.kinematics.LWR4Kinematics.packed`) is an argument of each call:
    the model repacks itself when its base moves.
    """

    def __init__(self) -> None:
        self._arm_key: tuple = ()
        self._arm = np.zeros(rk.ARM.size)
        self.io = np.zeros(rk.IO.size)
        self.out = np.zeros(rk.OUT.size)
        self.work = np.zeros(rk.WORK.size)
        self._params: tuple = ()  # the step's parameters last loaded
        self._make_views()

    def _make_views(self) -> None:
        """The fields the step reads and writes, as views of the packed arrays."""
        # the trial pose the contact is asked for, and where its wrench and stiffness go
        self._trial_pose = rk.WORK.view(self.work, "T_t")
        self._trial_contact = rk.WORK.span(self.work, "w_t", "Kx_t")
        io = self.io
        self._q_eq = rk.IO.view(io, "q_eq")
        self._q = rk.IO.view(io, "q")
        self._q_dot = rk.IO.view(io, "q_dot")
        self._twist = rk.IO.view(io, "twist")
        self._q_dot_cmd = rk.IO.view(io, "q_dot_cmd")
        out, view = self.out, rk.OUT.view
        self._T, self._J, self._wrench = view(out, "T"), view(out, "J"), view(out, "wrench")
        self._rate_q_dot, self._rate_residual = view(out, "rate_q_dot"), view(out, "rate_residual")

    def __getstate__(self) -> dict:
        # the packed arrays only: a copy's views must look into the copy's arrays
        return {k: v for k, v in self.__dict__.items() if k in ("_arm_key", "_arm", "io", "out", "work", "_params")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._make_views()

    def set_arm(self, stiffness: np.ndarray, damping: np.ndarray, avoid) -> None:
        """Pack the joint stiffness, damping and null-space objective (again only when they are
        other objects than last time)."""
        key = (id(stiffness), id(damping), id(avoid))
        if key != self._arm_key:
            self._arm = rk.pack_arm(stiffness, damping, avoid)
            self._arm_key = key

    def load(self, q_eq, q, dt: float, mode: float, command, *, ik_damping: float, sigma_threshold: float,
             max_step: float, tol: float, max_iter: int, pad_radius: float) -> None:
        """The arm's state and the step's inputs; ``command`` is the twist (mode
        :data:`RATES`), the joint velocities (:data:`JOINT_VELOCITIES`) or None (:data:`HOLD`)."""
        io = self.io
        self._q_eq[:] = q_eq
        self._q[:] = q
        if mode == RATES:
            self._twist[:] = command
        elif mode == JOINT_VELOCITIES:
            self._q_dot_cmd[:] = command
        io[rk.I_DT] = dt
        io[rk.I_MODE] = mode
        params = (ik_damping, sigma_threshold, max_step, tol, max_iter, pad_radius)
        if params != self._params:
            rk.IO.pack(io, ik_damping=ik_damping, sigma_threshold=sigma_threshold, max_step=max_step, tol=tol,
                       max_iter=max_iter, pad_radius=pad_radius)
            self._params = params

    def rates(self, kin: np.ndarray) -> bool:
        """Resolved rates of the loaded twist at ``q_eq`` into the output; False when a joint
        would pass its limit (the Python solve's saturation loop is needed; nothing written)."""
        io = self.io
        return rk.rates_fast(self._q_eq, self._twist, kin, self._arm, io[rk.I_DT], io[rk.I_DAMP],
                             io[rk.I_EPS], self.out)

    def run(self, contact: CompiledContact, kin: np.ndarray) -> int:
        """The step: :func:`~tactile_bt.robot.kernels.arm_step` and the contact model's kernel at
        each trial pose, in turn.  Returns the step's status (``STATUS_*`` of
        :mod:`tactile_bt.robot.kernels`)."""
        kernel, data = contact.contact_kernel()
        step, arm, io, out, work = rk.arm_step, self._arm, self.io, self.out, self.work
        T, wK = self._trial_pose, self._trial_contact
        status = step(rk.BEGIN, kin, arm, io, out, work)
        while status == rk.STATUS_EVALUATE:
            kernel(T, data, wK)
            status = step(0, kin, arm, io, out, work)
        return int(status)

    # ------------------------------------------------------------------ results
    def rate_solution(self) -> RateSolution:
        """The resolved rates :meth:`rates` found (no joint saturated)."""
        out = self.out
        return RateSolution(self._rate_q_dot.copy(), float(out[rk.O_LAM]), float(out[rk.O_SMIN]),
                            np.zeros(7, dtype=bool), float(out[rk.O_SCALE]), self._rate_residual.copy())

    def q_eq(self) -> np.ndarray:
        """The equilibrium posture after the step (rad)."""
        return self._q_eq.copy()

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q, q_dot)`` after a step that ended with ``STATUS_OK`` (rad, rad/s)."""
        return self._q.copy(), self._q_dot.copy()

    def pose_jacobian(self) -> tuple[np.ndarray, np.ndarray]:
        """The pad pose ``T_gs`` (4x4) and the spatial Jacobian (6x7) at the step's end."""
        return self._T.copy(), self._J.copy()

    def solve(self) -> tuple[np.ndarray, float, int, int, bool]:
        """The equilibrium's wrench (N, N m), largest residual (N m), Newton iterations,
        contact evaluations and whether it converged."""
        out = self.out
        return (self._wrench.copy(), float(out[rk.O_RES]), int(out[rk.O_IT]), int(out[rk.O_EVAL]),
                bool(out[rk.O_CONV]))
