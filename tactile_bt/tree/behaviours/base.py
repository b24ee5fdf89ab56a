"""Shared machinery of the tactile leaves: the leaf base with its cycle data, and the servo base.

Every leaf reads the cycle's data from the blackboard namespace ``/tactile``
(:mod:`tactile_bt.tree.blackboard` lists the keys).

Speed: a leaf runs every control cycle, so what py_trees does per tick besides the leaf's own
work is trimmed (:meth:`TactileBehaviour.tick`), and the servo leaves work on Python floats with
their per-cycle index tables built once.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
import py_trees
from py_trees.common import Access, Status

from tactile_bt import defaults
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.tree.declaration import REQUIRED, Parameter, Parameterised
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, POSITIVE_OR_INF, between, resolve_references
from tactile_bt.control.chatter import ChatterDamper
from tactile_bt.control.servo import PID, feature_error, feature_errors_of, inverse_task_jacobian, per_component
from tactile_bt.tree.blackboard import FEATURES, FEATURES_RAW, KEYS, NAMESPACE, POSE, TIME, current_pad, read
from tactile_bt.tree.ticking import STATUSES, checked, debug_logging

__all__ = ["LazyFeedback", "TactileBehaviour", "TactileDecorator", "ServoLeaf", "ROLL_RADIUS", "METRIC_OF_COMPONENT", "metric_scale", "norm"]

_ZERO_TWIST = (0.0,) * 6
_RUNNING = Status.RUNNING

#: Name of the logged error of each feature component (units: px of the pad, Pa, rad).
METRIC_OF_COMPONENT = {
    0: "cop_x_px",
    1: "cop_y_px",
    2: "pressure_pa",
    3: "orientation_rad",
}


def norm(v: np.ndarray) -> float:
    """``float(numpy.linalg.norm(v))`` of a float vector: the same product and square root,
    without that function's dispatch (a few µs, in leaves that run every cycle)."""
    return math.sqrt(v.dot(v))


def metric_scale(component: int, pad: PadGeometry) -> float:
    """Factor from a component's error in SI units (m, Pa, rad) to its logged unit: tactels of
    ``pad`` (``1 / pad.pitch``) for the COP components, 1 for pressure and orientation."""
    return 1.0 / pad.pitch if component in (0, 1) else 1.0


class LazyFeedback:
    """A py_trees node whose ``feedback_message`` is formatted only when somebody reads it.

    Formatting a message every control cycle would cost more than most leaves' work, so a node
    that runs sets ``self._feedback = None`` and overrides :meth:`describe`; reading
    ``feedback_message`` then returns ``describe()`` of the node's current state. Assigning
    ``feedback_message`` (an end, a fixed word) stores that message as py_trees does.
    """

    _feedback: str | None = ""

    @property
    def feedback_message(self) -> str:
        message = self._feedback
        return self.describe() if message is None else message

    @feedback_message.setter
    def feedback_message(self, message: str) -> None:
        self._feedback = message

    def describe(self) -> str:
        """The message of the node's current state, while no fixed message is set."""
        return ""


class TactileBehaviour(LazyFeedback, Parameterised, py_trees.behaviour.Behaviour):
    """A py_trees leaf with read access to the cycle data of the ``/tactile`` blackboard.

    Subclasses list the features they need in ``uses`` (``"pressure"``, ``"cop"``,
    ``"orientation"``); the mission computes only what the running leaves use. They declare
    their parameters as class attributes (:class:`~tactile_bt.tree.declaration.Parameter`) and
    build what they derive from them in :meth:`parameters_changed`; a leaf is built with
    keyword arguments, ``ForceHold("hold", target_pa=1500.0)`` (``name`` may come first, and the
    parameters after it in the order of ``parameters``).
    """

    uses: frozenset[str] = frozenset()
    writes: tuple[str, ...] = ()
    #: A leaf whose SUCCESS ends a task by touch (the end of a cable, no frontier left): its name
    #: and feedback message become the mission's reason (:func:`tactile_bt.mission.loop.success_reason`).
    reports_success: bool = False

    def standing(self) -> str:
        """What a task that ends by itself (``reports_success``) has achieved so far, for the
        reason of a mission whose time ran out before it ended
        (:func:`tactile_bt.mission.loop.running_reason`); "" when there is nothing to say."""
        return ""

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        values = self.check_parameters(name, parameters, args)
        py_trees.behaviour.Behaviour.__init__(self, name=values["name"])
        self.bb = self.attach_blackboard_client(name=self.name, namespace=NAMESPACE)
        for key in KEYS:
            access = Access.WRITE if key in self.writes else Access.READ
            self.bb.register_key(key=key, access=access)
        self.apply_parameters(values)

    # Hot-path reads. The keys are registered with the client above (so py_trees shows who
    # reads what); the per-cycle values come through the blackboard adapter's fast path.
    @property
    def features(self):
        """Smoothed :class:`~tactile_bt.perception.features.ContactFeatures` of this cycle."""
        return read(FEATURES)

    @property
    def features_raw(self):
        """Unsmoothed features of this cycle."""
        return read(FEATURES_RAW)

    @property
    def now(self) -> float:
        """Mission time in s."""
        return read(TIME)

    @property
    def pose(self) -> np.ndarray:
        """``T_gs`` of this cycle."""
        return read(POSE)

    @property
    def pad(self) -> PadGeometry:
        """The mission's pad (``/tactile/pad``; the default ``PadGeometry()`` when none is written)."""
        return current_pad()

    def tick(self):
        """py_trees' :meth:`~py_trees.behaviour.Behaviour.tick`, minus two costs of every tick that
        do no work: a debug message formatted while py_trees' debug log is off, and the list of
        all statuses built to check the one ``update`` returned. Same calls, same order, same
        result; with py_trees' debug log on, py_trees' own ``tick`` runs."""
        if debug_logging():
            if self.status != _RUNNING:
                resolve_references(self)
            yield from super().tick()
            return
        self.tick_direct()
        yield self

    def tick_direct(self) -> None:
        """:meth:`tick` without the generator (:mod:`tactile_bt.tree.ticking`)."""
        if self.status != _RUNNING:
            resolve_references(self)
            self.initialise()
        new_status = self.update()
        if new_status not in STATUSES:
            new_status = checked(self, new_status)
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status

    def setup(self, **kwargs) -> None:
        """Bind the mission's constant objects: the control period and the cycle command.

        The mission (or :mod:`tactile_bt.testing`) writes them before calling ``tree.setup()``.
        """
        self.dt = float(self.bb.dt)
        self.command = self.bb.command


class TactileDecorator(Parameterised):
    """Base of a decorator with declared parameters (mixed in before its py_trees decorator
    class): built as ``Retry(child, name="retry", num_failures=2)``, the child first.

    The py_trees class's own ``__init__`` does not run (its arguments are the declared
    parameters); a decorator sets the rest of py_trees' state as class attributes or in
    :meth:`~tactile_bt.tree.declaration.Parameterised.parameters_changed`.
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, name: str | None = None, *args, **parameters) -> None:
        values = self.check_parameters(name, parameters, args)
        py_trees.decorators.Decorator.__init__(self, name=values["name"], child=child)
        self.apply_parameters(values)


#: ``roll_radius`` of the leaves that roll (``Roll``, ``TactileServo``, ``RollTo``), each
#: declaring ``roll_radius = ROLL_RADIUS.replace()``.
ROLL_RADIUS = Parameter(defaults.ROLL_RADIUS_M, bound=POSITIVE, unit="m", fixed=True,
                        doc="Rolling radius r of the rows ωx = +Δy/r, ωy = −Δx/r of J⁻¹ (m).")


class ServoLeaf(TactileBehaviour):
    """Base of every servo primitive: PID on some feature components, one part of Eq. 3.

    A subclass sets ``components`` (indices into Δf = [Δx, Δy, Δp, Δα]) and ``rows`` (the twist
    rows it drives, i.e. the ones of its projection P_i), and implements :meth:`targets`. While
    RUNNING the leaf adds ``P_i · J⁻¹ · u`` to the cycle's command. With ``converge`` set it
    succeeds once every controlled error stays inside ``band`` for ``dwell_s`` seconds;
    otherwise it runs until its parent stops it.

    The gains, ``output_limit`` and ``band`` are declared here without a default or unit; each
    subclass redeclares them with its own (``kp = ServoLeaf.kp.replace(default=..., unit=...)``).

    Every servo leaf damps chatter the same way: an output that switches sign with a large jump
    tick after tick (a flat pad over a ridge or bridging a concave surface) has its gain
    reduced and is low-passed until it stops (:class:`~tactile_bt.control.chatter.ChatterDamper`,
    the ``chatter_*`` parameters, defaults ``defaults.SERVO_CHATTER_*``); an output that does
    not chatter passes unchanged.
    """

    components: tuple[int, ...] = ()
    rows: tuple[int, ...] = ()

    kp = Parameter(REQUIRED, type=float, bound=NON_NEGATIVE, unit=None,
                   doc="Proportional gain per controlled component (see the subclass for units).")
    ki = Parameter(0.0, type=float, bound=NON_NEGATIVE, unit=None, doc="Integral gain per controlled component.")
    kd = Parameter(0.0, type=float, bound=NON_NEGATIVE, unit=None, doc="Derivative gain per controlled component.")
    output_limit = Parameter(math.inf, type=float, bound=POSITIVE_OR_INF, unit=None,
                             doc="Largest command per component (m/s for positions and force, rad/s for angles).")
    converge = Parameter(False, doc="Succeed once the error stays inside ``band`` for ``dwell_s``; otherwise run "
                                    "until the parent stops the leaf.")
    band = Parameter(math.inf, type=float, bound=POSITIVE, unit=None,
                     doc="Convergence band per component, in the component's error unit (m, Pa or rad).")
    dwell_s = Parameter(0.5, bound=NON_NEGATIVE, doc="Time the errors must stay inside ``band`` (s, mission clock).")
    chatter_jump_share = Parameter(defaults.SERVO_CHATTER_JUMP_SHARE, bound=between(0, 2, low_open=True), unit=None,
                                   doc="A sign change of an output counts as chatter when it jumps by at least this "
                                       "share of ``output_limit`` within "
                                       f"{defaults.SERVO_CHATTER_GAP_S * 1e3:g} ms of the previous one.")
    chatter_gain_min = Parameter(defaults.SERVO_CHATTER_GAIN_MIN, bound=between(0, 1), unit=None,
                                 doc="Gain of an output at full chatter (1: no damping).")
    chatter_smooth_s = Parameter(defaults.SERVO_CHATTER_SMOOTH_S, bound=NON_NEGATIVE,
                                 doc="Time constant of the low-pass on an output at full chatter (s).")
    chatter_recover_s = Parameter(defaults.SERVO_CHATTER_RECOVER_S, bound=POSITIVE,
                                  doc="Time in which the damping wears off without chatter (s).")

    _inputs = None  # features and targets of the last tick, for last_error
    _inside_since: float | None = None
    _last_twist = _ZERO_TWIST

    def parameters_changed(self, changed: frozenset[str]) -> None:
        """Rebuild the PID of changed gains, the Jacobian map of a changed ``roll_radius`` (or
        projection), the per-component ``band``."""
        n = len(self.components)
        if changed & {"kp", "ki", "kd", "output_limit"}:
            self.pid = self._make_pid(self.kp, self.ki, self.kd, self.output_limit)
        if changed & {"kp", "ki", "kd", "output_limit", "chatter_jump_share", "chatter_gain_min", "chatter_smooth_s",
                      "chatter_recover_s"}:
            self.damper = ChatterDamper(self.pid.output_limit, self.chatter_jump_share, defaults.SERVO_CHATTER_STEP,
                                        self.chatter_recover_s, self.chatter_gain_min, self.chatter_smooth_s,
                                        defaults.SERVO_CHATTER_GAP_S)
        if "roll_radius" in changed or not hasattr(self, "_map"):
            self._build_map(getattr(self, "roll_radius", defaults.ROLL_RADIUS_M))
        if "band" in changed:
            self.band = per_component(self.band, n, "band", self.name)

    def _build_map(self, roll_radius: float) -> None:
        """The columns of P·J⁻¹ of this leaf's components and the tables of the hot path."""
        n = len(self.components)
        P = np.zeros((6, 6))
        P[list(self.rows), list(self.rows)] = 1.0
        # Columns of P·J⁻¹ for this leaf's components: a 6×n map from u to the twist part.
        self._map = (P @ inverse_task_jacobian(roll_radius))[:, list(self.components)]
        # The same map as (row, coefficient) pairs per component, for the per-cycle hot path.
        self._rows_of = [[(r, float(self._map[r, j])) for r in range(6) if self._map[r, j] != 0.0]
                         for j in range(n)]
        # ... and flat, as (component, row, coefficient) in the order of the components.
        self._terms = [(j, r, c) for j in range(n) for r, c in self._rows_of[j]]
        # Components with no row in P·J⁻¹ are not controlled (e.g. a tactile_servo whose P
        # leaves them out): they neither gate the leaf on NaN nor appear in the error log.
        self._active = [j for j in range(n) if self._rows_of[j]]
        # Their errors are computed only when read (last_error); their PID loops would run for
        # nothing and see NaN (state held, u = 0).
        self._error = feature_errors_of(self.components, self._active)
        self._no_contact = [math.nan] * n
        self._set_pad(PadGeometry())  # the mission's pad replaces it when the leaf starts

    def _make_pid(self, kp, ki, kd, output_limit) -> PID:
        return PID(kp, ki, kd, output_limit, n=len(self.components), owner=self.name)

    def _set_pad(self, pad: PadGeometry) -> None:
        """Log the COP errors in tactels of ``pad``."""
        self._metrics = [(METRIC_OF_COMPONENT[c], metric_scale(c, pad)) for c in self.components]
        # (component, logged name, scale) of the controlled components, for the per-cycle log.
        self._logged = [(j, *self._metrics[j]) for j in self._active]

    @property
    def last_twist(self) -> np.ndarray:
        """The twist part ``P_i · J⁻¹ · u`` this leaf added in its last tick (sensor frame)."""
        return np.array(self._last_twist, dtype=float)

    @property
    def last_error(self) -> list[float]:
        """Δf of every component at the last tick (m, Pa, rad; NaN before the first tick or
        where undefined), computed when read."""
        if self._inputs is None:
            return [math.nan] * len(self.components)
        f, (cop, pressure, alpha) = self._inputs
        full = feature_error(f, cop, pressure, alpha)
        return [full[c] for c in self.components]

    def describe(self) -> str:
        """The errors of the last tick (measured − target, logged units)."""
        return "error " + ", ".join(
            f"{metric}={-e * scale:+.3g}" for (metric, scale), e in zip(self._metrics, self.last_error)
        )

    # -- to be provided by subclasses -------------------------------------------------------
    def targets(self) -> tuple[tuple[float, float], float, float]:
        """``(target_cop (m, m), target_pressure (Pa), target_orientation (rad))``."""
        raise NotImplementedError

    # -- py_trees life cycle ----------------------------------------------------------------
    def initialise(self) -> None:
        self._set_pad(self.pad)
        self.pid.reset()
        self.damper.reset()
        self._inside_since = None
        self._last_twist = _ZERO_TWIST

    def update(self) -> Status:
        f = read(FEATURES)
        targets = self.targets()
        self._inputs = (f, targets)
        # only the controlled components: the others are computed when last_error is read
        error = self._error(f, targets) if f.in_contact else self._no_contact
        command = self.command
        errors = command.errors
        finite = True
        for j, metric, scale in self._logged:
            e = error[j]
            errors[metric] = -e * scale  # logged as measured − target, metric units
            if e != e:
                finite = False
        if not finite:
            self._last_twist = _ZERO_TWIST
            self._inside_since = None
            self.feedback_message = "no contact" if not f.in_contact else "feature undefined"
            return _RUNNING
        active = self._active  # idle components: error NaN, u = 0, so only these are advanced
        u = self.damper.apply(self.pid.update(error, self.dt, active), self.dt, active)
        twist = [0.0] * 6
        for j, r, coefficient in self._terms:
            twist[r] += coefficient * u[j]
        self._last_twist = twist
        command.add(self.name, twist)
        self._feedback = None  # described on demand from last_error
        if self.converge:
            band = self.band
            inside = True
            for j in self._active:
                if not abs(error[j]) <= band[j]:
                    inside = False
                    break
            if inside:
                now = read(TIME)
                if self._inside_since is None:
                    self._inside_since = now
                if now - self._inside_since >= self.dwell_s:
                    self._feedback = self.describe() + " (converged)"
                    return Status.SUCCESS
            else:
                self._inside_since = None
        return _RUNNING
