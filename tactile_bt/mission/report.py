"""The typed mission report: what ``report.json`` holds, for missions and replays alike.

:class:`MissionReport` is the one description of a run's outcome: the command line prints it, the
output writer saves it (:meth:`MissionReport.to_dict` gives the JSON), the view and the studies
read it back (:meth:`MissionReport.load`). ``MissionResult.report`` is its dict, as
docs/architecture.md promises users.

Layer: mission.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from tactile_bt.contacts.frontier_map import describe_left
from tactile_bt.sim.region import describe_region

__all__ = ["FeatureMetrics", "MissionReport", "OK_STATUSES"]

#: Statuses of a run that did what it was asked (the CLI's exit code 0).
OK_STATUSES = ("success", "completed")


#: The unit of a metric from its name's suffix (``pressure_pa`` → Pa).
_METRIC_UNITS = {"pa": "Pa", "px": "px", "rad": "rad"}


def _number(value: Any) -> float:
    """JSON stores NaN and inf as null: read null back as NaN."""
    return float("nan") if value is None else float(value)


@dataclass
class FeatureMetrics:
    """The paper's Table I–III columns for one controlled feature (units of the feature:
    Pa, px or rad; times in s)."""

    steady_state_error: float
    std: float
    response_time_s: float
    band: float
    start_s: float
    window_s: float

    @classmethod
    def from_dict(cls, d: dict) -> "FeatureMetrics":
        return cls(**{f.name: _number(d.get(f.name)) for f in fields(cls)})

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass
class MissionReport:
    """Outcome of one mission or replay.

    Attributes
    ----------
    tree, scene : str
        The tree file (or root name) and the scene file (absolute path; empty for a replay of a
        live recording).
    seed : int or None
    status : str
        ``success`` or ``failure`` (the tree's root ended), ``completed`` (the budget ran out),
        ``interrupted`` (Ctrl-C) or ``error``.
    reason : str
        Why a run failed, e.g. ``"follow: contact lost"`` or ``"no contact was made"``.
    sim_time_s, wall_time_s, real_time_factor : float
        Mission time (s), wall-clock time (s) and their ratio.
    ticks : int
        Control cycles run.
    metrics : dict of FeatureMetrics
        One entry per controlled feature (``pressure_pa``, ``cop_x_px``, ``cop_y_px``,
        ``orientation_rad``).
    contacts : int
        Samples in the contact cloud.
    warnings : list of str
        What the user should know about the run (a torn recording, a saturated joint, ...).
    rate_hz : float, optional
        Control rate of a simulated mission.
    recording : str, optional
        The recording a replay ran on.
    path_error_m, path_error_cop_m : dict, optional
        Distance of the recorded contacts (and of the plain centres of pressure) from a cable's
        true centreline (m): ``mean``, ``max``, ...
    reconstruction : dict, optional
        Reconstruction and accuracy figures of a scan (:mod:`tactile_bt.mission.accuracy`).
    supervisor : dict, optional
        The supervisor's limits, how often and how long it intervened, the peak pressure and
        force it saw and why it ended the mission, if it did
        (:meth:`tactile_bt.mission.supervisor.Supervisor.summary`).
    frontier : dict, optional
        The frontier a scan left, in m by reason: ``explained`` (the table, the tilt limit) and
        ``unexplained`` (an edge, a stall, ..., "" for frontier never tried)
        (:meth:`tactile_bt.tree.behaviours.frontier.FrontierGuidance.frontier_left`).
    force : dict, optional
        How hard the mission pressed after its approach
        (:func:`tactile_bt.mission.metrics.force_figures`) and, under ``stiffness``, the contact
        stiffness an ``adapt_force_target`` leaf estimated and the target it adapted
        (:meth:`tactile_bt.tree.behaviours.stiffness.AdaptForceTarget.summary`).
    table : dict or list, optional
        What the tree's ``table_clearance`` guard saw and did over the mission: the share of
        cycles its brake slowed, its trips, the time it lifted the pad (s) and the lowest
        clearance of the pad's lowest corner above the table (m)
        (:meth:`tactile_bt.tree.behaviours.table.TableClearance.summary`; a list for several).
    realtime : dict, optional
        A live mission's real-time figures: latency (frame arrival to twist sent), cycle period,
        jitter and work per cycle as percentiles in ms, cycles over budget
        (:func:`tactile_bt.mission.live.realtime_summary`).
    """

    tree: str
    scene: str
    seed: int | None
    status: str
    reason: str
    sim_time_s: float
    wall_time_s: float
    real_time_factor: float
    ticks: int
    metrics: dict[str, FeatureMetrics]
    contacts: int
    warnings: list[str] = field(default_factory=list)
    rate_hz: float | None = None
    recording: str | None = None
    path_error_m: dict | None = None
    path_error_cop_m: dict | None = None
    reconstruction: dict | None = None
    supervisor: dict | None = None
    realtime: dict | None = None
    frontier: dict | None = None
    force: dict | None = None
    table: dict | list | None = None

    #: Key order of report.json.
    ORDER = ("tree", "recording", "scene", "seed", "status", "reason", "warnings", "rate_hz", "sim_time_s",
             "wall_time_s", "real_time_factor", "ticks", "metrics", "contacts", "path_error_m",
             "path_error_cop_m", "reconstruction", "frontier", "supervisor", "force", "table", "realtime")

    @property
    def ok(self) -> bool:
        """Whether the run did what it was asked (``success`` or ``completed``)."""
        return self.status in OK_STATUSES

    def to_dict(self) -> dict:
        """The content of report.json (optional entries only when present)."""
        out = {}
        for name in self.ORDER:
            value = getattr(self, name)
            if value is None and name in ("rate_hz", "recording", "path_error_m", "path_error_cop_m",
                                          "reconstruction", "frontier", "supervisor", "force", "table",
                                          "realtime"):
                continue
            if name == "metrics":
                value = {k: m.to_dict() for k, m in value.items()}
            elif name == "warnings":
                value = list(value)
            out[name] = value
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "MissionReport":
        """The report of a report.json's content (nulls of NaN figures read back as NaN)."""
        known = {f.name for f in fields(cls)}
        kwargs = {k: v for k, v in d.items() if k in known}
        kwargs["metrics"] = {k: FeatureMetrics.from_dict(m) for k, m in d.get("metrics", {}).items()}
        for name in ("sim_time_s", "wall_time_s", "real_time_factor"):
            kwargs[name] = _number(d.get(name))
        kwargs.setdefault("warnings", [])
        return cls(**kwargs)

    @classmethod
    def load(cls, path: str | Path) -> "MissionReport":
        """Read ``report.json`` (or the one in the output directory ``path``)."""
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file or directory (expected the output directory of "
                                    "'tactile-bt run' or its report.json)")
        if path.is_dir():
            path = path / "report.json"
            if not path.exists():
                raise FileNotFoundError(f"{path} not found: is {path.parent} the output of 'tactile-bt run'?")
        return cls.from_dict(json.loads(path.read_text()))

    def summary_lines(self) -> list[str]:
        """The lines the command line prints after a run."""
        lines = []
        for name, m in self.metrics.items():
            if math.isfinite(m.response_time_s):
                lines.append(f"  {name:16s} steady-state {m.steady_state_error:+.4g}  std {m.std:.4g}  "
                             f"response {m.response_time_s:.2f} s")
            else:  # controlled, but its error never stayed in the band: no figures to give
                unit = _METRIC_UNITS.get(name.rsplit("_", 1)[-1], "")
                lines.append(f"  {name:16s} never settled within ±{m.band:.3g} {unit} in {m.window_s:.2f} s "
                             "of control")
        if self.path_error_m and math.isfinite(self.path_error_m.get("mean", float("nan"))):
            p = self.path_error_m
            lines.append(f"  path error       mean {p['mean'] * 1e3:.2f} mm  max {p['max'] * 1e3:.2f} mm  "
                         f"followed {p['followed_m'] * 1e3:.0f} of {p['cable_length_m'] * 1e3:.0f} mm")
        rec = self.reconstruction
        if rec and rec.get("chamfer_m") is not None and math.isfinite(rec["chamfer_m"]):
            lines.append(f"  reconstruction   {rec['method']}, {rec['points']} contacts: chamfer "
                         f"{rec['chamfer_m'] * 1e3:.2f} mm, Hausdorff {rec['hausdorff_m'] * 1e3:.2f} mm, "
                         f"coverage {rec['coverage']:.3f} of {describe_region(rec.get('region'))}")
        if self.frontier:
            lines.append(f"  frontier left    {describe_left(self.frontier)}")
        sup = self.supervisor
        if sup and sup.get("interventions"):
            n = sup["interventions"]
            lines.append(f"  supervisor       {n} intervention{'s' if n > 1 else ''}, "
                         f"{sup['retreat_time_s']:.2f} s retreating (longest {sup['longest_intervention_s']:.2f} s), "
                         f"peak {sup['peak_pressure_pa']:.0f} Pa, {sup['peak_force_n']:.1f} N")
        table = self.table
        if isinstance(table, dict) and table.get("lowest_clearance_m") is not None:
            lifted = f", lifted {table['lifted_s']:.2f} s" if table.get("lifted_s") else ""
            trips = table.get("trips", 0)
            lines.append(f"  table guard      lowest corner {table['lowest_clearance_m'] * 1e3:.1f} mm above the table, "
                         f"{trips} trip{'' if trips == 1 else 's'}{lifted}, braking "
                         f"{100 * table.get('braked_share', 0.0):.1f} % of cycles")
        force = self.force
        stiffness = (force or {}).get("stiffness") or {}
        if force and (not force.get("ok", True)
                      or stiffness.get("lowest_target_pa", math.inf) < stiffness.get("tree_target_pa", 0.0)):
            k = stiffness.get("stiffness_pa_per_m")
            adapted = (f"target {stiffness['target_pa']:.0f} of {stiffness['tree_target_pa']:.0f} Pa "
                       f"(stiffness {k:.3g} Pa/m), " if stiffness and k is not None else "")
            lines.append(f"  force            {adapted}longest above 2x target {force['longest_over_s']:.2f} s, "
                         f"peak {force['peak_force_n']:.1f} N")
        rt = self.realtime
        if rt:
            lines.append(f"  real time        latency p50 {rt['latency_ms']['p50']:.2f} ms, p99 {rt['latency_ms']['p99']:.2f} ms; "
                         f"period jitter p99 {rt['jitter_ms']['p99']:.2f} ms; {rt['over_budget']} of {rt['cycles']} "
                         "cycles over budget")
        return lines
