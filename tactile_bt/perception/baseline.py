"""The "obvious" scikit-image implementation of the contact features, as a speed baseline.

:func:`extract_with_regionprops` computes the same features as
:func:`tactile_bt.perception.features.extract` with ``method="moments"`` the way one would first write it:
``skimage.measure.label`` (8-connectivity) + ``skimage.measure.regionprops`` with the force
image as intensity image, the largest region by area (ties: larger force), its
``centroid_weighted`` as COP and its ``moments_weighted_central`` for the orientation.
``tactile-bt bench`` times both on the same frame; the tests check that they agree.

Layer: perception.
"""

from __future__ import annotations

import math

import numpy as np
from skimage.measure import label, regionprops

from tactile_bt import defaults
from tactile_bt.perception.features import MIN_ANISOTROPY, ContactFeatures
from tactile_bt.sense.geometry import PadGeometry

__all__ = ["extract_with_regionprops"]


def extract_with_regionprops(
    image,
    threshold: float = defaults.CONTACT_THRESHOLD_N,
    pad: PadGeometry | None = None,
    min_anisotropy: float = MIN_ANISOTROPY,
) -> ContactFeatures:
    """Contact features by ``skimage.measure.label`` + ``regionprops`` (reference, slow).

    Parameters
    ----------
    image : array_like
        ``(rows, cols)`` force image in N per tactel (x = column, y = row).
    threshold : float
        Binarisation threshold in N per tactel (strictly greater is in contact).
    pad : PadGeometry, optional
        The pad the image comes from, of the image's shape (default: the paper's 5 mm pitch,
        the image's shape), as in ``extract``.
    min_anisotropy : float
        Minimum covariance anisotropy for a defined orientation (as in ``extract``).

    Returns
    -------
    ContactFeatures
        With ``method="moments"``.
    """
    img = np.array(image, dtype=float)
    if img.ndim != 2:
        raise ValueError(f"need a 2-D (rows, cols) force image, got ndim={img.ndim}")
    if pad is None:
        pad = PadGeometry(*img.shape)
    elif pad.shape != img.shape:
        raise ValueError(f"the image has {img.shape[0]}x{img.shape[1]} tactels, the pad {pad.rows}x{pad.cols}")
    bad = ~np.isfinite(img) | (img < 0)
    n_bad = int(bad.sum())
    img[bad] = 0.0
    labels = label(img > threshold, connectivity=2)
    regions = regionprops(labels, intensity_image=img)
    if not regions:
        return ContactFeatures.no_contact(img.shape, n_bad, "moments", pad)
    region = max(regions, key=lambda r: (r.area, float(r.image_intensity[r.image].sum())))
    force = float(region.image_intensity[region.image].sum())
    if not force > 0:
        return ContactFeatures.no_contact(img.shape, n_bad, "moments", pad)
    row, col = region.centroid_weighted
    mu = region.moments_weighted_central  # mu[p, q]: row order p, column order q
    mu20, mu11, mu02 = mu[0, 2] / force, mu[1, 1] / force, mu[2, 0] / force
    eig_sum = mu20 + mu02
    eig_diff = math.hypot(mu20 - mu02, 2.0 * mu11)
    if eig_sum > 0 and eig_diff >= min_anisotropy * eig_sum:
        angle = 0.5 * math.atan2(2.0 * mu11, mu20 - mu02)
        if angle <= -0.5 * math.pi:
            angle += math.pi
    else:
        angle = math.nan
    area = int(region.area)
    return ContactFeatures(
        in_contact=True,
        force=force,
        area=area,
        pressure=force / (area * pad.pitch**2),
        cop_px=np.array([col, row]),
        orientation=angle,
        method="moments",
        mask=labels == region.label,
        invalid_tactels=n_bad,
        pad=pad,
    )
