"""The supervisor: one check of every cycle between the controller and the mount, outside the tree.

```
ControlLoop (features, tree tick, V_s) ─→ Supervisor ─→ Ad(T_gs) ─→ mount / robot
```

It sees each cycle's smoothed features, the pad's pose and the tree's sensor-frame twist before
the mount does, and enforces what no tree may switch off:

- **force and pressure limits**: while the smoothed pressure or force is above its limit, the
  twist is replaced by a retreat along the pad normal (``-z`` of the sensor frame, whose ``z``
  points towards the object; at ``retreat_speed_mps``, or as fast as the tree itself backs off
  when that is faster), with a slide in the pad's plane away from the contact off its
  centre (up to that speed at the border: an object beside the border is left sideways too; never
  towards another contact region seen within ``defaults.SUPERVISOR_BRIDGE_MEMORY_S``), and the
  tree is told through the blackboard
  (:mod:`tactile_bt.tree.behaviours.supervision`); once a limit has been exceeded for ``grace_s``
  in all within one intervention (the supervisor retreating all that time), the mission ends with
  ``failure`` naming the limit. An intervention is over once every value has stayed within its
  limit for ``clear_s``; a tree that presses again before that is still in it, so that its
  stretches above a limit add up.
- **live missions**: a silent sensor (no new frame for ``sensor_silence_s``), a stale robot pose
  (older than ``pose_stale_s``) and a pad outside the workspace box end the mission at once,
  with a zero twist.

Its limits are a :class:`SupervisorLimits`, declared in one place: the defaults in
:mod:`tactile_bt.defaults` (pressure: twice the highest pressure target of the tree's leaves;
force: the absolute cap), the bounds a scene or run may set them within in the scene schema
(``supervisor:``, :data:`tactile_bt.sim.scene.SUPERVISOR`). No tree parameter reaches it.
:meth:`Supervisor.stop` gives the last command of every way out of a mission: a zero twist.

Layer: mission.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Callable, Mapping

import numpy as np

from tactile_bt import defaults
from tactile_bt.sim.scene import SUPERVISOR
from tactile_bt.tree.behaviours.supervision import publish_supervision

__all__ = ["SupervisorLimits", "Supervisor", "Intervention", "tree_targets", "PRESSURE_TARGETS", "FORCE_TARGETS"]

#: Leaf parameters that name a contact pressure the tree aims for or must reach (Pa).
PRESSURE_TARGETS = ("target_pa", "pressure_pa")
#: Leaf parameters that name a contact force the tree aims for (N).
FORCE_TARGETS = ("target_n",)
#: Interventions listed one by one in the report (the count and times cover all of them).
REPORTED_INTERVENTIONS = 20


@dataclass(frozen=True)
class SupervisorLimits:
    """What the supervisor enforces. Every field is checked against the scene schema's bounds
    (:data:`tactile_bt.sim.scene.SUPERVISOR`): ValueError naming the field otherwise.

    Attributes
    ----------
    pressure_limit_pa : float
        Largest smoothed contact pressure (Pa).
    force_limit_n : float
        Largest smoothed contact force of the contact region (N); at most
        ``defaults.SUPERVISOR_FORCE_CAP_N``.
    grace_s : float
        Time above a limit, in all, within one intervention, after which the mission ends (s):
        the retreat had that long to bring the value back.
    clear_s : float
        Time within every limit after which an intervention is over (s).
    retreat_speed_mps : float
        Speed of the retreat along the pad normal, away from the object (m/s).
    sensor_silence_s : float
        Live missions: longest time without a new sensor frame (s).
    pose_stale_s : float
        Live missions: oldest robot pose accepted (s).
    workspace_min_m, workspace_max_m : tuple of 3 floats, optional
        Corners of the box (base frame, m) the pad's origin must stay in; no box when None.
    """

    pressure_limit_pa: float = defaults.SUPERVISOR_PRESSURE_FACTOR * defaults.TARGET_PRESSURE_PA
    force_limit_n: float = defaults.SUPERVISOR_FORCE_CAP_N
    grace_s: float = defaults.SUPERVISOR_GRACE_S
    clear_s: float = defaults.SUPERVISOR_CLEAR_S
    retreat_speed_mps: float = defaults.SUPERVISOR_RETREAT_SPEED_MPS
    sensor_silence_s: float = defaults.SUPERVISOR_SENSOR_SILENCE_S
    pose_stale_s: float = defaults.SUPERVISOR_POSE_STALE_S
    workspace_min_m: tuple[float, float, float] | None = None
    workspace_max_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None and f.name.startswith("workspace_"):
                continue
            kind = SUPERVISOR[f.name]
            if f.name.startswith("workspace_"):
                value = tuple(float(v) for v in value)
                if len(value) != 3 or not all(kind.item.accepts(v) for v in value):
                    raise ValueError(f"supervisor.{f.name}: expected {kind}, got {value!r}")
            elif not kind.accepts(value):
                raise ValueError(f"supervisor.{f.name}: expected {kind}, got {value!r}")
            object.__setattr__(self, f.name, value if isinstance(value, tuple) else float(value))
        lo, hi = self.workspace_min_m, self.workspace_max_m
        if (lo is None) != (hi is None):
            raise ValueError("supervisor: a workspace box needs both workspace_min_m and workspace_max_m")
        if lo is not None and not all(a < b for a, b in zip(lo, hi)):
            raise ValueError(f"supervisor.workspace_max_m: expected every coordinate above workspace_min_m {list(lo)}, "
                             f"got {list(hi)}")

    @classmethod
    def for_tree(cls, tree, declared: Mapping | None = None) -> "SupervisorLimits":
        """The limits of a mission running ``tree``: ``defaults.SUPERVISOR_PRESSURE_FACTOR``
        times the highest pressure (and force) target of its leaves (:func:`tree_targets`; the
        default target when it has none), the force capped at ``defaults.SUPERVISOR_FORCE_CAP_N``,
        then what the scene or run ``declared`` (its ``supervisor:`` fields) on top."""
        pressures, forces = tree_targets(tree)
        factor = defaults.SUPERVISOR_PRESSURE_FACTOR
        pressure = factor * max(pressures, default=defaults.TARGET_PRESSURE_PA)
        limits = {
            "pressure_limit_pa": min(pressure, defaults.SUPERVISOR_PRESSURE_CAP_PA),
            "force_limit_n": min(factor * max(forces, default=math.inf), defaults.SUPERVISOR_FORCE_CAP_N),
        }
        limits.update(declared or {})
        return cls(**limits)

    def to_dict(self) -> dict:
        """The limits as report.json shows them (a workspace corner as a list, or null)."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


def tree_targets(tree) -> tuple[list[float], list[float]]:
    """The pressures (Pa) and forces (N) the leaves of ``tree`` (a BehaviourTree or its root)
    aim for or must reach: their :data:`PRESSURE_TARGETS` and :data:`FORCE_TARGETS` parameters,
    as set when the mission starts. A servo leaf whose rows leave out the normal (``vz``, row 2)
    holds no pressure, whatever its ``target_pa``."""
    root = getattr(tree, "root", tree)
    pressures, forces = [], []
    for node in root.iterate():
        rows = getattr(node, "rows", None)
        if rows is not None and 2 not in rows:
            continue
        for names, out in ((PRESSURE_TARGETS, pressures), (FORCE_TARGETS, forces)):
            for name in names:
                value = getattr(node, name, None)
                if isinstance(value, (int, float)) and math.isfinite(value) and value > 0:
                    out.append(float(value))
    return pressures, forces


@dataclass
class Intervention:
    """One intervention: from the first cycle above a limit until ``clear_s`` within all.

    Attributes
    ----------
    limit : str
        ``"pressure"`` or ``"force"``: the limit that started it.
    start_s, end_s : float
        Mission time of its first and last cycle above a limit (s).
    retreat_s : float
        Time the supervisor's retreat commands were in force in it (s): each lasts until the
        next check.
    peak : float
        Highest value of the limited quantity in it (Pa or N).
    """

    limit: str
    start_s: float
    end_s: float
    retreat_s: float = 0.0
    peak: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


_UNITS = {"pressure": "Pa", "force": "N"}
#: Slack on sums of cycle times (s): 125 cycles of 4 ms make 0.5 s, not a hair less.
_TIME_EPS = 1e-9


@dataclass
class _Peaks:
    pressure_pa: float = 0.0
    force_n: float = 0.0


class Supervisor:
    """Checks every cycle's twist before the mount gets it (see the module's docstring).

    Parameters
    ----------
    limits : SupervisorLimits
    publish : callable(retreating, reason), optional
        Tells the tree; default: the ``/supervisor`` blackboard keys
        (:func:`tactile_bt.tree.behaviours.supervision.publish_supervision`). Called once here
        (not retreating) and then only when the state changes.

    Attributes
    ----------
    outcome : tuple of (str, str) or None
        ``("failure", reason)`` once the supervisor has ended the mission, else None.
    interventions : list of Intervention
        Every intervention so far, the one under way last.
    last_command : numpy.ndarray
        The last sensor-frame twist it let through or gave (zero after :meth:`stop`).
    """

    def __init__(self, limits: SupervisorLimits | None = None,
                 publish: Callable[[bool, str], None] = publish_supervision) -> None:
        self.limits = SupervisorLimits() if limits is None else limits
        self._publish = publish
        self._retreat = np.array([0.0, 0.0, -self.limits.retreat_speed_mps, 0.0, 0.0, 0.0])
        self.outcome: tuple[str, str] | None = None
        self.interventions: list[Intervention] = []
        self._current: Intervention | None = None
        self._clear_since: float | None = None
        self._t_prev = 0.0
        self._retreated: Intervention | None = None  # the intervention of last cycle's retreat
        self._two_regions_at = -math.inf  # when the pad last bore more than one contact region
        self._other_xy = (math.nan, math.nan)  # where the other regions' centre was then (m, sensor frame)
        self.peaks = _Peaks()
        self.last_command = np.zeros(6)
        publish(False, "")

    @property
    def retreating(self) -> bool:
        """Whether an intervention is under way."""
        return self._current is not None

    def check(self, features, pose: np.ndarray, twist_s: np.ndarray, t: float, frame_time: float | None = None,
              pose_time: float | None = None) -> np.ndarray:
        """The sensor-frame twist to send for this cycle.

        Parameters
        ----------
        features : ContactFeatures
            The cycle's smoothed features (``pressure`` in Pa, ``force`` in N).
        pose : (4, 4) array
            ``T_gs``, the pad's pose in the base frame (m).
        twist_s : (6,) array
            The tree's command ``[vx, vy, vz, wx, wy, wz]``, sensor frame (m/s, rad/s).
        t : float
            Mission time of the cycle (s).
        frame_time, pose_time : float, optional
            Live missions: when the newest sensor frame arrived and when the pose was measured,
            on the mission clock (s); None skips the check (simulation).

        Returns
        -------
        (6,) array
            ``twist_s`` unchanged within every limit; the retreat ``[-v x/h, -v y/h, -v, 0, 0, 0]``
            while a force or pressure limit is exceeded (``v`` the retreat speed, the normal part
            the tree's own ``-vz`` when larger; ``(x, y)`` the centre of pressure and ``h`` half the
            pad's width, m; the slide less its part towards another region, see
            :meth:`_slide_away`); zero once the supervisor has ended the mission.
        """
        if self._retreated is not None:  # the retreat sent last cycle lasted until now
            self._retreated.retreat_s += t - self._t_prev
            self._retreated = None
        self._t_prev = t
        if self.outcome is not None:
            return self._send(np.zeros(6))
        fault = self._hardware_fault(pose, t, frame_time, pose_time)
        if fault:
            self._end(fault)
            return self._send(np.zeros(6))
        pressure, force = features.pressure, features.force
        if features.in_contact and features.others_tactels > 0:
            self._two_regions_at = t
            self._other_xy = features.pad.xy_px_to_m(*features.others_cop_px)
        peaks = self.peaks
        if pressure > peaks.pressure_pa:
            peaks.pressure_pa = pressure
        if force > peaks.force_n:
            peaks.force_n = force
        limits = self.limits
        if pressure > limits.pressure_limit_pa:
            limit, value = "pressure", pressure
        elif force > limits.force_limit_n:
            limit, value = "force", force
        else:
            self._within(t)
            return self._send(twist_s)
        return self._send(self._exceeded(limit, value, t, float(twist_s[2]), features))

    def stop(self) -> np.ndarray:
        """The last command of a mission, on every way out: a zero twist."""
        return self._send(np.zeros(6))

    def summary(self) -> dict:
        """What report.json shows under ``supervisor``: the limits, how often and how long the
        supervisor intervened, the peaks it saw and, when it ended the mission, why."""
        runs = self.interventions
        return {
            "limits": self.limits.to_dict(),
            "interventions": len(runs),
            "retreat_time_s": float(sum(r.retreat_s for r in runs)),
            "longest_intervention_s": float(max((r.end_s - r.start_s for r in runs), default=0.0)),
            "peak_pressure_pa": float(self.peaks.pressure_pa),
            "peak_force_n": float(self.peaks.force_n),
            "ended_mission": "" if self.outcome is None else self.outcome[1],
            "runs": [r.to_dict() for r in runs[:REPORTED_INTERVENTIONS]],
        }

    # --- the steps of a check ---------------------------------------------------------------

    def _send(self, twist: np.ndarray) -> np.ndarray:
        self.last_command = twist
        return twist

    def _within(self, t: float) -> None:
        """Every value within its limit: end the intervention under way after ``clear_s``."""
        if self._current is None:
            return
        if self._clear_since is None:
            self._clear_since = t
        elif t - self._clear_since >= self.limits.clear_s:
            self._current = None
            self._publish(False, "")

    def _exceeded(self, limit: str, value: float, t: float, tree_vz: float = 0.0, features=None) -> np.ndarray:
        """A limit exceeded: retreat, or end the mission once the grace time is over. A tree
        already backing off along the normal faster than the retreat keeps its speed (``tree_vz``,
        m/s): the supervisor never slows a retreat down. A contact off the pad's centre
        (the ``features``' centre of pressure) adds a slide away from it, in the pad's plane, as
        much faster as the contact is nearer the border: an object pressing on the pad's border
        may lie beside it, where backing off along the normal alone drags the border along it,
        and a corner meeting a side steep to the pad is freed by the slide, hardly by the normal.
        With another contact region under the pad (a pad bridging a groove or a ring's hole), or
        seen there within ``defaults.SUPERVISOR_BRIDGE_MEMORY_S`` (a pad rocking from rim to rim
        bears one at a time), sliding towards it would press it: the slide keeps only its part
        across the line to that region's centre (none for rims on opposite borders; none when
        where it lies is unknown)."""
        unit = _UNITS[limit]
        bound = getattr(self.limits, f"{limit}_limit_{unit.lower()}")
        run = self._current
        if run is None:
            run = self._current = Intervention(limit, t, t)
            self.interventions.append(run)
            self._publish(True, f"{limit} {value:.4g} {unit} above the limit {bound:.4g} {unit} at {t:.2f} s")
        self._clear_since = None
        run.end_s = t
        if value > run.peak:
            run.peak = value
        if run.retreat_s >= self.limits.grace_s - _TIME_EPS:
            self._end(f"{limit} limit: {value:.4g} {unit} above {bound:.4g} {unit} at {t:.2f} s, above a limit "
                      f"for {run.retreat_s:.2f} s in all, the pad pulled back, in the {t - run.start_s:.2f} s "
                      f"since the intervention began at {run.start_s:.2f} s")
            return np.zeros(6)
        self._retreated = run
        retreat = self._retreat.copy()
        if tree_vz < retreat[2]:
            retreat[2] = tree_vz
        if features is not None and features.in_contact:
            retreat[0], retreat[1] = self._slide_away(features, t)
        return retreat

    def _slide_away(self, features, t: float) -> tuple[float, float]:
        """The retreat's slide in the pad's plane (m/s, sensor frame): away from the contact's
        centre of pressure, at the retreat speed times its distance from the centre over half the
        pad's width, less its part towards another region seen within
        ``defaults.SUPERVISOR_BRIDGE_MEMORY_S`` (zero when where that lies is unknown)."""
        x, y = features.cop_xy
        half = 0.5 * min(features.pad.size_m)
        if not (math.isfinite(x) and math.isfinite(y) and half > 0):
            return 0.0, 0.0
        speed = self.limits.retreat_speed_mps
        sx, sy = -x / half * speed, -y / half * speed
        if t - self._two_regions_at > defaults.SUPERVISOR_BRIDGE_MEMORY_S:
            return sx, sy
        ux, uy = self._other_xy[0] - x, self._other_xy[1] - y
        n = math.hypot(ux, uy)
        if not n > 0:
            return 0.0, 0.0
        ux, uy = ux / n, uy / n
        towards = sx * ux + sy * uy
        if towards > 0:
            sx, sy = sx - towards * ux, sy - towards * uy
        return sx, sy

    def _end(self, why: str) -> None:
        self.outcome = ("failure", f"supervisor: {why}")
        self._publish(True, why)

    def _hardware_fault(self, pose, t: float, frame_time, pose_time) -> str:
        """What stops a live mission at once ("" when nothing does)."""
        limits = self.limits
        if frame_time is not None and t - frame_time > limits.sensor_silence_s:
            return (f"sensor silent: no frame for {(t - frame_time) * 1e3:.0f} ms (limit "
                    f"{limits.sensor_silence_s * 1e3:.0f} ms) at {t:.2f} s")
        if pose_time is not None and t - pose_time > limits.pose_stale_s:
            return (f"stale robot pose: {(t - pose_time) * 1e3:.0f} ms old (limit {limits.pose_stale_s * 1e3:.0f} ms) "
                    f"at {t:.2f} s")
        lo, hi = limits.workspace_min_m, limits.workspace_max_m
        if lo is not None:
            p = pose[:3, 3]
            if not all(a <= x <= b for a, x, b in zip(lo, p, hi)):
                return (f"pose outside the workspace: the pad at {_mm(p)} mm, the box {_mm(lo)} to {_mm(hi)} mm "
                        f"at {t:.2f} s")
        return ""


def _mm(v) -> str:
    """A point in metres as ``[x, y, z]`` in whole millimetres."""
    return "[" + ", ".join(f"{1e3 * x:.0f}" for x in v) + "]"
