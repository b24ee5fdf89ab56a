"""Joint-limit warnings: the runs of cycles in which the arm held a joint on its limit.

Each cycle the mission logs which joints the arm's resolved-rate solve saturated (held at the
velocity that stops them on a position limit, ``joint_saturated`` in log.npz) and the part of
the commanded pad twist it could not realise (``rate_residual``: commanded minus realised hybrid
twist of the pad centre, m/s and rad/s in the world frame).  :func:`saturation_runs` finds, per
joint, the spans of consecutive saturated cycles and :func:`saturation_warnings` words them for
the report, e.g.

    joint 4 at its upper limit (+120°) from 3.21 s to 11.40 s (8.19 s); largest task-space error
    meanwhile 14.8 mm / 2.1°

Rules
-----
* A joint that leaves its limit for less than ``max_gap_s`` (0.1 s) stays in the same run, so a
  joint chattering on its stop gives one warning.
* Runs shorter than ``min_duration_s`` (0.1 s, 25 cycles at 250 Hz) are ignored: a joint that
  touches its limit for a few cycles costs the task nothing measurable.
* The task-space error of a run is the first-order distance between where the commanded motion
  would have taken the pad and where the arm's (equilibrium) motion took it: the residual twist
  integrated from the start of the run, ``e(t) = sum r_k dt``, its largest norm over the run,
  translation (mm) and rotation (degrees) separately.  It counts every shortfall of the solve
  during the span (the saturated joint, the damping near a singularity, the velocity scaling);
  it does not include the deflection of the compliant joints by the contact forces, which is
  the same with or without the limit.
* At most :data:`MAX_RUNS_PER_JOINT` runs per joint are listed; one more line sums up the rest.
* A mission that fails names in its reason the joints held on a limit during its last
  :data:`HELD_AT_END_S` (:func:`held_at_end`): a saturated joint keeps the pad from going where
  the tree sends it, which is what a follow then reports lost or stalled.

Layer: mission.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["SaturationRun", "saturation_runs", "saturation_warnings", "held_at_end", "MAX_RUNS_PER_JOINT",
           "HELD_AT_END_S"]

#: Runs listed per joint before the rest is summed up in one line.
MAX_RUNS_PER_JOINT = 5
#: A run that lasted into this last stretch of a failed mission is named in its reason (s): about
#: the time a follow takes to notice that the pad makes no headway.
HELD_AT_END_S = 5.0


@dataclass(frozen=True)
class SaturationRun:
    """One span in which a joint sat on its limit.

    Attributes
    ----------
    joint : int
        Joint number, 1-based (joint 4 is the LWR's elbow).
    start_s, end_s : float
        Mission time at the start of the first saturated cycle and at the end of the last (s).
    error_m, error_rad : float
        Largest task-space error during the run (module docstring); NaN when no residual was logged.
    side : int
        +1 on the upper limit, -1 on the lower, 0 when the joint angles are unknown.
    limit_rad : float
        The limit's angle (rad), NaN when unknown.
    """

    joint: int
    start_s: float
    end_s: float
    error_m: float = float("nan")
    error_rad: float = float("nan")
    side: int = 0
    limit_rad: float = float("nan")

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def message(self) -> str:
        """The warning's text."""
        where = {1: "upper ", -1: "lower ", 0: ""}[self.side]
        value = "" if not math.isfinite(self.limit_rad) else f" ({math.degrees(self.limit_rad):+.0f}°)"
        text = (f"joint {self.joint} at its {where}limit{value} from {self.start_s:.2f} s to {self.end_s:.2f} s "
                f"({self.duration_s:.2f} s)")
        if math.isfinite(self.error_m):
            text += (f"; largest task-space error meanwhile {self.error_m * 1e3:.1f} mm / "
                     f"{math.degrees(self.error_rad):.1f}°")
        return text


def _spans(flags: np.ndarray, max_gap: int) -> list[tuple[int, int]]:
    """``(first, last)`` cycle of each run of True, runs closer than ``max_gap`` False cycles merged."""
    padded = np.concatenate(([False], flags, [False]))
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    spans: list[tuple[int, int]] = []
    for first, end in zip(edges[::2], edges[1::2]):
        if spans and first - spans[-1][1] - 1 < max_gap:
            spans[-1] = (spans[-1][0], int(end) - 1)
        else:
            spans.append((int(first), int(end) - 1))
    return spans


def saturation_runs(t, saturated, dt: float, residual=None, joints=None, q_min=None, q_max=None,
                    min_duration_s: float = 0.1, max_gap_s: float = 0.1) -> list[SaturationRun]:
    """The runs of saturated cycles of every joint, in order of start time.

    Parameters
    ----------
    t : (n,) array
        Mission time of each cycle (s).
    saturated : (n, J) bool array
        Joints held on a limit in each cycle.
    dt : float
        Control period (s).
    residual : (n, 6) array, optional
        Unrealised hybrid twist per cycle (m/s, rad/s), for the task-space error.
    joints : (n, J) array, optional
        Joint angles (rad) with ``q_min``, ``q_max`` ((J,) rad): which limit, and its angle.
    min_duration_s, max_gap_s : float
        Shortest run reported, longest gap bridged (s); see the module docstring.
    """
    t = np.asarray(t, float)
    sat = np.asarray(saturated, bool)
    if sat.ndim != 2 or sat.shape[0] != t.shape[0]:
        raise ValueError(f"saturated must be (n, joints) with n = {t.shape[0]}, got {sat.shape}")
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    max_gap = int(round(max_gap_s / dt))
    runs = []
    for j in range(sat.shape[1]):
        for first, last in _spans(sat[:, j], max_gap):
            if (last - first + 1) * dt < min_duration_s - 1e-9:
                continue
            err_m = err_rad = float("nan")
            if residual is not None:
                e = np.cumsum(np.asarray(residual, float)[first:last + 1], axis=0) * dt
                err_m = float(np.max(np.linalg.norm(e[:, :3], axis=1)))
                err_rad = float(np.max(np.linalg.norm(e[:, 3:], axis=1)))
            side, limit = 0, float("nan")
            if joints is not None and q_min is not None and q_max is not None:
                q = float(np.mean(np.asarray(joints)[first:last + 1, j]))
                lo, hi = float(q_min[j]), float(q_max[j])
                side, limit = (1, hi) if hi - q < q - lo else (-1, lo)
            runs.append(SaturationRun(j + 1, float(t[first]), float(t[last]) + dt, err_m, err_rad, side, limit))
    runs.sort(key=lambda r: (r.start_s, r.joint))
    return runs


def saturation_warnings(runs: list[SaturationRun], max_per_joint: int = MAX_RUNS_PER_JOINT) -> list[str]:
    """One warning per run, at most ``max_per_joint`` per joint and a line summing up the rest."""
    out, listed, rest = [], {}, {}
    for run in runs:
        n = listed.get(run.joint, 0)
        if n < max_per_joint:
            out.append(run.message())
            listed[run.joint] = n + 1
        else:
            count, total = rest.get(run.joint, (0, 0.0))
            rest[run.joint] = (count + 1, total + run.duration_s)
    for joint, (count, total) in sorted(rest.items()):
        out.append(f"joint {joint} at its limit {count} more times ({total:.2f} s in all)")
    return out


def held_at_end(runs: list[SaturationRun], end_s: float, within_s: float = HELD_AT_END_S) -> str:
    """The joints on a limit during the last ``within_s`` before ``end_s`` (s), worded for a
    failed mission's reason ("joint 4 held at its upper limit (+120°) since 7.63 s"); "" when none."""
    held = {}
    for run in runs:
        if run.end_s >= end_s - within_s:
            held.setdefault(run.joint, run)
    parts = []
    for joint, run in sorted(held.items()):
        where = {1: "upper ", -1: "lower ", 0: ""}[run.side]
        value = "" if not math.isfinite(run.limit_rad) else f" ({math.degrees(run.limit_rad):+.0f}°)"
        parts.append(f"joint {joint} held at its {where}limit{value} since {run.start_s:.2f} s")
    return "; ".join(parts)
