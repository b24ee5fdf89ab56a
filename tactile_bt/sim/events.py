"""Scene events: displace an object once when the mission time reaches a given instant.

The paper's rolling experiment (Fig. 11) displaces the object after 4 s; a scene says so with

.. code-block:: yaml

    events:
      - {at_s: 4.0, object: 0, translate: [0.0, -0.01, 0.0]}
      - {at_s: 8.0, object: 0, rotate_deg: [0, 0, 15]}

An event turns the object about its own origin by the extrinsic x-y-z angles ``rotate_deg``
(degrees, world axes), then shifts it by ``translate`` (m, world frame); see
:meth:`tactile_bt.sim.objects.SimObject.moved`. :meth:`tactile_bt.sim.world.World.update`
applies the events that are due, once each, in the order of their times (events at the same
time in the order of the file), and tells the sensor model that the objects moved.

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ObjectEvent", "EventSchedule"]

#: Mission times are multiples of the control period; this absorbs their rounding.
TIME_TOLERANCE_S = 1.0e-9


@dataclass(frozen=True)
class ObjectEvent:
    """Move scene object ``object`` (its index in ``objects``) at mission time ``at_s`` (s)."""

    at_s: float
    object: int
    translate: tuple = (0.0, 0.0, 0.0)
    rotate_deg: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not self.at_s >= 0:
            raise ValueError(f"event at_s must be >= 0, got {self.at_s!r}")
        if len(self.translate) != 3 or len(self.rotate_deg) != 3:
            raise ValueError("event translate and rotate_deg must have 3 entries")

    def apply(self, objects: list) -> None:
        """Replace ``objects[self.object]`` by its displaced copy (in place in the list)."""
        objects[self.object] = objects[self.object].moved(self.translate, self.rotate_deg)


class EventSchedule:
    """The events of one world, each applied once.

    Parameters
    ----------
    events : iterable of ObjectEvent
    """

    def __init__(self, events=()) -> None:
        self.events = sorted(events, key=lambda e: e.at_s)  # stable: file order at equal times
        self._next = 0

    def __len__(self) -> int:
        return len(self.events)

    @property
    def pending(self) -> list:
        """Events not yet applied."""
        return self.events[self._next:]

    def due(self, t: float) -> list:
        """The events not yet applied whose time has come at mission time ``t``; marks them
        applied."""
        start = self._next
        while self._next < len(self.events) and self.events[self._next].at_s <= t + TIME_TOLERANCE_S:
            self._next += 1
        return self.events[start:self._next]

    def apply_due(self, t: float, objects: list) -> list:
        """Apply the due events to ``objects`` (a list, changed in place); returns them."""
        fired = self.due(t)
        for event in fired:
            event.apply(objects)
        return fired
