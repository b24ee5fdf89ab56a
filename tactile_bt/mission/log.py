"""The time series of a mission, preallocated and filled one control cycle at a time.

When the pad is on the arm, :meth:`MissionLog.track_joints` adds per-cycle series of the arm:
``joints_rad`` (actual joint angles, rad), ``joint_saturated`` (joints the resolved-rate solve
held on a position limit, bool) and ``rate_residual`` (commanded minus realised hybrid twist of
the pad centre, m/s and rad/s, world frame); :mod:`tactile_bt.mission.joints` turns the last two
into the report's joint-limit warnings. :meth:`MissionLog.track_nodes` adds the status of
every node of the tree per tick (``node_names``, ``node_depth``, ``node_status``;
:mod:`tactile_bt.mission.node_status`).

Layer: mission.
"""

from __future__ import annotations

import numpy as np

from tactile_bt import defaults
from tactile_bt.mission.node_status import NodeStatusLog

__all__ = ["MissionLog"]

_ERRORS = tuple(defaults.METRIC_BANDS)  # the logged error of every controllable feature


class MissionLog:
    """Preallocated per-cycle time series; :meth:`arrays` gives the rows written so far."""

    SCALARS = (
        "t",
        "in_contact",
        "force_n",
        "area",
        "pressure_raw_pa",
        "pressure_pa",
        "cop_x_px",
        "cop_y_px",
        "orientation_raw_rad",
        "orientation_rad",
        "penetration_m",
        *(f"error_{e}" for e in _ERRORS),
    )

    def __init__(self, n: int) -> None:
        self.n = 0
        self.scalars = {k: np.full(n, np.nan) for k in self.SCALARS}
        # The columns that every cycle writes, bound once (write() runs every control cycle).
        s = self.scalars
        self._columns = tuple(s[k] for k in ("t", "in_contact", "force_n", "area", "pressure_raw_pa", "pressure_pa",
                                             "cop_x_px", "cop_y_px", "orientation_raw_rad", "orientation_rad",
                                             "penetration_m"))
        self._error_columns = {e: s["error_" + e] for e in _ERRORS}
        self.twist = np.zeros((n, 6))
        self.position = np.zeros((n, 3))
        self.rotation = np.zeros((n, 3, 3))
        self.joints: np.ndarray | None = None  # (n, 7) rad, when the pad is on the arm
        self.joint_saturated: np.ndarray | None = None  # (n, 7) bool
        self.rate_residual: np.ndarray | None = None  # (n, 6) m/s, rad/s
        #: ``(q_min, q_max)`` of the arm's joints (rad), when they are tracked.
        self.joint_limits: tuple[np.ndarray, np.ndarray] | None = None
        #: Status of every node per tick, when tracked (:meth:`track_nodes`).
        self.nodes: NodeStatusLog | None = None

    def track_nodes(self, root) -> NodeStatusLog:
        """Log the status of every node under ``root`` (a py_trees behaviour) at every
        :meth:`write`; returns the node log."""
        self.nodes = NodeStatusLog(root, self.scalars["t"].shape[0])
        return self.nodes

    def track_joints(self, n_joints: int, limits: tuple | None = None) -> None:
        """Log the arm's joints as well (:meth:`write_joints`); ``limits``: ``(q_min, q_max)`` in rad."""
        n = self.scalars["t"].shape[0]
        self.joints = np.zeros((n, n_joints))
        self.joint_saturated = np.zeros((n, n_joints), dtype=bool)
        self.rate_residual = np.zeros((n, 6))
        if limits is not None:
            self.joint_limits = (np.asarray(limits[0], float).copy(), np.asarray(limits[1], float).copy())

    def write_joints(self, k: int, q, saturated=None, residual=None) -> None:
        """Store the arm's state of cycle ``k``: joint angles (rad), joints held on a limit, and
        the unrealised twist of the resolved-rate solve (m/s, rad/s)."""
        self.joints[k] = q
        if saturated is not None:
            self.joint_saturated[k] = saturated
        if residual is not None:
            self.rate_residual[k] = residual

    def write(self, k: int, t: float, loop, twist_s: np.ndarray, pose: np.ndarray,
               penetration: float = float("nan")) -> None:
        """Store cycle ``k`` (mission time ``t``) of a control loop."""
        f_raw, f = loop.features_raw, loop.features
        t_, in_contact, force, area, pressure_raw, pressure, cop_x, cop_y, orientation_raw, orientation, \
            penetration_ = self._columns
        t_[k] = t
        in_contact[k] = f_raw.in_contact
        force[k] = f_raw.force
        area[k] = f_raw.area
        pressure_raw[k] = f_raw.pressure
        pressure[k] = f.pressure
        cop_x[k], cop_y[k] = f_raw.cop_px.tolist()
        orientation_raw[k] = f_raw.orientation
        orientation[k] = f.orientation
        penetration_[k] = penetration
        columns = self._error_columns
        for name, value in loop.command.errors.items():
            columns[name][k] = value
        self.twist[k] = twist_s
        self.position[k] = pose[:3, 3]
        self.rotation[k] = pose[:3, :3]
        if self.nodes is not None:
            self.nodes.record(k)
        self.n = k + 1

    def arrays(self) -> dict[str, np.ndarray]:
        n = self.n
        out = {k: v[:n].copy() for k, v in self.scalars.items()}
        out["twist_s"] = self.twist[:n].copy()
        out["position_m"] = self.position[:n].copy()
        out["rotation"] = self.rotation[:n].copy()
        if self.joints is not None:
            out["joints_rad"] = self.joints[:n].copy()
            out["joint_saturated"] = self.joint_saturated[:n].copy()
            out["rate_residual"] = self.rate_residual[:n].copy()
        if self.nodes is not None:
            out.update(self.nodes.arrays())
        return out
