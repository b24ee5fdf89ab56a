"""Recovering a lost cable: the pad's recorded path and ``backtrack`` along it.

``cable_end`` records the pad pose ``T_gs`` (world frame) of the cycles it judged on the line in
a :class:`PadPath` on the blackboard, and writes a :class:`CableLoss` when it loses the line. The
tree composes the recovery (``trees/cable_follow.yaml``): a ``retry`` around a sequence of
``backtrack`` (back along the recorded path to where the line was followed), re-acquiring the
line (centring and edge alignment until both converge) and the follow itself, so the number of
attempts is the tree's.

Layer: tree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from py_trees.common import Access, Status

from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.blackboard import POSE, TIME, read, read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import POSITIVE, normalise_key

__all__ = ["Backtrack", "CableLoss", "PadPath"]


@dataclass(frozen=True)
class CableLoss:
    """Where and how the followed line was lost.

    Attributes
    ----------
    what : str
        How it was lost ("the line left the pad sideways").
    path_m : float
        Path length of the pad along the followed line when it was lost (m).
    time_s : float
        Mission time of the loss (s).
    message : str
        The full message ``cable_end`` ended with.
    """

    what: str
    path_m: float
    time_s: float
    message: str


class PadPath:
    """The pad's path along a followed line: its length and the poses of on-line cycles.

    ``length_m`` is the distance the pad centre travelled (world frame, m) while a follow ran,
    set back when ``backtrack`` returns along the path. Poses are kept every ``spacing_m``.
    """

    def __init__(self, spacing_m: float = 0.001) -> None:
        self.spacing_m = float(spacing_m)
        self.length_m = 0.0
        self._last: tuple[float, float, float] | None = None  # the last pad position seen (m, world)
        self._s: list[float] = []  # path length of each recorded pose (m)
        self._poses: list[np.ndarray] = []
        self.losses: list[CableLoss] = []

    def resume(self, pose: np.ndarray) -> None:
        """Start measuring travel from ``pose`` (a follow starts or restarts here)."""
        self._last = tuple(pose[:3, 3].tolist())

    def advance(self, pose: np.ndarray) -> None:
        """Add the travel from the last pose to ``pose`` to :attr:`length_m` (per cycle: Python floats)."""
        p = pose[:3, 3].tolist()
        if self._last is not None:
            self.length_m += math.dist(p, self._last)
        self._last = p

    def record(self, pose: np.ndarray) -> None:
        """Keep ``pose`` (an on-line cycle's) when the pad moved ``spacing_m`` since the last kept one."""
        if not self._s or self.length_m - self._s[-1] >= self.spacing_m:
            self._s.append(self.length_m)
            self._poses.append(np.array(pose, dtype=float))

    def lost(self, loss: CableLoss) -> None:
        """Note a loss of the line."""
        self.losses.append(loss)

    @property
    def resumed(self) -> bool:
        """Whether the line was lost before (the current follow is a re-acquired one)."""
        return bool(self.losses)

    @property
    def first_loss(self) -> str:
        """How and where the line was first lost, e.g. "the line left the pad sideways 212 mm
        along the path"; "" when it never was."""
        if not self.losses:
            return ""
        loss = self.losses[0]
        return f"{loss.what} {loss.path_m * 1e3:.0f} mm along the path"

    def back(self, distance_m: float) -> tuple[float, np.ndarray] | None:
        """The recorded pose ``distance_m`` before the last one and its path length; the first
        recorded one when the path is shorter; None before any."""
        if not self._s:
            return None
        goal = self._s[-1] - distance_m
        k = max(int(np.searchsorted(self._s, goal, side="right")) - 1, 0)
        return self._s[k], self._poses[k]

    def return_to(self, s_m: float) -> None:
        """The pad is back where the path was ``s_m`` long: forget what was recorded after it."""
        k = int(np.searchsorted(self._s, s_m, side="right"))
        del self._s[k:], self._poses[k:]
        self.length_m = s_m


class Backtrack(TactileBehaviour):
    """Back the pad up along its recorded path after ``cable_end`` lost the line.

    With a :class:`CableLoss` on ``lost_key`` the leaf moves the pad centre in the pad plane
    (sensor x and y; the force hold running beside it keeps the contact) towards the pose
    recorded ``distance_m`` before the last on-line one, and turns it about the pad normal to
    that pose's heading. SUCCESS there (within ``tolerance_m`` and 2°), which also clears the loss;
    SUCCESS at once when no loss is pending (the first follow). FAILURE after ``timeout_s``.
    """

    uses = frozenset({"pressure"})

    distance_m = Parameter(0.03, bound=POSITIVE, doc="How far to back up along the recorded path (m).")
    speed_mps = Parameter(0.01, bound=POSITIVE, doc="Largest speed in the pad plane (m/s).")
    turn_gain = Parameter(2.0, bound=POSITIVE, unit="1/s", doc="Turn rate per rad of heading error (1/s).")
    tolerance_m = Parameter(0.001, bound=POSITIVE, doc="Distance to the recorded pose that counts as arrived (m).")
    timeout_s = Parameter(10.0, bound=POSITIVE, doc="Mission time allowed (s).")
    path_key = Parameter("/cable/path", fixed=True, doc="Blackboard key of the pad path ``cable_end`` records.")
    lost_key = Parameter("/cable/lost", fixed=True, doc="Blackboard key ``cable_end`` writes a loss to.")

    def __init__(self, name: str | None = None, *args, **parameters) -> None:
        super().__init__(name, *args, **parameters)
        self.path_key = normalise_key(self.path_key)
        self.lost_key = normalise_key(self.lost_key)
        self._client = self.attach_blackboard_client(name=f"{self.name}/cable")
        for key in (self.path_key, self.lost_key):
            self._client.register_key(key=key, access=Access.WRITE)
        self._target: tuple[float, np.ndarray] | None = None
        self._start = 0.0

    def initialise(self) -> None:
        self._start = read(TIME)
        self._target = None
        path = read_or(self.path_key)
        if read_or(self.lost_key) is not None and isinstance(path, PadPath):
            self._target = path.back(self.distance_m)
        self.feedback_message = ""

    def update(self) -> Status:
        if self._target is None:
            write(self.lost_key, None)
            self.feedback_message = "nothing to back up from"
            return Status.SUCCESS
        s_m, target = self._target
        pose = read(POSE)
        rotation = pose[:3, :3]
        error = rotation.T @ (target[:3, 3] - pose[:3, 3])  # sensor frame (m)
        heading = rotation.T @ target[:3, 1]  # the recorded sensor y axis, in the sensor frame
        turn = math.atan2(-heading[0], heading[1])  # about the sensor z axis (rad)
        distance = math.hypot(error[0], error[1])
        if distance <= self.tolerance_m and abs(turn) <= math.radians(2.0):
            read(self.path_key).return_to(s_m)
            write(self.lost_key, None)
            self.feedback_message = f"backed up to {s_m * 1e3:.0f} mm along the path"
            return Status.SUCCESS
        if read(TIME) - self._start > self.timeout_s:
            self.feedback_message = (f"could not back up to {s_m * 1e3:.0f} mm along the path within "
                                     f"{self.timeout_s:g} s ({distance * 1e3:.1f} mm off)")
            return Status.FAILURE
        speed = min(self.speed_mps, 2.0 * distance) / max(distance, 1e-9)  # slow down over the last 5 mm
        self.command.add(self.name, (error[0] * speed, error[1] * speed, 0.0, 0.0, 0.0, self.turn_gain * turn))
        self.feedback_message = f"backing up, {distance * 1e3:.1f} mm to go"
        return Status.RUNNING
