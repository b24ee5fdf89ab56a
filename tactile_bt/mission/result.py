"""What a mission leaves, and the one place where a run (simulated or replayed) is wrapped up.

:func:`finish_mission` turns a control loop's log and contact cloud into a
:class:`MissionResult`: the typed :class:`~tactile_bt.mission.report.MissionReport` with the
paper's metrics, the path error on a known cable, the scan's accuracy, and the "no contact was
made" rule. :func:`tactile_bt.mission.run.run_mission` and
:func:`tactile_bt.mission.replay.replay_mission` both end through it.

Layer: mission.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tactile_bt.mission.joints import held_at_end, saturation_runs, saturation_warnings
from tactile_bt.mission.loop import running_reason
from tactile_bt.mission.metrics import controlled_feature_metrics, force_figures, path_error
from tactile_bt.mission.report import FeatureMetrics, MissionReport

__all__ = ["MissionResult", "finish_mission"]


@dataclass
class MissionResult:
    """What a mission leaves: the report, every logged series and the recorded contacts.

    Attributes
    ----------
    summary : MissionReport
        The typed report; :attr:`report` is its dict, the content of ``report.json``.
    log : dict of numpy arrays
        Time series keyed by name, all with the ``t`` array's length, and the tree's nodes:
        ``node_names``, ``node_depth`` (one per node) and ``node_status`` (ticks × nodes;
        :mod:`tactile_bt.mission.node_status`).
    contact_data : (N, 8) array
        World points (m), outward surface normals, pressure (Pa) and mission time (s) of every
        sample ``record_contacts`` took.
    surface : trimesh.Trimesh or None
        The surface reconstructed from the contacts (world frame, m), when the tree or the run
        asked for one (``record_contacts: {reconstruct: ...}`` or ``run_mission(reconstruct=...)``).
    """

    summary: MissionReport
    log: dict
    contact_data: np.ndarray = field(default_factory=lambda: np.zeros((0, 8)))
    surface: object = None

    @property
    def report(self) -> dict:
        """The report as a dict: the same content as ``report.json``."""
        return self.summary.to_dict()

    @property
    def contacts(self) -> np.ndarray:
        """``(N, 6)`` world points (m) and outward surface normals of the contact cloud."""
        return self.contact_data[:, :6]

    def plot(self, path: str | Path | None = None):
        """Feature errors against mission time (paper Figs. 8–10, 12b); saved when ``path``."""
        from tactile_bt.mission.outputs import plot_errors

        return plot_errors(self, path)

    def save(self, out: str | Path) -> None:
        """Write report.json, log.npz, errors.png and contacts.ply into ``out``; for a scan
        also surface.ply and render.png."""
        from tactile_bt.mission.outputs import write_outputs

        write_outputs(self, Path(out))


def _frontier_left(tree) -> dict | None:
    """The frontier left by the tree's frontier planner (a leaf with ``frontier_left``), if it
    has planned at all."""
    for node in tree.root.iterate():
        left = getattr(node, "frontier_left", None)
        if callable(left) and getattr(node, "left", None):
            return left()
    return None


def finish_mission(tree, log, contacts, status: str, reason: str, wall_start: float, sim_time_s: float, *,
                   scene=None, seed: int | None = None, recording: str | None = None,
                   warnings: list[str] | tuple = (), scan: dict | None = None, pad=None,
                   supervision: dict | None = None) -> MissionResult:
    """Wrap up a run: metrics, report, path error and scan accuracy.

    Parameters
    ----------
    tree : py_trees.trees.BehaviourTree
    log : MissionLog
    contacts : ContactCloud
    status, reason : str
        How the loop ended (``completed`` when the budget ran out). A run that ``completed``
        without a single cycle in contact becomes ``failure: no contact was made``.
    wall_start : float
        ``time.perf_counter()`` when the loop started.
    sim_time_s : float
        Mission time covered (s).
    scene : Scene or str, optional
        The simulated scene (its cable gives the path error, its object the scan accuracy), or
        the scene file a recording names.
    seed : int, optional
    recording : str, optional
        The recording a replay ran on.
    warnings : list of str
        What the run itself noticed; the joint-limit warnings of an arm's log (the runs of
        ``joint_saturated``, :mod:`tactile_bt.mission.joints`) are appended.
    scan : dict, optional
        Reconstruction method and region (``scan_settings``) of a scan.
    pad : PadGeometry, optional
        The pad whose centre-of-pressure log is carried to the world for ``path_error_cop_m``
        (default: the scene's).
    supervision : dict, optional
        What the supervisor did (:meth:`~tactile_bt.mission.supervisor.Supervisor.summary`),
        the report's ``supervisor`` entry.
    """
    wall = time.perf_counter() - wall_start
    arrays = log.arrays()
    runs = _joint_limit_runs(arrays, log, scene)
    warnings = [*warnings, *saturation_warnings(runs)]
    if status == "failure" and runs and (held := held_at_end(runs, float(sim_time_s))):
        reason = f"{reason}; {held}"
    if status == "completed" and not np.any(arrays["in_contact"] == 1):
        status, reason = "failure", "no contact was made"
    elif status == "completed" and not reason:  # a task that had not ended says what it was doing
        reason = running_reason(tree.root, round(float(sim_time_s), 6))
    scene_file = getattr(scene, "file", scene) or ""
    summary = MissionReport(
        tree=str(getattr(tree, "source", getattr(tree.root, "name", "tree"))),
        # absolute, so that `tactile-bt view DIR` finds the scene from any directory
        scene=str(Path(scene_file).resolve()) if scene_file else "",
        seed=seed,
        status=status,
        reason=reason,
        sim_time_s=float(sim_time_s),
        wall_time_s=wall,
        real_time_factor=sim_time_s / wall if wall > 0 else float("inf"),
        ticks=log.n,
        metrics={k: FeatureMetrics(**m) for k, m in controlled_feature_metrics(arrays).items()},
        contacts=len(contacts),
        warnings=list(warnings),
        rate_hz=getattr(scene, "rate_hz", None),
        recording=None if recording is None else str(recording),
        supervisor=supervision,
        frontier=_frontier_left(tree),
        force=_force_report(tree, arrays),
        table=_table_report(tree),
    )
    cable = getattr(scene, "cable", None)
    if cable is not None:
        summary.path_error_m = path_error(contacts.points[:, :2], cable)
        # The same for the plain centre of pressure of every cycle in contact, for comparison.
        touching = (arrays["in_contact"] == 1) & np.isfinite(arrays["cop_x_px"])
        if touching.any():
            pad = pad if pad is not None else scene.sensor.geometry
            c = pad.px_to_m(np.stack((arrays["cop_x_px"], arrays["cop_y_px"]), axis=1)[touching])
            R = arrays["rotation"][touching]
            world = np.einsum("nij,nj->ni", R[:, :, :2], c) + arrays["position_m"][touching]
            cop_error = path_error(world[:, :2], cable)
            summary.path_error_cop_m = {"mean": cop_error["mean"], "max": cop_error["max"]}
    surface = None
    if scan is not None and len(contacts):
        from tactile_bt.mission.accuracy import contact_continuity, evaluate_scan

        try:
            surface, figures = evaluate_scan(scene, contacts.data, scan["method"], scan["region"])
        except Exception as exc:  # a failed reconstruction must not lose the mission's outputs
            figures = {"method": scan["method"], "error": f"{type(exc).__name__}: {exc}"}
        figures.update(contact_continuity(arrays["t"], arrays["in_contact"]))
        summary.reconstruction = figures
    return MissionResult(summary=summary, log=arrays, contact_data=contacts.data.copy(), surface=surface)


def _summaries(tree, kind: type) -> dict | list | None:
    """The ``summary()`` of the tree's leaves of type ``kind``: one leaf's dict, a list for
    several, None for none."""
    root = getattr(tree, "root", tree)
    found = [node.summary() for node in root.iterate() if isinstance(node, kind)]
    if not found:
        return None
    return found[0] if len(found) == 1 else found


def _force_report(tree, arrays: dict) -> dict:
    """The report's ``force``: the force figures of the log, and the estimate and target of the
    tree's ``adapt_force_target`` leaves (one: a dict; several: a list)."""
    from tactile_bt.tree.behaviours.stiffness import AdaptForceTarget

    force = force_figures(arrays)
    adapters = _summaries(tree, AdaptForceTarget)
    if adapters is not None:
        force["stiffness"] = adapters
    return force


def _table_report(tree) -> dict | list | None:
    """The report's ``table``: what the tree's ``table_clearance`` guards saw and did
    (:meth:`~tactile_bt.tree.behaviours.table.TableClearance.summary`; one: a dict, several: a
    list, none: None)."""
    from tactile_bt.tree.behaviours.table import TableClearance

    return _summaries(tree, TableClearance)


def _joint_limit_runs(arrays: dict, log, scene) -> list:
    """The runs in which the arm held a joint on its limit (none without an arm)."""
    saturated = arrays.get("joint_saturated")
    t = arrays["t"]
    if saturated is None or not saturated.any():
        return []
    rate = getattr(scene, "rate_hz", None)
    dt = 1.0 / rate if rate else float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    limits = getattr(log, "joint_limits", None) or (None, None)
    return saturation_runs(t, saturated, dt, residual=arrays.get("rate_residual"), joints=arrays.get("joints_rad"),
                           q_min=limits[0], q_max=limits[1])
