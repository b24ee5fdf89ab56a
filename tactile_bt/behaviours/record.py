"""Contact recording: the robot as a ruler (paper Sec. IV). Each cycle in contact, the centre of
pressure is carried to the base frame through the forward kinematics ``T_gs``."""

from __future__ import annotations

from typing import Literal

import numpy as np
from py_trees.common import Status

from tactile_bt.behaviours.base import TactileBehaviour
from tactile_bt.features import local_contact_point

__all__ = ["ContactCloud", "RecordContacts"]


class ContactCloud:
    """Growable store of contact samples in the base (world) frame.

    Columns: point ``x, y, z`` (m), outward surface normal ``nx, ny, nz`` (the object's, i.e.
    −z of the sensor frame), pressure (Pa) and mission time (s).
    """

    COLUMNS = ("x", "y", "z", "nx", "ny", "nz", "pressure", "t")

    def __init__(self, capacity: int = 1024) -> None:
        self._data = np.empty((capacity, len(self.COLUMNS)))
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def append(self, point, normal, pressure: float, t: float) -> None:
        """Add one sample: point and normal (3 each, world frame), pressure (Pa), time (s)."""
        if self._n == self._data.shape[0]:
            self._data = np.concatenate((self._data, np.empty_like(self._data)))
        self._data[self._n] = (*point, *normal, pressure, t)
        self._n += 1

    @property
    def data(self) -> np.ndarray:
        """``(N, 8)`` array of the samples (a view)."""
        return self._data[: self._n]

    @property
    def points(self) -> np.ndarray:
        return self._data[: self._n, 0:3]

    @property
    def normals(self) -> np.ndarray:
        return self._data[: self._n, 3:6]


class RecordContacts(TactileBehaviour):
    """While RUNNING, append the contact point ``T_gs · cop`` of every cycle in contact to the
    mission's contact cloud (``/tactile/contacts``). Never finishes by itself; the feedback
    message counts the samples.

    Parameters
    ----------
    min_spacing_m : float
        Skip a sample closer than this (m) to the previous recorded one (0 keeps all).
    point : str
        ``"cop"``: the centre of pressure (Eq. 1). ``"local"``: where an elongated contact
        crosses the pad centre (:func:`~tactile_bt.features.local_contact_point`), which removes
        the chord bias of the COP on curved lines such as a bent cable; needs the orientation.
    """

    uses = frozenset({"cop", "pressure"})
    fixed_parameters = frozenset({"name", "point"})

    def __init__(self, name: str = "record_contacts", min_spacing_m: float = 0.0,
                 point: Literal["cop", "local"] = "cop") -> None:
        super().__init__(name)
        if point not in ("cop", "local"):
            raise ValueError(f"{name}: point must be 'cop' or 'local', got {point!r}")
        self.point = point
        if point == "local":
            self.uses = frozenset({"cop", "pressure", "orientation"})
        self.set_parameter("min_spacing_m", min_spacing_m)
        self._last: np.ndarray | None = None
        self._in_contact = False

    def set_parameter(self, name: str, value) -> None:
        if name == "min_spacing_m" and not value >= 0:
            raise ValueError(f"{self.name}: min_spacing_m must not be negative, got {value}")
        super().set_parameter(name, float(value) if name == "min_spacing_m" else value)

    # Formatted only when somebody reads it (not every cycle).
    @property
    def feedback_message(self) -> str:
        if self._feedback is None:
            contacts = getattr(self, "contacts", None)
            n = len(contacts) if contacts is not None else 0
            return f"{n} contacts" + ("" if self._in_contact else ", not in contact")
        return self._feedback

    @feedback_message.setter
    def feedback_message(self, message: str) -> None:
        self._feedback = message

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        self.contacts = self.bb.contacts

    def initialise(self) -> None:
        self._last = None

    def update(self) -> Status:
        f = self.features_raw
        cloud = self.contacts
        self._feedback = None
        if not f.in_contact:
            self._in_contact = False
            return Status.RUNNING
        self._in_contact = True
        T = self.pose
        if self.point == "local":
            px = local_contact_point(f)
            cop = (px - ((f.mask.shape[1] - 1) * 0.5, (f.mask.shape[0] - 1) * 0.5)) * f.pitch
        else:
            cop = f.cop
        point = T[:3, :3] @ (cop[0], cop[1], 0.0) + T[:3, 3]
        if self._last is not None and self.min_spacing_m > 0:
            if np.sum((point - self._last) ** 2) < self.min_spacing_m**2:
                return Status.RUNNING
        cloud.append(point.tolist(), (-T[:3, 2]).tolist(), f.pressure, self.now)
        self._last = point
        return Status.RUNNING
