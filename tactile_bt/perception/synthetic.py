"""Synthetic tactile images with known ground truth, for tests and the accuracy study.

All coordinates are in tactel units of the sensor frame: ``[x, y] = [column, row]``, tactel
centres at integers, so tactel ``(r, c)`` covers ``x in [c - 0.5, c + 0.5]`` and
``y in [r - 0.5, r + 0.5]``.  Angles are in rad from +x towards +y.  Force images are in N per
tactel.  Contacts are *tactel-integrated*: the continuous pressure profile is sampled on an
``oversample x oversample`` sub-grid of every tactel and summed, and the result is normalised so
that the whole contact (including any part that falls outside the pad) carries ``force_n``.

:func:`sensor_effects` passes an image through the calibration characteristic, noise, 12-bit
quantisation, clipping and the inverse calibration; :mod:`tactile_bt.experiments.accuracy` uses
these images for the paper's Fig. 4 study.

Layer: perception.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.sense.calibration import TactelCalibration

__all__ = [
    "SHAPE",
    "line_contact",
    "blob_contact",
    "sensor_effects",
    "add_spurious_blob",
    "NOISE_COUNTS",
]

#: Default raw-count noise (1 sigma) of :func:`sensor_effects`: ~1 mN on an unloaded nominal
#: tactel, well below ``defaults.CONTACT_THRESHOLD_N`` (8 mN).
NOISE_COUNTS: float = 25.0
#: Shape of the synthetic images: the paper's 16×16 pad.
SHAPE = (defaults.ROWS, defaults.COLS)


def _integrate(
    profile: Callable[[np.ndarray, np.ndarray], np.ndarray],
    bbox: tuple[float, float, float, float],
    shape: tuple[int, int],
    oversample: int,
    force_n: float,
) -> np.ndarray:
    """Integrate ``profile(x, y)`` over tactels; normalise the whole support to ``force_n``."""
    if oversample < 1:
        raise ValueError(f"oversample must be >= 1, got {oversample}")
    if force_n < 0 or not math.isfinite(force_n):
        raise ValueError(f"force_n must be finite and >= 0, got {force_n}")
    rows, cols = shape
    xmin, xmax, ymin, ymax = bbox
    c0 = min(0, math.floor(xmin + 0.5))
    c1 = max(cols - 1, math.floor(xmax + 0.5))
    r0 = min(0, math.floor(ymin + 0.5))
    r1 = max(rows - 1, math.floor(ymax + 0.5))
    sub = (np.arange(oversample) + 0.5) / oversample - 0.5
    xs = (np.arange(c0, c1 + 1)[:, None] + sub).ravel()
    ys = (np.arange(r0, r1 + 1)[:, None] + sub).ravel()
    values = profile(xs[None, :], ys[:, None])
    nr, nc = r1 - r0 + 1, c1 - c0 + 1
    tactels = values.reshape(nr, oversample, nc, oversample).sum(axis=(1, 3))
    total = tactels.sum()
    if not total > 0:
        return np.zeros(shape)
    tactels *= force_n / total
    return tactels[-r0 : -r0 + rows, -c0 : -c0 + cols].copy()


def line_contact(
    center_px,
    angle_rad: float,
    length_px: float,
    width_px: float,
    force_n: float,
    shape: tuple[int, int] = SHAPE,
    oversample: int = 8,
) -> np.ndarray:
    """Force image of a line-segment (capsule) contact, such as a pen or an edge.

    Parameters
    ----------
    center_px : array_like
        ``[x, y]`` centre of the segment in tactels.
    angle_rad : float
        Direction of the segment in rad from +x towards +y.
    length_px : float
        Length of the segment axis in tactels (>= 0; 0 gives a round contact).
    width_px : float
        Full width at half maximum of the cross profile in tactels (> 0).  The profile is
        ``cos^2(pi d / (2 width_px))`` of the distance ``d`` to the axis, zero for
        ``d >= width_px`` (smooth, compact support of total width ``2 width_px``).
    force_n : float
        Total force in N of the whole contact.
    shape : tuple of int
        ``(rows, cols)`` of the image.
    oversample : int
        Sub-samples per tactel and axis.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols)`` force image in N per tactel; sums to ``force_n`` when the contact lies
        inside the pad.
    """
    if not width_px > 0:
        raise ValueError(f"width_px must be > 0, got {width_px}")
    if not length_px >= 0:
        raise ValueError(f"length_px must be >= 0, got {length_px}")
    cx, cy = (float(v) for v in center_px)
    ux, uy = math.cos(angle_rad), math.sin(angle_rad)
    half = 0.5 * length_px
    x0, y0 = cx - half * ux, cy - half * uy

    def profile(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        dx, dy = x - x0, y - y0
        t = np.clip(dx * ux + dy * uy, 0.0, length_px)
        d = np.hypot(dx - t * ux, dy - t * uy)
        return np.cos(0.5 * math.pi * np.minimum(d / width_px, 1.0)) ** 2  # 0 for d >= width

    reach_x = half * abs(ux) + width_px
    reach_y = half * abs(uy) + width_px
    bbox = (cx - reach_x, cx + reach_x, cy - reach_y, cy + reach_y)
    return _integrate(profile, bbox, shape, oversample, force_n)


def blob_contact(
    center_px,
    sigma_px: float,
    force_n: float,
    shape: tuple[int, int] = SHAPE,
    oversample: int = 8,
) -> np.ndarray:
    """Force image of a round Gaussian contact (e.g. a fingertip or a ball).

    Parameters
    ----------
    center_px : array_like
        ``[x, y]`` centre in tactels.
    sigma_px : float
        Standard deviation of the Gaussian in tactels (> 0); truncated at 4 sigma.
    force_n : float
        Total force in N.
    shape, oversample
        As in :func:`line_contact`.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols)`` force image in N per tactel.
    """
    if not sigma_px > 0:
        raise ValueError(f"sigma_px must be > 0, got {sigma_px}")
    cx, cy = (float(v) for v in center_px)
    reach = 4.0 * sigma_px
    inv = -0.5 / (sigma_px * sigma_px)

    def profile(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        r2 = (x - cx) ** 2 + (y - cy) ** 2
        return np.where(r2 < reach * reach, np.exp(inv * r2), 0.0)

    bbox = (cx - reach, cx + reach, cy - reach, cy + reach)
    return _integrate(profile, bbox, shape, oversample, force_n)


def sensor_effects(
    image,
    rng: np.random.Generator,
    calibration: TactelCalibration | None = None,
    noise_counts: float = NOISE_COUNTS,
    quantise: bool = True,
) -> np.ndarray:
    """Pass a true force image through the sensor and back through its calibration.

    Force -> raw counts (per-tactel characteristic) -> + Gaussian noise -> rounding to integers
    (``quantise``) -> clipping to ``[0, ADC_MAX]`` -> inverse characteristic -> force.

    Parameters
    ----------
    image : array_like
        ``(rows, cols)`` true force image in N per tactel.
    rng : numpy.random.Generator
        Source of the noise.
    calibration : TactelCalibration, optional
        Characteristic used both ways; nominal tactels by default.
    noise_counts : float
        Standard deviation of the raw noise in ADC counts.
    quantise : bool
        Round to integer counts (12-bit ADC).

    Returns
    -------
    numpy.ndarray
        ``(rows, cols)`` measured force image in N per tactel (finite, >= 0, saturated tactels
        clipped at the calibration's saturation force).
    """
    img = np.asarray(image, dtype=float)
    cal = calibration if calibration is not None else TactelCalibration.nominal(*img.shape)
    raw = cal.raw_from_force(img)
    if noise_counts > 0:
        raw = raw + rng.normal(0.0, noise_counts, img.shape)
    if quantise:
        raw = np.rint(raw)
    np.clip(raw, 0.0, float(defaults.ADC_MAX), out=raw)
    return cal.force_from_raw(raw)


def add_spurious_blob(
    image,
    rng: np.random.Generator,
    force_n: float = 0.05,
    min_distance_px: int = 3,
    threshold: float = defaults.CONTACT_THRESHOLD_N,
) -> np.ndarray:
    """Add a single-tactel spike at a random tactel away from the existing contact.

    Parameters
    ----------
    image : array_like
        ``(rows, cols)`` force image in N per tactel (not modified).
    rng : numpy.random.Generator
        Chooses the tactel.
    force_n : float
        Force of the spike in N.
    min_distance_px : int
        Minimum Chebyshev distance in tactels to every tactel above ``threshold / 4``, so the
        spike forms a separate 8-connected region.
    threshold : float
        Contact threshold in N per tactel.

    Returns
    -------
    numpy.ndarray
        A copy of ``image`` with the spike added.

    Raises
    ------
    ValueError
        If no tactel is far enough from the contact.
    """
    img = np.array(image, dtype=float)
    loaded = img > 0.25 * threshold
    size = 2 * int(min_distance_px) + 1
    forbidden = ndimage.binary_dilation(loaded, np.ones((size, size), dtype=bool))
    free = np.flatnonzero(~forbidden)
    if free.size == 0:
        raise ValueError("no tactel is far enough from the contact for a spurious blob")
    img.ravel()[free[rng.integers(free.size)]] += force_n
    return img
