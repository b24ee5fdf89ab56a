"""Synthetic tactile images with known ground truth, and the perception accuracy study.

All coordinates are in tactel units of the sensor frame: ``[x, y] = [column, row]``, tactel
centres at integers, so tactel ``(r, c)`` covers ``x in [c - 0.5, c + 0.5]`` and
``y in [r - 0.5, r + 0.5]``.  Angles are in rad from +x towards +y.  Force images are in N per
tactel.  Contacts are *tactel-integrated*: the continuous pressure profile is sampled on an
``oversample x oversample`` sub-grid of every tactel and summed, and the result is normalised so
that the whole contact (including any part that falls outside the pad) carries ``force_n``.

:func:`orientation_comparison` reproduces the paper's Fig. 4 study (Hough vs. moments) and
:func:`cop_accuracy` the centre-of-pressure accuracy, both on contacts passed through
:func:`sensor_effects` (calibration characteristic, noise, 12-bit quantisation, clipping and the
inverse calibration) with a spurious one-tactel spike added away from the contact.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.perception.features import extract, wrap_half_pi

__all__ = [
    "line_contact",
    "blob_contact",
    "sensor_effects",
    "add_spurious_blob",
    "orientation_comparison",
    "cop_accuracy",
    "NOISE_COUNTS",
]

#: Default raw-count noise (1 sigma) of :func:`sensor_effects`: ~1 mN on an unloaded nominal
#: tactel, well below ``defaults.CONTACT_THRESHOLD_N`` (8 mN).
NOISE_COUNTS: float = 25.0
_SHAPE = (defaults.ROWS, defaults.COLS)


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
    shape: tuple[int, int] = _SHAPE,
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
    shape: tuple[int, int] = _SHAPE,
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


def _inside_centre(rng, reach_xy, jitter, shape=_SHAPE):
    """Random centre within +-jitter of the pad centre that keeps the support inside the pad."""
    centre = np.empty(2)
    for k, (n, reach) in enumerate(zip(shape[::-1], reach_xy)):
        mid = 0.5 * (n - 1)
        room = max(0.0, min(jitter, mid + 0.5 - reach))
        centre[k] = mid + rng.uniform(-room, room)
    return centre


def _line_trial(rng, angle, length, width, force, jitter):
    reach = 0.5 * length * np.abs([math.cos(angle), math.sin(angle)]) + width
    centre = _inside_centre(rng, reach, jitter)
    img = line_contact(centre, angle, length, width, force)
    img = sensor_effects(add_spurious_blob(img, rng), rng)
    return centre, img


def orientation_comparison(
    angles_deg: Sequence[float] = (30, 45, 60, 75, 90, 120, 150),
    trials: int = 20,
    seed: int = 0,
    lengths_px: Sequence[float] = (6, 9, 12),
    width_px: float = 2.0,
    force_n: float = 2.0,
) -> dict:
    """Angle error of the moments and Hough methods on line contacts (paper Fig. 4).

    Each trial draws a line of one of ``lengths_px`` (cycled) with FWHM ``width_px``, centred
    within +-0.5 tactel of the pad centre (less where it would leave the pad), carrying
    ``force_n`` N, plus a spurious spike, noise and quantisation (:func:`sensor_effects`).

    Returns
    -------
    dict
        ``angles_deg`` (list), ``moments`` and ``hough`` (lists, per-angle mean absolute error
        in degrees, modulo 180), ``moments_max``/``hough_max`` (worst error in degrees, over all
        trials), ``moments_nan``/``hough_nan`` (trials without an orientation; they count as
        90 degree errors), ``mean_area`` (tactels) and ``trials``.
    """
    rng = np.random.default_rng(seed)
    out = {"angles_deg": [float(a) for a in angles_deg], "moments": [], "hough": []}
    worst = {"moments": 0.0, "hough": 0.0}
    nans = {"moments": 0, "hough": 0}
    areas = []
    for angle_deg in angles_deg:
        truth = math.radians(angle_deg)
        errs = {"moments": [], "hough": []}
        for t in range(trials):
            length = lengths_px[t % len(lengths_px)]
            _, img = _line_trial(rng, truth, length, width_px, force_n, 0.5)
            for method in ("moments", "hough"):
                f = extract(img, method=method)
                if method == "moments":
                    areas.append(f.area)
                if math.isnan(f.orientation):
                    nans[method] += 1
                    err = 90.0
                else:
                    err = abs(math.degrees(wrap_half_pi(f.orientation - truth)))
                errs[method].append(err)
        for method in ("moments", "hough"):
            out[method].append(float(np.mean(errs[method])))
            worst[method] = max(worst[method], float(np.max(errs[method])))
    out.update(
        moments_max=worst["moments"],
        hough_max=worst["hough"],
        moments_nan=nans["moments"],
        hough_nan=nans["hough"],
        mean_area=float(np.mean(areas)),
        trials=int(trials),
    )
    return out


def cop_accuracy(trials: int = 50, seed: int = 0, force_n: float = 2.0) -> dict:
    """Centre-of-pressure error of :func:`~tactile_bt.perception.features.extract` in tactels.

    Lines: random direction, length 6, 9 or 12, FWHM 2 tactels; blobs: sigma 1 to 2 tactels.
    Centres are uniform within +-1.5 tactels of the pad centre (less where the contact would
    leave the pad); every image carries a spurious
    spike, noise and quantisation.

    Returns
    -------
    dict
        ``line_rms_px``, ``line_max_px``, ``blob_rms_px``, ``blob_max_px`` (tactels) and
        ``trials``.
    """
    rng = np.random.default_rng(seed)
    lines, blobs = [], []
    for t in range(trials):
        angle = rng.uniform(0.0, math.pi)
        centre, img = _line_trial(rng, angle, (6, 9, 12)[t % 3], 2.0, force_n, 1.5)
        lines.append(np.hypot(*(extract(img, method=None).cop_px - centre)))
        sigma = rng.uniform(1.0, 2.0)
        centre = _inside_centre(rng, (4.0 * sigma, 4.0 * sigma), 1.5)
        img = blob_contact(centre, sigma, force_n)
        img = sensor_effects(add_spurious_blob(img, rng), rng)
        blobs.append(np.hypot(*(extract(img, method=None).cop_px - centre)))
    lines_a, blobs_a = np.asarray(lines), np.asarray(blobs)
    return {
        "line_rms_px": float(np.sqrt(np.mean(lines_a**2))),
        "line_max_px": float(lines_a.max()),
        "blob_rms_px": float(np.sqrt(np.mean(blobs_a**2))),
        "blob_max_px": float(blobs_a.max()),
        "trials": int(trials),
    }
