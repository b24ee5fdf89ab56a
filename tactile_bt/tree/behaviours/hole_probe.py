"""Lower the pad's corner into a valley the flat pad bridges, to tell a hole from a bowl.

A flat pad bridges a hollow narrower than itself and leaves it untouched: a bowl's floor that
is surface to scan, or the table seen through a ring. The frontier planner
(``frontier_guidance: {max_hole_probes: ...}``) then writes a probe of the valley to the
re-approach key, ``{"hole": {"probes": [(xy, R, corner_z), ...], "cells": xy}, "top_z": z,
"home": (point, normal)}`` (world, m; from :mod:`tactile_bt.contacts.hole_probe`; ``cells``:
the valley's cells a probe found open marks empty): points spread
over the valley, each with the tilted pose that lowers the pad's corner furthest there without
any part of the pad coming near the touched surface, and the height the corner may go down to.
The planner probes a hole wider than the pad (up to twice its width) the same way, where every
attempt to slide over its rim failed: the pad fits in it, but nothing it touched says whether it
has a floor.

The ``hole_probe`` leaf lifts the pad off, rises above everything touched, moves over each point
in turn with the pad tilted corner first (turned a quarter turn about its normal, which the
square pad senses the same, where the arm's wrist would otherwise be wound near its limit, as
``reapproach`` does) and lowers it straight down, holding its orientation,
until the corner reaches its height (the valley is open there: on to the next point), the pad
touches, or comes into contact at all while lowering (the valley holds surface: ``"result":
"touched"``, with the point under ``"touched"``)
or the arm stops it (on to the next point). It writes each point's outcome under
``"outcomes"`` and the corner's lowest heights under ``"reached"``, and ``"result": "open"``
when the pad touched nowhere and the arm got it to every point but one at most, and to two at
least (``reach`` otherwise). Then it goes back to the touched point it left, as
``reapproach`` does, lifting off straight up where the corner touched while lowering (the way it
came down: along its tilted normal it may press the valley's other side); exploring goes on from there.

It belongs beside ``reapproach`` and ``border_sweep`` in the sequence before ``touch``: each
leaf carries out its own kind of job and lets the other pass.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status

from tactile_bt.control.spatial import make_pose
from tactile_bt.tree.behaviours.reapproach import HOLD_GAIN, STUCK_S, Reapproach
from tactile_bt.tree.behaviours.table import lowest_corner
from tactile_bt.tree.blackboard import read_or

__all__ = ["HoleProbe"]

#: The corner has reached its height within this distance (m).
_DEPTH_M = 0.0005
#: A valley is open when the pad touched at none of its points and the arm got it to all but
#: at most this many (a wrist wound near its limit by the turns from one point to the next), and
#: to two at least.
_UNREACHED = 1


class HoleProbe(Reapproach):
    """Carry out the probe of a valley pending on ``key``, if any (see the module docstring);
    SUCCESS at once without one."""

    _rising = False  # lift straight up off the next contact (the corner touched while lowering)

    def initialise(self) -> None:
        super().initialise()  # a re-approach job is reapproach's; this leaf passes it by
        job = read_or(self.key)
        self._job = job if isinstance(job, dict) and "hole" in job and "result" not in job else None
        self._lowering = self._rising = False
        if self._job is not None:
            self._job["reached"], self._job["outcomes"] = [], []
            self._probe = 0
            self._start_probe()

    def describe(self) -> str:
        if self._job is not None and self._lowering and not self._going_home:
            return f"lowering the corner into the valley, point {self._probe + 1} of {len(self._probes())}"
        return super().describe()

    def _lift_direction(self) -> np.ndarray:
        """Straight up after the corner touched while lowering: the pad came down that way, and
        its normal, tilted corner first, may point at the valley's other side."""
        if self._rising:
            return np.array([0.0, 0.0, 1.0])
        return super()._lift_direction()

    def _probes(self) -> list:
        return self._job["hole"]["probes"]

    def _start_probe(self) -> None:
        """Route to above the current point, the pad tilted corner first."""
        xy, R, corner_z = self._probes()[self._probe]
        self._R = self._unwound(np.asarray(R, dtype=float))  # a quarter turn back where the wrist is wound
        self._corner = np.array([xy[0], xy[1], corner_z])
        offset = lowest_corner(make_pose(self._R, np.zeros(3)), self.pad)  # from the pad's centre
        top_z = float(self._job.get("top_z", corner_z))
        start = self._corner - offset
        start[2] += max(top_z + self.clearance_m - corner_z, 0.0)  # the corner above everything touched
        self._going_home = False
        self._lowering = False
        self._route(start, self._R, top_z)
        self._low = (math.inf, self.now)

    def _finish(self, result: str) -> None:
        """Note the corner's height and the point's outcome; on to the next point unless the
        pad touched. At the end: ``open`` when every point was open but at most
        ``_UNREACHED`` the arm could not get to, ``reach`` when it could not get to more."""
        if not self._going_home and self._job is not None and "hole" in self._job:
            self._job["reached"].append(float(lowest_corner(self.pose, self.pad)[2]))
            self._job["outcomes"].append(result)
            if result != "touched" and self._probe + 1 < len(self._probes()):
                self._probe += 1
                self._start_probe()
                return
            self._lowering = False
            if result != "touched":
                opened = self._job["outcomes"].count("open")
                result = "open" if opened >= max(2, len(self._probes()) - _UNREACHED) else "reach"
        super()._finish(result)

    def update(self) -> Status:
        if self._verdict or self._job is None or self._going_home or self._done:
            status = super().update()
            if self._done and self._job is not None:
                self.feedback_message = f"hole probe: {self._job.get('result', '')}"
            return status
        self._feedback = None
        f = self.features
        touching = f.in_contact and f.pressure >= self.pressure_pa
        if self._waypoints:
            self._next_waypoint(touching, "touched")
            return Status.RUNNING
        self._lowering = True
        self._phase = "lowering the corner"
        corner = lowest_corner(self.pose, self.pad)
        if f.in_contact:  # lowering, any contact is surface: the valley is not open there
            self._note_touch()
            self._rising = True  # back up the way it came down
            self._finish("touched")
        elif corner[2] <= self._corner[2] + _DEPTH_M or self._corner_at_table():
            self._finish("open")
        else:
            if corner[2] < self._low[0] - 1e-3:
                self._low = (float(corner[2]), self.now)
            if self.now - self._low[1] > STUCK_S:  # no nearer by a millimetre: the arm stops it
                self._finish("reach")
            else:
                self._lower(corner)
        return Status.RUNNING

    def _lower(self, corner: np.ndarray) -> None:
        """Command the pad straight down at ``approach_speed_mps``, the corner held over its
        point and the pad's orientation held."""
        error = self._corner - corner
        v = HOLD_GAIN * np.array([error[0], error[1], 0.0])
        v[2] = -min(self.approach_speed_mps, HOLD_GAIN * max(-error[2], 0.0) + 1e-3)
        self._command_world(v, self._turn_back(self._R))
