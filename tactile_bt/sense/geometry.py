"""The pad's geometry: the one place for its size and for tactel ↔ metre conversions.

A :class:`PadGeometry` is built from a scene's ``sensor:`` section (or a real module's
configuration) and passed to everything that needs the pad's extent: calibration, feature
extraction, the leaves' ``px`` units and logged errors, the contact recorder and the metrics.

Conventions (docs/architecture.md): the sensor frame's origin is the pad centre, x along increasing column
index, y along increasing row index; tactel ``[x, y] = [column, row]`` centres sit at integers,
so the centre of a 16×16 pad is at ``(7.5, 7.5)`` px.

Layer: sense.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_bt import defaults

__all__ = ["PadGeometry"]


@dataclass(frozen=True)
class PadGeometry:
    """A rectangular tactile array.

    Parameters
    ----------
    rows, cols : int
        Tactels along the sensor y and x axes (16 × 16 for the paper's module).
    pitch : float
        Distance between tactel centres (m); 5 mm for the paper's module.
    """

    rows: int = defaults.ROWS
    cols: int = defaults.COLS
    pitch: float = defaults.PITCH_M

    def __post_init__(self) -> None:
        if int(self.rows) != self.rows or int(self.cols) != self.cols or self.rows < 1 or self.cols < 1:
            raise ValueError(f"a pad needs whole numbers of rows and columns >= 1, got {self.rows} x {self.cols}")
        if not (np.isfinite(self.pitch) and self.pitch > 0):
            raise ValueError(f"a pad needs a finite pitch > 0 m, got {self.pitch}")

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``, the shape of the pad's images."""
        return (int(self.rows), int(self.cols))

    @property
    def tactels(self) -> int:
        """Number of tactels."""
        return int(self.rows) * int(self.cols)

    @property
    def tactel_area_m2(self) -> float:
        """Area of one tactel (m²)."""
        return self.pitch * self.pitch

    @property
    def centre_px(self) -> tuple[float, float]:
        """The pad centre ``(x, y)`` in tactel units (7.5, 7.5 on a 16×16 pad)."""
        return ((self.cols - 1) * 0.5, (self.rows - 1) * 0.5)

    @property
    def size_m(self) -> tuple[float, float]:
        """Width along x and height along y of the sensing area (m)."""
        return (self.cols * self.pitch, self.rows * self.pitch)

    @property
    def half_diagonal_m(self) -> float:
        """Distance from the pad centre to a corner of the sensing area (m)."""
        w, h = self.size_m
        return 0.5 * float(np.hypot(w, h))

    @property
    def half_width_m(self) -> float:
        """Half of the longer side (m): a turn of the pad by θ rad moves its border by about this
        times θ."""
        return 0.5 * max(self.size_m)

    def px_to_m(self, px) -> np.ndarray:
        """Points ``[..., (x, y)]`` in tactel units → metres in the sensor frame."""
        cx, cy = self.centre_px
        p = np.asarray(px, dtype=float)
        return (p - np.array([cx, cy])) * self.pitch

    def xy_px_to_m(self, x: float, y: float) -> tuple[float, float]:
        """One point in tactel units → ``(x, y)`` in metres, as Python floats (per-cycle code)."""
        return ((x - (self.cols - 1) * 0.5) * self.pitch, (y - (self.rows - 1) * 0.5) * self.pitch)

    def m_to_px(self, m) -> np.ndarray:
        """Points ``[..., (x, y)]`` in metres in the sensor frame → tactel units."""
        cx, cy = self.centre_px
        return np.asarray(m, dtype=float) / self.pitch + np.array([cx, cy])

    def corners_m(self) -> np.ndarray:
        """The four corners of the sensing area in the sensor frame, ``(4, 3)`` (m, z = 0)."""
        w, h = self.size_m
        return np.array([[-w, -h, 0], [w, -h, 0], [w, h, 0], [-w, h, 0]]) * 0.5
