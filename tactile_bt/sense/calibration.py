"""Per-tactel sensor characteristic and its inverse (paper Sec. III, Fig. 1).

Every tactel has its own squashed, saturating characteristic

    raw = offset + span * (1 - exp(-force / force_scale))

with ``raw`` in ADC counts (a float before the simulator adds noise, quantises and clips to
``[0, ADC_MAX]``) and ``force`` in N on that tactel.  ``offset``, ``span`` and ``force_scale``
are ``(rows, cols)`` arrays.

Saturation: the ADC clips at ``ADC_MAX``, and the exponential flattens out, so the inverse is
clipped at the *saturation raw value* ``raw_sat = min(ADC_MAX, offset + SPAN_FRACTION * span)``
(:data:`SPAN_FRACTION` = 0.999).  :attr:`TactelCalibration.saturation_force` is the force at
``raw_sat``; :meth:`TactelCalibration.force_from_raw` never returns more than that, nor NaN/inf.

Nominal tactel (:meth:`TactelCalibration.nominal`): offset :data:`NOMINAL_OFFSET` = 100 counts,
``force_scale`` :data:`NOMINAL_FORCE_SCALE` = 0.25 N and a span chosen so that the ADC saturates
at :data:`NOMINAL_SATURATION_PA` = 10 kPa on one tactel of the pad
(:class:`~tactile_bt.sense.geometry.PadGeometry`): :data:`NOMINAL_SATURATION_N` = 0.25 N per tactel
on the paper's 25 mm^2 tactel.  There the slope at zero force is ~25 000 counts/N (1 count ~ 0.04 mN);
at 0.1 N the response is 18 % below the tangent (the "linear-ish" range), at 0.25 N it is 37 % below.

Layer: sense.
"""

from __future__ import annotations

import math
import os

import numpy as np

from tactile_bt import defaults
from tactile_bt.sense.geometry import PadGeometry

__all__ = [
    "TactelCalibration",
    "NOMINAL_OFFSET",
    "NOMINAL_FORCE_SCALE",
    "NOMINAL_SATURATION_PA",
    "NOMINAL_SATURATION_N",
    "SPAN_FRACTION",
]

#: Raw counts of an unloaded nominal tactel.
NOMINAL_OFFSET: float = 100.0
#: Force scale of the nominal exponential characteristic in N.
NOMINAL_FORCE_SCALE: float = 0.25
#: Pressure on a tactel in Pa at which a nominal tactel reaches ``ADC_MAX``.
NOMINAL_SATURATION_PA: float = 10e3
#: Force per tactel in N at which a nominal tactel of the default pad reaches ``ADC_MAX``
#: (10 kPa x 25 mm^2); a pad of another pitch saturates at ``NOMINAL_SATURATION_PA`` times its
#: tactel area.
NOMINAL_SATURATION_N: float = NOMINAL_SATURATION_PA * PadGeometry().tactel_area_m2
#: Fraction of the span above which the characteristic counts as saturated.
SPAN_FRACTION: float = 0.999

_FIELDS = ("offset", "span", "force_scale")


class TactelCalibration:
    """Per-tactel characteristic ``raw = offset + span (1 - exp(-force / force_scale))``.

    Parameters
    ----------
    offset : array_like
        ``(rows, cols)`` raw counts at zero force (>= 0).
    span : array_like
        ``(rows, cols)`` asymptotic raw increase in counts (> 0).
    force_scale : array_like
        ``(rows, cols)`` force scale in N (> 0).

    Raises
    ------
    ValueError
        If the arrays are not 2-D, differ in shape, are not finite or out of range.
    """

    __slots__ = ("offset", "span", "force_scale", "_raw_sat", "_u_sat", "_f_sat")

    def __init__(self, offset, span, force_scale) -> None:
        arrays = [np.array(a, dtype=float) for a in (offset, span, force_scale)]
        shape = arrays[0].shape
        for name, a in zip(_FIELDS, arrays):
            if a.ndim != 2:
                raise ValueError(
                    f"calibration field {name!r} must be 2-D (rows, cols), got shape {a.shape}"
                )
            if a.shape != shape:
                raise ValueError(
                    f"calibration field {name!r} has shape {a.shape}, expected {shape}"
                )
            if not np.all(np.isfinite(a)):
                raise ValueError(f"calibration field {name!r} contains NaN or inf")
        if np.any(arrays[0] < 0):
            raise ValueError("calibration field 'offset' must be >= 0 counts")
        if np.any(arrays[0] >= defaults.ADC_MAX):
            raise ValueError(f"calibration field 'offset' must be below ADC_MAX={defaults.ADC_MAX}")
        for name, a in zip(_FIELDS[1:], arrays[1:]):
            if np.any(a <= 0):
                raise ValueError(f"calibration field {name!r} must be > 0")
        self.offset, self.span, self.force_scale = arrays
        for a in arrays:
            a.setflags(write=False)
        self._raw_sat = np.minimum(float(defaults.ADC_MAX), self.offset + SPAN_FRACTION * self.span)
        self._u_sat = (self._raw_sat - self.offset) / self.span
        self._f_sat = -self.force_scale * np.log1p(-self._u_sat)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def nominal(cls, rows: int | None = None, cols: int | None = None, *,
                pad: PadGeometry | None = None) -> TactelCalibration:
        """Identical tactels that reach ``ADC_MAX`` at :data:`NOMINAL_SATURATION_PA` (10 kPa) times
        the pad's tactel area (0.25 N on the default pad).

        Parameters
        ----------
        rows, cols : int, optional
            Array size of a pad with the default pitch (a shorthand for
            ``pad=PadGeometry(rows, cols)``).
        pad : PadGeometry, optional
            The pad: its shape and tactel area (default: ``PadGeometry()``, 16 x 16 at 5 mm).
        """
        pad = _pad_of(rows, cols, pad)
        saturation_n = NOMINAL_SATURATION_PA * pad.tactel_area_m2
        span = (defaults.ADC_MAX - NOMINAL_OFFSET) / (
            1.0 - math.exp(-saturation_n / NOMINAL_FORCE_SCALE)
        )
        ones = np.ones(pad.shape)
        return cls(NOMINAL_OFFSET * ones, span * ones, NOMINAL_FORCE_SCALE * ones)

    @classmethod
    def random(
        cls,
        rng: np.random.Generator,
        rows: int | None = None,
        cols: int | None = None,
        spread: float = 0.15,
        *,
        pad: PadGeometry | None = None,
    ) -> TactelCalibration:
        """Every tactel different: nominal parameters times ``exp(spread * N(0, 1))``.

        Parameters
        ----------
        rng : numpy.random.Generator
            Source of all random draws (same seed, same calibration).
        rows, cols : int, optional
            Array size of a pad with the default pitch (shorthand for ``pad=``).
        spread : float
            Relative log-normal spread of offset, span and force scale (0 gives nominal).
        pad : PadGeometry, optional
            The pad (shape and tactel area of the nominal tactel); default ``PadGeometry()``.
        """
        if spread < 0:
            raise ValueError(f"spread must be >= 0, got {spread}")
        pad = _pad_of(rows, cols, pad)
        rows, cols = pad.shape
        nom = cls.nominal(pad=pad)
        factors = np.exp(spread * rng.standard_normal((3, rows, cols)))
        offset = np.minimum(nom.offset * factors[0], 0.5 * defaults.ADC_MAX)
        return cls(offset, nom.span * factors[1], nom.force_scale * factors[2])

    # ------------------------------------------------------------------ mapping
    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the calibrated array."""
        return self.offset.shape

    @property
    def saturation_force(self) -> np.ndarray:
        """``(rows, cols)`` largest force in N that :meth:`force_from_raw` returns, per tactel."""
        return self._f_sat

    @property
    def saturation_raw(self) -> np.ndarray:
        """``(rows, cols)`` raw counts at which each tactel counts as saturated."""
        return self._raw_sat

    def raw_from_force(self, force) -> np.ndarray:
        """Raw counts (float, no noise, no quantisation, no clipping) for a force image in N.

        Negative forces are treated as 0.  ``force`` broadcasts against ``(rows, cols)``.
        """
        f = np.maximum(np.asarray(force, dtype=float), 0.0)
        return self.offset + self.span * -np.expm1(-f / self.force_scale)

    def force_from_raw(self, raw) -> np.ndarray:
        """Force image in N per tactel from raw counts (the calibration inverse).

        ``raw <= offset`` (and NaN, -inf) give 0; ``raw >= saturation_raw`` (and +inf) give
        :attr:`saturation_force`.  The result is always finite and >= 0.
        """
        u = (np.asarray(raw, dtype=float) - self.offset) / self.span
        # fmax/fmin drop NaN in favour of the bound: NaN -> 0, +inf -> saturation, -inf -> 0.
        np.fmax(u, 0.0, out=u)
        np.fmin(u, self._u_sat, out=u)
        np.negative(u, out=u)
        np.log1p(u, out=u)
        u *= self.force_scale
        return np.negative(u, out=u)

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | os.PathLike) -> None:
        """Write the three parameter arrays to an ``.npz`` file."""
        np.savez(path, offset=self.offset, span=self.span, force_scale=self.force_scale)

    @classmethod
    def load(cls, path: str | os.PathLike) -> TactelCalibration:
        """Read a calibration written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            If the file does not exist.
        ValueError
            If the file is not an ``.npz`` archive, lacks a field or holds invalid values; the
            message names the file and the field.
        """
        try:
            archive = np.load(path, allow_pickle=False)
        except FileNotFoundError:
            raise
        except Exception as exc:  # noqa: BLE001 - re-raised with the file name
            raise ValueError(
                f"calibration file {os.fspath(path)!r} is not a readable .npz: {exc}"
            ) from exc
        if not isinstance(archive, np.lib.npyio.NpzFile):
            raise ValueError(f"calibration file {os.fspath(path)!r} is not an .npz archive")
        with archive:
            missing = [k for k in _FIELDS if k not in archive.files]
            if missing:
                raise ValueError(
                    f"calibration file {os.fspath(path)!r} lacks field(s) {', '.join(missing)}"
                )
            fields = [archive[k] for k in _FIELDS]
        try:
            return cls(*fields)
        except ValueError as exc:
            raise ValueError(f"calibration file {os.fspath(path)!r}: {exc}") from exc

    def __repr__(self) -> str:
        return (
            f"TactelCalibration(shape={self.shape}, offset~{self.offset.mean():.1f} counts, "
            f"saturation~{self._f_sat.mean():.3f} N)"
        )


def _pad_of(rows: int | None, cols: int | None, pad: PadGeometry | None) -> PadGeometry:
    """The pad of a calibration: ``pad``, or the default pad with ``rows`` x ``cols`` tactels."""
    if pad is None:
        default = PadGeometry()
        return PadGeometry(default.rows if rows is None else rows, default.cols if cols is None else cols)
    if (rows is not None and rows != pad.rows) or (cols is not None and cols != pad.cols):
        raise ValueError(f"rows x cols {rows} x {cols} differ from the pad's {pad.rows} x {pad.cols}: give one")
    return pad
