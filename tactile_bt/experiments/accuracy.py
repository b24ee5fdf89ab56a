"""Feature accuracy on synthetic contacts (``tactile-bt accuracy``): the paper's Fig. 4 study of
the orientation error of the Hough transform and of image moments, and the accuracy of the
centre of pressure.

Every contact is tactel-integrated and passed through
:func:`~tactile_bt.perception.synthetic.sensor_effects` (calibration characteristic, noise,
12-bit quantisation, clipping and the inverse calibration) with a spurious one-tactel spike
added away from the contact.

Layer: experiments.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tactile_bt.perception.features import extract, wrap_half_pi
from tactile_bt.perception.synthetic import SHAPE, add_spurious_blob, blob_contact, line_contact, sensor_effects

__all__ = ["orientation_comparison", "cop_accuracy"]


def _inside_centre(rng, reach_xy, jitter, shape=SHAPE):
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
