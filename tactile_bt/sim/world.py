"""The simulated world: objects, the pad on its mount, and one step of the control cycle's
"robot" side (move by a base-frame twist, then sense).

Layer: sim.
"""

from __future__ import annotations

import numpy as np

from tactile_bt.robot.interface import SimulatedRobot
from tactile_bt.robot.mounts import CartesianMount
from tactile_bt.sim.pad import PadContact, SensorModel

__all__ = ["CartesianMount", "World"]


class World:
    """Objects and a pad on a mount.

    Parameters
    ----------
    objects : list of SimObject
    sensor : SensorModel
    mount : CartesianMount, ArmMount (a :class:`~tactile_bt.robot.interface.Robot`), or any
        object with ``pose`` and ``move(twist_g, dt)``
    """

    def __init__(self, objects, sensor: SensorModel, mount) -> None:
        self.objects = list(objects)
        self.sensor = sensor
        self.mount = mount
        # A Robot mount is moved as a live arm is: the twist sent, then a step of simulated time.
        self._robot = isinstance(mount, SimulatedRobot)
        self.last_force = np.zeros(sensor.params.geometry.shape)
        self.last_penetration = 0.0
        # A compliant mount feels the contact: wrench and stiffness from the pad model (and, for
        # the arm, its whole step in compiled kernels).
        mount.attach(PadContact(sensor, self))

    @property
    def pose(self) -> np.ndarray:
        """``T_gs``, the pad's pose in the base frame."""
        return self.mount.pose

    @property
    def calibration(self):
        """The calibration of the simulated tactels (what a calibrated real pad would ship)."""
        return self.sensor.calibration

    def sense(self) -> np.ndarray:
        """A raw frame (uint16 counts) for the pad's current pose."""
        raw, self.last_force, self.last_penetration = self.sensor.sense(self.pose, self.objects)
        return raw

    def move(self, twist_g: np.ndarray, dt: float) -> None:
        """Move the pad by the base-frame twist for ``dt`` seconds."""
        if self._robot:
            self.mount.send_twist(twist_g)
            self.mount.step(dt)
        else:
            self.mount.move(twist_g, dt)

    def update(self, t: float) -> list:
        """Apply the scene events due at mission time ``t`` (s), each once.

        An event replaces the object in ``self.objects`` by a displaced copy (the scene's own
        objects stay where the file puts them) and the sensor model's cached broad phase is
        dropped. The mission loop calls this once per cycle, before sensing. Returns the events
        applied (``tactile_bt.sim.events.ObjectEvent``), usually none.
        """
        schedule = getattr(self, "events", None)
        if not schedule:
            return []
        fired = schedule.apply_due(t, self.objects)
        if fired:
            self.sensor.invalidate()
        return fired
