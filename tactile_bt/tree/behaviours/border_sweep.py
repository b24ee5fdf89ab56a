"""Sweep with the border of the pad where its face cannot lie: the foot of a plane face just
above the table, and the sides of a hollow the flat pad bridges.

A pad lying on a face that runs down to the table stops with its lowest border above the table
(``table_clearance`` and the frontier planner see to that), and a band along the foot stays
untouched: on a 40° face, about 5 mm of it. Held level instead, ``foot_z`` above the table, the
pad can slide towards the face until its border touches it there, every corner equally far from
the table. A flat pad bridges a hollow narrower than itself and leaves its sides untouched;
tilted about the hollow's axis, its body over the touched rim, it can touch them with its border
row alone. The frontier planner (``frontier_guidance: {max_sweeps: ...}``) writes such a sweep
to the re-approach key, ``{"sweep": run, "foot_z": z, "top_z": z, "home": (point, normal)}`` (a
run of foot or a hollow's side from :mod:`tactile_bt.contacts.sweep_plan`, world, m), and fails
for the ``retry`` to carry it out.

The ``border_sweep`` leaf then lifts the pad off, rises above everything touched (or, lying on
the face whose foot it is to sweep, turns level just above it and glides down along it), turns
the pad with the side nearest its present heading facing the surface (for a foot, a quarter turn
back where the wrist is wound, as ``reapproach`` does), and approaches:

- a foot: level, sideways from beyond it at ``foot_z``; it sweeps along the foot holding its
  height and orientation, its distance to the face servoed on the border row's pressure
  (``sweep_pressure_pa``), to and fro in passes ``foot_step_m`` apart up the face until the
  band below the frontier left there is swept (:func:`foot_passes`);
- a hollow's side: tilted about the hinge (z × the direction of its body) ``lean_rad`` more
  steeply than the rim, from above; it sweeps along the hollow in passes ``step_m`` apart from
  its edge towards its middle, pressing down on the pressure and leaning about its border's edge
  (``lean_gain``) until the row beside the border just carries, so that the imprint lies on the
  surface. It never presses down once its lowest corner is within ``table_clearance_m`` of the
  table; where its border is down there touching nothing, the cells it passes are noted in the
  job's ``empty`` (no surface above the table there).

Every settled imprint of the border row goes into the mission's contact cloud with the surface's
estimated normal. At the end, or when the surface ends under the border (no contact for
``lost_s``), it writes ``"result": "swept"`` (``reach`` when the arm could not get there,
``nothing`` when no surface was found, ``tilt`` when a hollow needs the pad steeper than
``max_tilt_rad``, ``body`` when a level pad's body touched instead of its border) and goes back
to the touched point it left, as ``reapproach`` does; exploring goes on from there. From a foot it
first moves back along it to the run's middle, and where the way back is closed (the point lies
too near the table) it goes onto the face it swept instead, lying on it clear of the table.

It belongs beside ``reapproach`` in the sequence before ``touch``: each leaf carries out its
own kind of job and lets the other pass.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from py_trees.common import Status

from tactile_bt.contacts.sweep_plan import END_INSIDE_M
from tactile_bt.tree.behaviours.contact_points import imprint_points
from tactile_bt.tree.behaviours.reapproach import HOLD_GAIN, Reapproach
from tactile_bt.tree.blackboard import TIME, read, read_or
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE

__all__ = ["BorderSweep", "level_facing", "foot_passes"]

#: Each pass holds still until it has touched this long (s), for the pressure to settle, before it
#: sweeps, and does not end before.
_SETTLE_S = 0.5
#: The pad lies on the face to be swept while its centre is this close (m) to the face's plane.
_ON_FACE_M = 0.01
#: A level pad's body touches, not its border, when the centre of pressure lies this far (m) inside
#: the border row.
_BODY_M = 0.01
#: Down at the table touching nothing, a valley's pass goes this many times faster.
_CARVING = 2.0
#: Fastest roll (rad/s) of the lean about the border.
_MAX_LEAN_RPS = 0.3
#: Only the imprint within this distance (m) of the border facing the face is recorded.
_BORDER_M = 0.005
#: A foot's next pass, higher up the face, has this long (s) more to find the face again.
_REFIND_S = 1.0
#: Most passes of a foot's sweep (a band higher than this many steps is swept only this far up).
_MOST_FOOT_PASSES = 8
#: A pad that cannot go home from a foot takes up exploring on the face with its lowest corner this
#: much (m) higher than the re-approach's table clearance (see ``BorderSweep._above_band``).
_ABOVE_M = 0.005


def foot_passes(foot_z: float, band_top_z: float, normal: np.ndarray, step_m: float) -> tuple[int, float]:
    """How many level passes sweep the band of a face between ``foot_z`` and ``band_top_z``
    (world heights, m; the frontier left above it), and how much higher (m) each pass runs
    than the one before: passes ``step_m`` (m) apart along a face of outward ``normal``
    (world, unit), the first at ``foot_z``, the last at most a step below the band's top
    (which the frontier's own samples cover); :data:`_MOST_FOOT_PASSES` at most."""
    rise = step_m * math.hypot(float(normal[0]), float(normal[1]))  # step_m along the face
    if rise <= 0 or band_top_z <= foot_z:
        return 1, 0.0
    return min(_MOST_FOOT_PASSES, max(1, math.ceil((band_top_z - foot_z) / rise))), rise


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


class BorderSweep(Reapproach):
    """Carry out the border sweep pending on ``key``, if any (see the module docstring); SUCCESS
    at once without one."""

    uses = frozenset({"cop", "pressure"})

    sweep_speed_mps = Parameter(0.02, bound=POSITIVE, doc="Speed along the sweep (m/s).")
    sweep_pressure_pa = Parameter(1000.0, bound=POSITIVE,
                                  doc="Pressure the border row is held at while sweeping (Pa).")
    kp = Parameter(1.0e-5, bound=POSITIVE, unit="m/s/Pa",
                   doc="Gain of the pad's speed towards the surface on the pressure error (m/s per Pa).")
    max_press_mps = Parameter(0.01, bound=POSITIVE, doc="Largest speed towards or away from the surface (m/s).")
    lost_s = Parameter(0.5, bound=POSITIVE,
                       doc="The surface has ended under the border after this long without contact (s).")
    voxel_m = Parameter(0.001, bound=POSITIVE, doc="One recorded sample per voxel of this edge (m), as ``record_contacts``.")
    lean_rad = Parameter(math.radians(15.0), bound=NON_NEGATIVE,
                         doc="A valley's side is approached with the pad this much steeper than the rim beside it "
                             "(rad).")
    lean_gain = Parameter(60.0, bound=NON_NEGATIVE, unit="rad/s/m",
                          doc="Sweeping a valley's side, the pad rolls about its border at this rate per m that the "
                              "centre of pressure lies inside the border row by more than half a pitch (body up), or "
                              "less (body down): it leans until the row next to the border just begins to carry.")
    foot_step_m = Parameter(0.003, bound=POSITIVE,
                            doc="A foot is swept in level passes this far apart up the face (m, along it), from "
                                "``foot_z`` up to the frontier left above it, so that the band between is touched "
                                "within the coverage radius.")
    max_tilt_rad = Parameter(math.radians(70.0), bound=NON_NEGATIVE,
                             doc="Largest tilt of the pad from the level while sweeping a valley's side (rad); "
                                 "beyond it the sweep ends (``tilt``).")

    def initialise(self) -> None:
        super().initialise()  # a probe job is reapproach's; this leaf passes it by
        job = read_or(self.key)
        self._job = job if isinstance(job, dict) and "sweep" in job and "result" not in job else None
        self._sweeping = False
        self._recorded = 0
        if self._job is not None:
            self._start_sweep()

    # -- the plan -------------------------------------------------------------------------------
    def _start_sweep(self) -> None:
        run = self._job["sweep"]
        self._going_home = False
        self._kind = run.get("kind", "foot")
        out, along = np.asarray(run["out"], dtype=float), np.asarray(run["along"], dtype=float)
        self._out, self._along = np.array([*out, 0.0]), np.array([*along, 0.0])
        self._normal = np.asarray(run["normal"], dtype=float)
        reach = self.pad.half_width_m  # from the pad centre to the border row's edge
        length = float(run["length_m"])
        self._first = min(reach - END_INSIDE_M, length / 2)
        self._s_end = max(length - (reach - END_INSIDE_M), length / 2)
        border = np.asarray(run["start"], dtype=float) + along * self._first  # world xy of the border's middle
        level = level_facing(-out, self.pose[:3, :3])
        top_z = float(self._job.get("top_z", 0.0))
        if self._kind == "foot":
            level = self._unwound(level)  # any side may face the face: a quarter turn back where the wrist is wound
            tilt, z = 0.0, float(self._job["foot_z"])
            self._press = -self._out  # sideways onto the face
            self._passes, rise = foot_passes(z, float(run.get("band_top_z", z)), self._normal, self.foot_step_m)
            self._step = np.array([0.0, 0.0, rise])  # up the face: the press finds it further in
        else:  # steeper than the rim by lean_rad to start with; the lean servo sets it from there
            tilt = math.atan(max(float(run["rim_rise"]), 0.0)) + self.lean_rad
            z = float(run["rim_z"])
            self._press = np.array([0.0, 0.0, -1.0])  # down onto the side
            self._passes = max(1, int(math.ceil(float(run["width_m"]) / float(run["step_m"]))))
            self._step = -self._out * float(run["step_m"])
        # tilted about the axis, the body (towards out) rising
        self._hinge = np.cross([0.0, 0.0, 1.0], self._out)  # about it, -angle lifts the body
        turn = Rotation.from_rotvec(-tilt * self._hinge).as_matrix()
        self._R = turn @ level
        self._line = np.array([*border, z])  # the border's middle on the first pass's line
        self._pass = 0
        standoff = self._line + turn @ self._out * reach - self._press * self.standoff_m  # the pad centre
        self._route(standoff, self._R, top_z)
        if self._kind == "foot":
            self._low_route(standoff, length)
        self._last_contact = math.inf

    def _low_route(self, standoff: np.ndarray, length: float) -> None:
        """Over the face being swept, turn the pad level just above the face and glide down
        along it to the standoff, instead of moving over high above everything touched (a
        foot near the arm's base may be out of its reach from there)."""
        T = self.pose
        foot = self._line  # on the foot, level with the pad's border
        into = float((foot - T[:3, 3]) @ self._out)  # how far the pad is inside the foot (m)
        along = self._first + float((T[:3, 3] - foot) @ self._along)
        n = self._normal
        on_face = abs(float((T[:3, 3] - foot) @ n)) < _ON_FACE_M
        if into <= 0 or not on_face or not -END_INSIDE_M <= along <= length + END_INSIDE_M:
            return  # not on this face: the way over everything touched
        slope = math.hypot(n[0], n[1]) / max(n[2], 1e-6)  # the face's rise per m inwards
        border = into + self.pad.half_width_m  # the level pad's inner border, inside the foot (m)
        level_z = foot[2] + border * slope + self.clearance_m
        if level_z < T[2, 3]:
            level_z = T[2, 3]
        lifted = self._waypoints[0]
        self._waypoints = [lifted, (np.array([T[0, 3], T[1, 3], level_z + self.lift_m]), self._R, "levelling"),
                           (standoff, self._R, "gliding down to the foot")]

    def _start(self, target: tuple, home: bool) -> None:
        super()._start(target, home)
        if not (home and self._job is not None and self._kind == "foot"):
            return
        if not self._waypoints:  # no way back to where it left (too near the table): onto the face instead
            point, normal = self._above_band()
            if not self._plan(point, normal, float(self._job.get("top_z", point[2]))):
                return  # approach from where the pad is, as reapproach does
        self._back_along_foot()

    def _above_band(self) -> tuple[np.ndarray, np.ndarray]:
        """A point (world, m) on the face swept, above the run's middle, and the face's normal:
        where the pad, lying on the face, takes up exploring when it cannot go back to where it
        left (a level pad whose border alone touches the face would roll onto it pressing far
        harder than its target). As high up the face as the pad, lying on it with a corner
        downhill, needs to keep clear of the table, and no higher than everything touched."""
        run = self._job["sweep"]
        n = self._normal
        foot_z = float(self._job["foot_z"])
        sin_tilt = math.hypot(n[0], n[1])
        clear = foot_z + (self.pad.half_diagonal_m + self.corner_margin_m) * sin_tilt + self.table_clearance_m + _ABOVE_M
        z = max(min(clear, float(self._job.get("top_z", clear))), float(run.get("band_top_z", foot_z)))
        inwards = (z - foot_z) * n[2] / max(sin_tilt, 1e-9)  # up the face to that height (m, across)
        xy = np.asarray(run["centre"], dtype=float) - np.asarray(run["out"], dtype=float) * inwards
        return np.array([xy[0], xy[1], z]), n

    def _back_along_foot(self) -> None:
        """On the way home from a foot, move back along it, lifted off, to the middle of the run
        before rising over everything touched: a sweep carried on to a face's corner may end
        where the arm cannot rise that high (near its base)."""
        phases = [phase for _, _, phase in self._waypoints]
        if "rising" not in phases:
            return
        k = phases.index("rising")
        middle = 0.5 * float(self._job["sweep"]["length_m"])
        here = self._first + float((self._border() - self._line) @ self._along)  # the border's middle, along the run
        if abs(middle - here) < END_INSIDE_M:
            return
        shift = self._along * (middle - here)
        lifted, R, _ = self._waypoints[k - 1] if k else (self.pose[:3, 3], self.pose[:3, :3], "")
        rising, R_rising, _ = self._waypoints[k]
        self._waypoints[k] = (rising + shift, R_rising, "rising")
        self._waypoints.insert(k, (lifted + shift, R, "back along the foot"))

    def describe(self) -> str:
        if self._job is not None and self._sweeping and not self._going_home:
            return f"sweeping with the border, pass {self._pass + 1} of {self._passes}, {self._recorded} samples"
        return super().describe()

    # -- the life cycle -------------------------------------------------------------------------
    def update(self) -> Status:
        if self._verdict or self._job is None or self._going_home or self._done:
            return super().update()
        self._feedback = None  # the message says the phase (describe), not an earlier ending's
        f = self.features
        touching = f.in_contact and f.pressure >= self.pressure_pa
        if self._waypoints:
            self._next_waypoint(touching, "nothing")  # something in the way: not the surface looked for
            return Status.RUNNING
        if not self._sweeping:
            self._phase = "approaching with the border"
            if touching:
                self._sweeping, self._last_contact, self._pass_contact_s = True, self.now, 0.0
                self._carved = None
            elif self._approached > self.standoff_m + self.approach_m or self._at_table():
                self._finish("nothing")
                return Status.RUNNING
            else:
                self._approached += self.approach_speed_mps * self.dt
            self._hold(self.approach_speed_mps, 0.0)
            return Status.RUNNING
        self._phase = "sweeping with the border"
        inside = self._inside(f) if f.in_contact else 0.0  # how far the contact lies inside the border row
        lean = 0.0
        if self._kind != "foot" and f.in_contact:  # roll about the border until the next row just carries
            lean = max(-_MAX_LEAN_RPS, min(_MAX_LEAN_RPS, self.lean_gain * (inside - 0.5 * self.pad.pitch)))
            if math.acos(max(-1.0, min(1.0, -float(self.pose[2, 2])))) > self.max_tilt_rad and lean > 0:
                self._finish("tilt")
                return Status.RUNNING
        elif f.in_contact and inside > _BODY_M:  # a level pad's body on the surface: not the border
            self._finish("body")
            return Status.RUNNING
        at_table = self._at_table()
        carving = not f.in_contact and at_table  # a valley's border down at the table, touching nothing
        if f.in_contact or carving:
            self._last_contact = max(self._last_contact, self.now)  # a new pass's allowance stands
            self._pass_contact_s += self.dt
        if f.in_contact and inside <= self.pad.pitch:
            self._record(f)
        elif carving:
            self._carve()
        border = self._border()
        forward = self._pass % 2 == 0  # passes go to and fro
        along = self._first + float((border - self._line - self._step * self._pass) @ self._along)  # from the start
        settled = self._pass_contact_s >= _SETTLE_S  # this pass has touched long enough to sweep on
        done = along >= self._s_end if forward else along <= self._first
        if self.now - self._last_contact > self.lost_s:
            self._finish("swept")
            return Status.RUNNING
        if done and settled:
            self._pass += 1
            self._pass_contact_s = 0.0
            if self._pass >= self._passes:
                self._finish("swept")
                return Status.RUNNING
            forward = not forward
            if self._kind == "foot":  # rising to the next pass leaves the face: time to find it again
                self._last_contact = self.now + _REFIND_S
        if f.in_contact:
            press = max(-self.max_press_mps, min(self.max_press_mps, self.kp * (self.sweep_pressure_pa - f.pressure)))
        else:
            press = self.approach_speed_mps  # find the surface again
        if press > 0 and at_table and self._press[2] < 0:
            press = 0.0  # never down onto the table
        speed = (_CARVING * self.sweep_speed_mps if carving else self.sweep_speed_mps) if settled else 0.0
        self._hold(press, speed if forward else -speed, lean, border)
        return Status.RUNNING

    def _at_table(self) -> bool:
        """Whether the pad's lowest corner is within ``table_clearance_m`` of the table, coming
        down towards it (a valley's floor, not the table, is what the pad looks for)."""
        return self._kind != "foot" and self._corner_at_table()

    def _carve(self) -> None:
        """Note the cells under the border's edge, down at the table and touching nothing, in
        the job's ``empty`` (world xy, m): no surface above the table there. Every millimetre of
        the edge's travel."""
        border = self._border()
        if self._carved is not None and np.linalg.norm(border - self._carved) < 1e-3:
            return
        self._carved = border
        facing = self._facing()
        edge = self.pose[:3, :3] @ np.array([-facing[1], facing[0], 0.0])
        half = self.pad.half_width_m
        points = border + np.linspace(-half, half, int(2 * half / 0.002) + 1)[:, None] * edge
        self._job.setdefault("empty", []).append(points[:, :2])

    def _border(self) -> np.ndarray:
        """World position (m) of the middle of the pad's border edge on the side that touches."""
        T = self.pose
        u = self._facing() * self.pad.half_width_m
        return T[:3, :3] @ np.array([u[0], u[1], 0.0]) + T[:3, 3]

    def _hold(self, press_mps: float, along_mps: float, lean_rps: float = 0.0,
              border: np.ndarray | None = None) -> None:
        """Command a twist that moves the pad ``press_mps`` towards the surface and ``along_mps``
        along the sweep and rolls it ``lean_rps`` about its border's edge (body up), holding its
        orientation otherwise and its border's place across the sweep (the pass's line);
        ``border``: :meth:`_border` of this cycle, when the caller has it already."""
        T = self.pose
        if border is None:
            border = self._border()
        error = self._line + self._step * self._pass - border
        error -= (error @ self._along) * self._along + (error @ self._press) * self._press
        roll = -lean_rps * self._hinge  # about the border's edge: the body rises for lean_rps > 0
        if lean_rps:
            self._R = Rotation.from_rotvec(roll * self.dt).as_matrix() @ self._R
        v = HOLD_GAIN * error + self._press * press_mps + self._along * along_mps + np.cross(roll, T[:3, 3] - border)
        self._command_world(v, roll + self._turn_back(self._R))

    def _inside(self, f) -> float:
        """How far (m) the centre of pressure lies inside the centre of the border row."""
        x, y = f.cop_xy
        facing = self._facing()
        return self.pad.half_width_m - 0.5 * self.pad.pitch - float(x * facing[0] + y * facing[1])

    def _facing(self) -> np.ndarray:
        """The unit sensor-frame xy direction of the border row in contact: the pad's side
        facing away from its body."""
        facing = (self.pose[:3, :3].T @ -self._out)[:2]
        return facing / max(float(np.linalg.norm(facing)), 1e-9)

    def _record(self, f) -> None:
        """Add the imprint of the border row, while its pressure is settled (between half and
        twice ``sweep_pressure_pa``), with the surface's estimated normal."""
        if not 0.5 * self.sweep_pressure_pa <= f.pressure <= 2.0 * self.sweep_pressure_pa:
            return
        local, pressure = imprint_points(self.features_raw)
        T = self.pose
        keep = local[:, :2] @ self._facing() >= self.pad.half_width_m - _BORDER_M
        world = local[keep] @ T[:3, :3].T + T[:3, 3]
        cloud = self.bb.contacts
        fresh = cloud.fresh(world, self.voxel_m)
        cloud.extend(world[fresh], self._normal, pressure[keep][fresh], read(TIME))
        self._recorded += int(np.count_nonzero(fresh))
