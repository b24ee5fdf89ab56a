"""Moving-average smoothing of contact features (paper Sec. V: the 10 most recent samples).

All filters are O(1) per sample: a fixed-size ring buffer with a running sum that is recomputed
exactly every ``n`` pushes, so rounding errors cannot accumulate over a long mission.  They run
once per control cycle (4 ms at 250 Hz).

Layer: perception.
"""

from __future__ import annotations

import math

from tactile_bt import defaults
from tactile_bt.perception.features import ContactFeatures

__all__ = ["MovingAverage", "AngleMovingAverage", "FeatureSmoother"]

_HALF_PI = 0.5 * math.pi


class MovingAverage:
    """Mean of the last ``n`` finite samples of a scalar.

    Parameters
    ----------
    n : int
        Window length in samples (>= 1).

    Notes
    -----
    NaN and infinite samples are ignored (they neither enter the window nor push old samples
    out).  :attr:`value` is NaN while the window is empty.
    """

    __slots__ = ("n", "_buf", "_next", "_count", "_sum", "_since_exact")

    def __init__(self, n: int = defaults.SMOOTHING_SAMPLES) -> None:
        if int(n) != n or n < 1:
            raise ValueError(f"window length must be a positive integer, got {n!r}")
        self.n = int(n)
        self._buf = [0.0] * self.n
        self.reset()

    def reset(self) -> None:
        """Forget all samples."""
        self._next = 0
        self._count = 0
        self._sum = 0.0
        self._since_exact = 0

    def push(self, x: float) -> float:
        """Add a sample and return the current mean (NaN if still empty)."""
        x = float(x)
        if x - x != 0.0:  # NaN or +-inf
            return self.value
        i = self._next
        if self._count == self.n:
            self._sum += x - self._buf[i]
        else:
            self._sum += x
            self._count += 1
        self._buf[i] = x
        self._next = i + 1 if i + 1 < self.n else 0
        self._since_exact += 1
        if self._since_exact >= self.n:
            self._since_exact = 0
            self._sum = math.fsum(self._buf[: self._count] if self._count < self.n else self._buf)
        return self._sum / self._count

    @property
    def value(self) -> float:
        """Current mean, NaN when no finite sample has been pushed since the last reset."""
        return self._sum / self._count if self._count else math.nan

    def __len__(self) -> int:
        return self._count


class AngleMovingAverage:
    """Moving average of axis angles (modulo pi), e.g. the contact orientation.

    Averages the doubled-angle unit vectors ``(cos 2a, sin 2a)`` over the last ``n`` finite
    samples and returns ``0.5 atan2(mean sin, mean cos)`` in ``(-pi/2, pi/2]``, so samples on
    both sides of the +-pi/2 wrap average to about +-pi/2, not 0.  The value is NaN while empty
    and when the samples cancel exactly (e.g. 0 and pi/2: no meaningful mean axis).

    Parameters
    ----------
    n : int
        Window length in samples (>= 1).
    """

    __slots__ = ("_c", "_s")

    def __init__(self, n: int = defaults.SMOOTHING_SAMPLES) -> None:
        self._c = MovingAverage(n)
        self._s = MovingAverage(n)

    @property
    def n(self) -> int:
        """Window length in samples."""
        return self._c.n

    def reset(self) -> None:
        """Forget all samples."""
        self._c.reset()
        self._s.reset()

    def push(self, angle: float) -> float:
        """Add an angle in rad (NaN/inf ignored) and return the current mean angle."""
        a = float(angle)
        if a - a == 0.0:
            self._c.push(math.cos(2.0 * a))
            self._s.push(math.sin(2.0 * a))
        return self.value

    @property
    def value(self) -> float:
        """Mean axis angle in rad in ``(-pi/2, pi/2]``; NaN when empty or undefined."""
        c, s = self._c.value, self._s.value
        if not math.hypot(c, s) > 1e-12:  # also catches NaN (empty)
            return math.nan
        a = 0.5 * math.atan2(s, c)
        return a + math.pi if a <= -_HALF_PI else a

    def __len__(self) -> int:
        return len(self._c)


class FeatureSmoother:
    """Moving averages of force, pressure and orientation of successive :class:`ContactFeatures`.

    Parameters
    ----------
    n : int
        Window length in samples (default ``defaults.SMOOTHING_SAMPLES`` = 10, paper Sec. V).

    Notes
    -----
    - Force and pressure are averaged independently, so the smoothed pressure is the mean of the
      per-frame pressures, not ``mean force / area``.
    - The centre of pressure, area and mask are passed through unsmoothed.
    - A frame without contact resets all averages and is returned unchanged.
    - A frame with NaN orientation (not computed, or no dominant axis) leaves the angle average
      untouched and is returned with NaN orientation.
    """

    __slots__ = ("_force", "_pressure", "_angle")

    def __init__(self, n: int = defaults.SMOOTHING_SAMPLES) -> None:
        self._force = MovingAverage(n)
        self._pressure = MovingAverage(n)
        self._angle = AngleMovingAverage(n)

    def reset(self) -> None:
        """Forget all samples."""
        self._force.reset()
        self._pressure.reset()
        self._angle.reset()

    def __call__(self, f: ContactFeatures) -> ContactFeatures:
        """Push one frame's features and return them with smoothed force/pressure/orientation."""
        if not f.in_contact:
            self.reset()
            return f
        force = self._force.push(f.force)
        pressure = self._pressure.push(f.pressure)
        angle = f.orientation
        if angle == angle:
            angle = self._angle.push(angle)
        if force != force:  # every force so far non-finite: keep the frame's own value
            force = f.force
        if pressure != pressure:
            pressure = f.pressure
        # Built field by field, in their order: dataclasses.replace costs three times as much.
        return ContactFeatures(f.in_contact, force, f.area, pressure, f.cop_px, angle, f.method, f.mask,
                               f.invalid_tactels, f.pad, f.image, f.others_force, f.others_tactels, f.others_cop_px)
