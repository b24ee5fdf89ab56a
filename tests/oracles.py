"""Reference implementations the compiled kernels are checked against (``tests/perception/test_kernels.py``).

These are the numpy/scipy versions the package used before its hot paths were compiled, kept
verbatim: feature extraction (``scipy.ndimage.label`` with 8-connectivity, the moments as one
matrix product with a ``[1, x, y, x², xy, y²]`` basis) and the local contact point. They are slow and obviously right; the package's versions must give
the same answers to the tolerances stated in the tests.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.perception.features import (LOCAL_FIT_DEGREE, LOCAL_WINDOW_PX, MIN_ANISOTROPY, ContactFeatures,
                                            hough_orientation)
from tactile_bt.sense.geometry import PadGeometry

__all__ = ["extract", "local_contact_point", "central_moments"]

_HALF_PI = 0.5 * math.pi
_EIGHT = np.ones((3, 3), dtype=bool)


def _basis(shape):
    rows, cols = shape
    y, x = np.divmod(np.arange(rows * cols, dtype=float), cols)
    basis = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
    limit = np.finfo(float).max / (rows * cols * (max(rows, cols) ** 2 + 1) * 4.0)
    return basis, np.ascontiguousarray(basis[:, :3]), float(limit)


def _sanitise(img, limit):
    bad = ~(img >= 0.0) | (img == math.inf)
    n_bad = int(np.count_nonzero(bad))
    clean = np.where(bad, 0.0, img)
    np.minimum(clean, limit, out=clean)
    return clean, n_bad


def _moment_angle(mu20, mu11, mu02, min_anisotropy):
    trace = mu20 + mu02
    if not trace > 0.0:
        return math.nan
    diff = mu20 - mu02
    if math.hypot(diff, 2.0 * mu11) < min_anisotropy * trace:
        return math.nan
    a = 0.5 * math.atan2(2.0 * mu11, diff)
    return a + math.pi if a <= -_HALF_PI else a


def central_moments(features: ContactFeatures) -> tuple[float, float, float]:
    """``(mu20, mu11, mu02)`` of a region, force-weighted, as :func:`extract` computes them."""
    img, mask = features.image, features.mask
    basis, _, _ = _basis(mask.shape)
    m = ((img * mask).ravel() @ basis).tolist()
    f = m[0]
    cx = min(max(m[1] / f, 0.0), mask.shape[1] - 1.0)
    cy = min(max(m[2] / f, 0.0), mask.shape[0] - 1.0)
    return max(m[3] / f - cx * cx, 0.0), m[4] / f - cx * cy, max(m[5] / f - cy * cy, 0.0)


def extract(image, threshold=defaults.CONTACT_THRESHOLD_N, method="moments", pad=None, *,
            min_anisotropy=MIN_ANISOTROPY) -> ContactFeatures:
    """The feature extraction by ``scipy.ndimage.label`` and a moment basis."""
    img = np.asarray(image, dtype=float)
    shape = img.shape
    if pad is None:
        pad = PadGeometry(*shape) if min(shape) >= 1 else PadGeometry()
    pitch = pad.pitch
    if img.size == 0:
        return ContactFeatures.no_contact(shape, 0, method, pad)
    basis, basis_cop, limit = _basis(shape)
    n_bad = 0
    if not (img.min() >= 0.0 and img.max() < limit):
        img, n_bad = _sanitise(img, limit)
    binary = img > threshold
    labels, n = ndimage.label(binary, _EIGHT)
    if n == 0:
        return ContactFeatures.no_contact(shape, n_bad, method, pad)
    if n == 1:
        mask = binary
    else:
        flat_labels = labels.ravel()
        sizes = np.bincount(flat_labels).tolist()
        sizes[0] = 0  # background
        top = max(sizes)
        if sizes.count(top) == 1:
            best = sizes.index(top)
        else:  # tie in size: the larger force wins
            forces = np.bincount(flat_labels, weights=img.ravel()).tolist()
            best = max((k for k in range(1, n + 1) if sizes[k] == top), key=forces.__getitem__)
        mask = labels == best
    m = ((img * mask).ravel() @ (basis_cop if method is None else basis)).tolist()
    f = m[0]
    if not (f > 0.0 and math.isfinite(f)):
        return ContactFeatures.no_contact(shape, n_bad, method, pad)
    area = int(np.count_nonzero(mask))
    cx = min(max(m[1] / f, 0.0), shape[1] - 1.0)
    cy = min(max(m[2] / f, 0.0), shape[0] - 1.0)
    if method is None:
        angle = math.nan
    else:
        mu20 = max(m[3] / f - cx * cx, 0.0)
        mu11 = m[4] / f - cx * cy
        mu02 = max(m[5] / f - cy * cy, 0.0)
        angle = _moment_angle(mu20, mu11, mu02, min_anisotropy)
        if method == "hough" and angle == angle:
            angle = hough_orientation(img, mask)
    return ContactFeatures(
        in_contact=True,
        force=f,
        area=area,
        pressure=f / (area * pitch * pitch),
        cop_px=np.array((cx, cy)),
        orientation=angle,
        method=method,
        mask=mask,
        invalid_tactels=n_bad,
        pad=pad,
        image=img,
    )


def local_contact_point(features: ContactFeatures, window_px: float = LOCAL_WINDOW_PX,
                        degree: int = LOCAL_FIT_DEGREE) -> np.ndarray:
    """Where an elongated contact crosses the pad's centre, by numpy on the whole image: the
    weighted least-squares polynomial of ``degree`` across the major axis (``numpy.linalg.lstsq``
    on the design matrix), lowered while it is rank-deficient, taken where the axis passes
    closest to the pad centre."""
    alpha = features.orientation
    if not features.in_contact or alpha != alpha or features.image is None:
        return features.cop_px
    ux, uy = math.cos(alpha), math.sin(alpha)
    cx, cy = features.cop_px.tolist()
    px, py = features.pad.centre_px
    centre_along = (px - cx) * ux + (py - cy) * uy
    ox, oy = cx + centre_along * ux, cy + centre_along * uy
    ys, xs = np.nonzero(features.mask)
    t = ((xs - ox) * ux + (ys - oy) * uy) / window_px
    d = (ys - oy) * ux - (xs - ox) * uy
    w = features.image[ys, xs] * np.maximum(1.0 - np.abs(t), 0.0)
    keep = w > 0
    if not keep.any():
        return features.cop_px
    t, d, root = t[keep], d[keep], np.sqrt(w[keep])
    for n in range(degree + 1, 0, -1):
        design = np.vander(t, n, increasing=True) * root[:, None]
        coef, _, rank, _ = np.linalg.lstsq(design, d * root, rcond=None)
        if rank == n:
            return np.array((ox - coef[0] * uy, oy + coef[0] * ux))
    return features.cop_px
