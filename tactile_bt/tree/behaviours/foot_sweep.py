"""Sweep the foot of a plane face with the border of a level pad, just above the table.

A pad lying on a face that runs down to the table stops with its lowest border above the table
(``table_clearance`` and the frontier planner see to that), and a band along the foot stays
untouched: on a 40° face, about 5 mm of it. Held level instead, ``height`` above the table, the
pad can slide towards the face until its border touches it there, every corner equally far
from the table. The frontier planner (``frontier_guidance: {max_foot_sweeps: ...}``) writes
such a sweep to the re-approach key when that band is all that keeps the scan from its
coverage, ``{"sweep": run, "foot_z": z, "top_z": z, "home": (point, normal)}`` (a run of
foot from :func:`tactile_bt.contacts.foot_sweep_plan.foot_runs`, world, m), and fails for the
``retry`` to carry it out.

The ``foot_sweep`` leaf then lifts the pad off, rises above everything touched, turns it level
with the side nearest its present heading facing the face, lowers it to ``foot_z`` beyond the
foot and slides it towards the face until its border row touches (the pressure passes
``pressure_pa``). It sweeps along the foot at ``sweep_speed_mps``: the pad's height and
orientation held, its distance to the face servoed on the pressure (``sweep_pressure_pa``),
and every settled imprint of its border row recorded into the mission's contact cloud with the
face's normal. At the run's end, or when the face ends under the border (no contact for
``lost_s``), it writes ``"result": "swept"`` (``reach`` when the arm could not get there,
``nothing`` when no face was found) and goes back to the touched point it left, as
``reapproach`` does; exploring goes on from there and the planner finds the band touched.

It belongs beside ``reapproach`` in the sequence before ``touch``: each leaf carries out its
own kind of job and lets the other pass.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from py_trees.common import Status

from tactile_bt.tree.behaviours.contact_points import imprint_points
from tactile_bt.tree.behaviours.reapproach import Reapproach
from tactile_bt.tree.blackboard import TIME, read, read_or
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import POSITIVE

__all__ = ["FootSweep", "level_facing"]

#: Gains (1/s) of the height and orientation held while sweeping.
_K_HEIGHT = 5.0
_K_TURN = 3.0
#: The pad starts sweeping this far (m) inside the run's ends, so that its border row covers them.
_END_INSIDE_M = 0.01
#: The pad holds still this long (s) after touching, for the pressure to settle, before it sweeps.
_SETTLE_S = 0.5
#: The pad lies on the face to be swept while its centre is this close (m) to the face's plane.
_ON_FACE_M = 0.01
#: Only the imprint within this distance (m) of the border facing the face is recorded.
_BORDER_M = 0.005


def level_facing(towards: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The rotation (world, 3×3) of a level pad (sensor z down) with one of its four sides
    facing the world xy direction ``towards``: the one that turns the pad least from
    ``current``."""
    d = np.array([towards[0], towards[1], 0.0])
    d /= np.linalg.norm(d)
    z = np.array([0.0, 0.0, -1.0])
    best, best_angle = None, math.inf
    for side in (d, -d):
        for x in (side, np.cross(side, z)):  # the facing side is sensor ±x or ±y
            R = np.column_stack((x, np.cross(z, x), z))
            angle = float(np.linalg.norm(Rotation.from_matrix(R @ current.T).as_rotvec()))
            if angle < best_angle:
                best, best_angle = R, angle
    return best


class FootSweep(Reapproach):
    """Carry out the foot sweep pending on ``key``, if any (see the module docstring); SUCCESS
    at once without one."""

    uses = frozenset({"cop", "pressure"})

    sweep_speed_mps = Parameter(0.015, bound=POSITIVE, doc="Speed along the foot (m/s).")
    sweep_pressure_pa = Parameter(1000.0, bound=POSITIVE,
                                  doc="Pressure the border row is held at while sweeping (Pa).")
    kp = Parameter(1.0e-5, bound=POSITIVE, unit="m/s/Pa",
                   doc="Gain of the pad's speed towards the face on the pressure error (m/s per Pa).")
    max_press_mps = Parameter(0.01, bound=POSITIVE, doc="Largest speed towards or away from the face (m/s).")
    lost_s = Parameter(0.5, bound=POSITIVE, doc="The face has ended under the border after this long without contact (s).")
    voxel_m = Parameter(0.001, bound=POSITIVE, doc="One recorded sample per voxel of this edge (m), as ``record_contacts``.")

    def initialise(self) -> None:
        super().initialise()  # a probe job is reapproach's; this leaf passes it by
        job = read_or(self.key)
        self._job = job if isinstance(job, dict) and "sweep" in job and "result" not in job else None
        self._sweeping = False
        self._recorded = 0
        if self._job is not None:
            self._start_sweep()

    def _start_sweep(self) -> None:
        run, foot_z = self._job["sweep"], float(self._job["foot_z"])
        self._going_home = False
        self._run = run
        out, along = np.asarray(run["out"], dtype=float), np.asarray(run["along"], dtype=float)
        self._R = level_facing(-out, self.pose[:3, :3])
        reach = self.pad.half_width_m  # from the pad centre to the border facing the face
        length = float(run["length_m"])
        self._first = min(reach - _END_INSIDE_M, length / 2)
        self._s_end = max(length - (reach - _END_INSIDE_M), length / 2)
        foot = np.asarray(run["start"], dtype=float) + along * self._first
        self._origin = np.array([*(foot + out * reach), foot_z])  # the pad centre with its border at the foot
        self._out, self._along, self._foot_z = np.array([*out, 0.0]), np.array([*along, 0.0]), foot_z
        self._normal = np.asarray(run["normal"], dtype=float)
        standoff = self._origin + self._out * self.standoff_m
        self._route(standoff, self._R, float(self._job.get("top_z", foot_z)))
        self._low_route(standoff, length)
        self._approached = 0.0
        self._last_contact = math.inf

    def _low_route(self, standoff: np.ndarray, length: float) -> None:
        """Over the face being swept, turn the pad level just above the face and glide down
        along it to the standoff, instead of moving over high above everything touched (a
        foot near the arm's base may be out of its reach from there)."""
        T = self.pose
        foot = self._origin - self._out * self.pad.half_width_m  # on the foot, level with the pad's border
        into = float((foot - T[:3, 3]) @ self._out)  # how far the pad is inside the foot (m)
        along = self._first + float((T[:3, 3] - self._origin) @ self._along)
        n = self._normal
        on_face = abs(float((T[:3, 3] - foot) @ n)) < _ON_FACE_M
        if into <= 0 or not on_face or not -_END_INSIDE_M <= along <= length + _END_INSIDE_M:
            return  # not on this face: the way over everything touched
        slope = math.hypot(n[0], n[1]) / max(n[2], 1e-6)  # the face's rise per m inwards
        border = into + self.pad.half_width_m  # the level pad's inner border, inside the foot (m)
        level_z = self._foot_z + border * slope + self.clearance_m
        if level_z < T[2, 3]:
            level_z = T[2, 3]
        lifted = self._waypoints[0]
        self._waypoints = [lifted, (np.array([T[0, 3], T[1, 3], level_z + self.lift_m]), self._R, "levelling"),
                           (standoff, self._R, "gliding down to the foot")]

    def describe(self) -> str:
        if self._job is not None and self._sweeping and not self._going_home:
            return f"sweeping the foot, {self._recorded} samples"
        return super().describe()

    def update(self) -> Status:
        if self._verdict or self._job is None or self._going_home or self._done:
            return super().update()
        f = self.features
        touching = f.in_contact and f.pressure >= self.pressure_pa
        if self._waypoints:
            position, R, phase = self._waypoints[0]
            self._phase = phase
            if touching and phase != "lifting off":  # something in the way: not the foot looked for
                self._finish("nothing")
            elif self._move(position, R):
                self._waypoints.pop(0)
                self._deadline = self.now + self.move_s
                self._progress = (math.inf, self.now)
            elif self._out_of_reach():
                self._finish("reach")
            return Status.RUNNING
        if not self._sweeping:
            self._phase = "approaching the foot"
            if touching:
                self._sweeping, self._last_contact, self._touched = True, self.now, self.now
            elif self._approached > self.standoff_m + self.approach_m:
                self._finish("nothing")
                return Status.RUNNING
            else:
                self._approached += self.approach_speed_mps * self.dt
            self._hold(-self.approach_speed_mps, 0.0)
            return Status.RUNNING
        self._phase = "sweeping the foot"
        if f.in_contact:
            self._last_contact = self.now
            self._record(f)
        along = self._first + float((self.pose[:3, 3] - self._origin) @ self._along)  # from the run's start
        settled = self.now - self._touched >= _SETTLE_S
        if (along >= self._s_end and settled) or self.now - self._last_contact > self.lost_s:
            self._finish("swept")
            return Status.RUNNING
        press = self.kp * (self.sweep_pressure_pa - f.pressure) if f.in_contact else 0.0
        self._hold(-max(-self.max_press_mps, min(self.max_press_mps, press)), self.sweep_speed_mps if settled else 0.0)
        self._feedback = None
        return Status.RUNNING

    def _hold(self, outwards_mps: float, along_mps: float) -> None:
        """Command a twist that moves the pad ``outwards_mps`` away from the face and
        ``along_mps`` along its foot, holding the pad's height at the foot and its level
        orientation."""
        T = self.pose
        v = self._out * outwards_mps + self._along * along_mps
        v[2] += _K_HEIGHT * (self._foot_z - T[2, 3])
        w = _K_TURN * Rotation.from_matrix(self._R @ T[:3, :3].T).as_rotvec()
        Rt = T[:3, :3].T
        self.command.add(self.name, (*(Rt @ v), *(Rt @ w)))

    def _record(self, f) -> None:
        """Add the imprint of the border row facing the face, while its pressure is settled
        (between half and twice ``sweep_pressure_pa``), with the face's normal."""
        if not 0.5 * self.sweep_pressure_pa <= f.pressure <= 2.0 * self.sweep_pressure_pa:
            return
        local, pressure = imprint_points(self.features_raw)
        T = self.pose
        facing = T[:3, :3].T @ -self._out  # the side facing the face, in the sensor frame
        keep = local[:, :2] @ facing[:2] >= self.pad.half_width_m - _BORDER_M
        world = local[keep] @ T[:3, :3].T + T[:3, 3]
        cloud = self.bb.contacts
        fresh = cloud.fresh(world, self.voxel_m)
        cloud.extend(world[fresh], self._normal, pressure[keep][fresh], read(TIME))
        self._recorded += int(np.count_nonzero(fresh))
