"""Helpers to unit-test tactile leaves without a simulator: fake features, a fake mission clock
and access to the twist a leaf added.

Example
-------
>>> from tactile_bt.behaviours import ForceHold
>>> from tactile_bt.testing import LeafHarness, make_features
>>> h = LeafHarness(ForceHold(target_pa=2000))
>>> h.tick(make_features(pressure=1500))        # too light: press on
<Status.RUNNING: 'RUNNING'>
>>> bool(h.twist[2] > 0)                         # +z of the sensor frame, towards the object
True
"""

from __future__ import annotations

from typing import Callable, Iterable

import numpy as np
import py_trees
from py_trees.common import Status

from tactile_bt import defaults
from tactile_bt.behaviours.base import cycle_writer
from tactile_bt.behaviours.record import ContactCloud
from tactile_bt.control import ServoCommand
from tactile_bt.features import ContactFeatures

__all__ = ["make_features", "LeafHarness"]


def make_features(
    cop_px=(7.5, 7.5),
    pressure: float = defaults.TARGET_PRESSURE_PA,
    orientation: float = np.pi / 2,
    area: int = 40,
    in_contact: bool = True,
    shape=(defaults.ROWS, defaults.COLS),
) -> ContactFeatures:
    """Features of a fake contact: COP in tactels ``[x, y]``, pressure in Pa, orientation in rad.

    ``in_contact=False`` gives the features of an empty frame.
    """
    if not in_contact:
        return ContactFeatures.no_contact(shape)
    mask = np.zeros(shape, dtype=bool)
    mask.flat[:area] = True
    force = pressure * area * defaults.TACTEL_AREA_M2
    return ContactFeatures(
        in_contact=True,
        force=float(force),
        area=int(area),
        pressure=float(pressure),
        cop_px=np.asarray(cop_px, dtype=float),
        orientation=float(orientation),
        method="moments",
        mask=mask,
        invalid_tactels=0,
    )


class LeafHarness:
    """Tick one behaviour (or a small tree) against fake features and a fake mission clock.

    Parameters
    ----------
    behaviour : py_trees.behaviour.Behaviour
        The leaf (or subtree root) under test; ``setup()`` is called here.
    dt : float
        Control period (s); the clock advances by ``dt`` after every tick.
    features : ContactFeatures, optional
        Initial features (default: a centred contact at the target pressure).
    pose : (4, 4) array, optional
        ``T_gs`` of the pad (default identity).
    """

    def __init__(self, behaviour: py_trees.behaviour.Behaviour, dt: float = 1.0 / defaults.RATE_HZ,
                 features: ContactFeatures | None = None, pose: np.ndarray | None = None) -> None:
        self.behaviour = behaviour
        self.dt = float(dt)
        self.time = 0.0
        self.command = ServoCommand(np.inf, np.inf)
        self.contacts = ContactCloud()
        self._writer = cycle_writer("harness", self.command, self.contacts, self.dt, pose)
        self.set_features(features if features is not None else make_features())
        for node in behaviour.iterate():
            node.setup()

    def set_features(self, features: ContactFeatures, raw: ContactFeatures | None = None) -> None:
        """Features seen from the next tick on (``raw``: unsmoothed, defaults to the same)."""
        self._writer.features = features
        self._writer.features_raw = raw if raw is not None else features

    def set_pose(self, pose: np.ndarray) -> None:
        self._writer.pose = np.asarray(pose, dtype=float)

    def tick(self, features: ContactFeatures | None = None) -> Status:
        """Tick once (with new ``features`` if given), then advance the clock by ``dt``."""
        if features is not None:
            self.set_features(features)
        self._writer.time = self.time
        self.command.clear()
        self.behaviour.tick_once()
        self.time += self.dt
        return self.behaviour.status

    def tick_until(self, done: Callable[[Status], bool] | Status = Status.SUCCESS, max_ticks: int = 10_000,
                   features: Iterable[ContactFeatures] | None = None) -> int:
        """Tick until ``done(status)`` (or the status equals ``done``); return the number of ticks.

        ``features`` may script one feature set per tick. Raises ``AssertionError`` when
        ``max_ticks`` pass first.
        """
        test = done if callable(done) else (lambda s: s == done)
        script = iter(features) if features is not None else None
        for n in range(1, max_ticks + 1):
            status = self.tick(next(script) if script is not None else None)
            if test(status):
                return n
        raise AssertionError(f"{self.behaviour.name}: still {self.behaviour.status} after {max_ticks} ticks")

    @property
    def twist(self) -> np.ndarray:
        """Summed sensor-frame twist ``[vx, vy, vz, wx, wy, wz]`` added during the last tick."""
        return self.command.twist()

    @property
    def errors(self) -> dict[str, float]:
        """Errors (measured − target, metric units) reported during the last tick."""
        return dict(self.command.errors)
