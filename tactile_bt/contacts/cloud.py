"""The contact cloud: every contact sample of a mission in the base (world) frame.

The mission owns one cloud and puts it on the blackboard (``/tactile/contacts``); the
``record_contacts`` leaf appends to it (the robot as a ruler, paper Sec. IV), and the mission's
outputs, the reconstruction and the accuracy figures read it.

Layer: contacts.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ContactCloud"]


class ContactCloud:
    """Growable store of contact samples in the base (world) frame.

    Columns: point ``x, y, z`` (m), outward surface normal ``nx, ny, nz`` (the object's, i.e.
    −z of the sensor frame), pressure (Pa) and mission time (s).

    The cloud also remembers which voxels hold a sample (:meth:`fresh`), so every recorder of a
    mission thins against the same set: a stripe scan that passes a spot twice stores it once.
    """

    COLUMNS = ("x", "y", "z", "nx", "ny", "nz", "pressure", "t")

    def __init__(self, capacity: int = 1024) -> None:
        self._data = np.empty((capacity, len(self.COLUMNS)))
        self._n = 0
        self._voxels: dict[float, set] = {}

    def __len__(self) -> int:
        return self._n

    def _reserve(self, extra: int) -> None:
        need = self._n + extra
        if need > self._data.shape[0]:
            grown = np.empty((max(need, 2 * self._data.shape[0]), len(self.COLUMNS)))
            grown[: self._n] = self._data[: self._n]
            self._data = grown

    def append(self, point, normal, pressure: float, t: float) -> None:
        """Add one sample: point and normal (3 each, world frame), pressure (Pa), time (s)."""
        if self._n == self._data.shape[0]:
            self._reserve(1)
        self._data[self._n] = (*point, *normal, pressure, t)
        self._n += 1

    def extend(self, points: np.ndarray, normal, pressure, t: float) -> None:
        """Add ``k`` samples: ``(k, 3)`` points (m, world), one normal or ``(k, 3)`` normals,
        one pressure or ``(k,)`` pressures (Pa), all at mission time ``t`` (s)."""
        k = len(points)
        if k == 0:
            return
        self._reserve(k)
        block = self._data[self._n: self._n + k]
        block[:, 0:3] = points
        block[:, 3:6] = normal
        block[:, 6] = pressure
        block[:, 7] = t
        self._n += k

    def fresh(self, points: np.ndarray, voxel_m: float) -> np.ndarray:
        """Mask of the ``(k, 3)`` points (m) whose voxel of edge ``voxel_m`` holds no sample yet
        (one per voxel within the batch too); marks those voxels as taken."""
        keys = np.floor(np.asarray(points) / voxel_m).astype(np.int64)
        # one int per voxel: 21 bits per axis covers ±1 km at 1 mm
        packed = ((keys[:, 0] & 0x1FFFFF) << 42) | ((keys[:, 1] & 0x1FFFFF) << 21) | (keys[:, 2] & 0x1FFFFF)
        seen = self._voxels.setdefault(voxel_m, set())
        mask = np.zeros(len(packed), dtype=bool)
        for i, key in enumerate(packed.tolist()):
            if key not in seen:
                seen.add(key)
                mask[i] = True
        return mask

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
