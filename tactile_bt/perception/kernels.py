"""Compiled loops of the feature extraction on one small force image (numba, nopython).

Kernels, each a few passes over the ``rows × cols`` tactels without a temporary array,
where numpy would spend most of its time in per-call overhead on 256 values:

* :func:`largest_region` — sanitise the image, label the regions above the threshold with
  8-connectivity, pick the largest (ties: larger force, then the one met first in row-major
  order, as ``scipy.ndimage.label`` numbers them), or the one that comes nearest a given point,
  and sum its moments ``[1, x, y, x², xy, y²]``;
* :func:`windowed_line_sums` — the sums of a force-weighted polynomial fit of an elongated
  region's centre across its axis under a triangular window along it (the local contact
  point of an elongated contact), and :func:`line_fit_offset`, the solve of that fit.

They are compiled on first use and cached on disk (``cache=True``: a fresh install pays the
compile once). Arguments must have the types the callers in :mod:`tactile_bt.perception.features`
give them (C-contiguous, writable float64 / bool arrays, Python floats), so that each kernel is
compiled for one signature only. ``tests/perception/test_kernels.py`` checks them against the numpy and
scipy implementations they replace (``tests/oracles.py``).

Layer: perception.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["largest_region", "windowed_line_sums", "line_fit_offset"]


@njit(cache=True, nogil=True, error_model="numpy")
def largest_region(img, threshold, limit, clean, mask, work, near_x, near_y, along_x, along_y, half_length):
    """Largest 8-connected region of ``img > threshold`` (or the one nearest a point) and its
    force moments.

    Parameters
    ----------
    img : float64[:, ::1]
        Force image (N per tactel); NaN, infinite and negative tactels count as 0, finite ones
        above ``limit`` as ``limit``.
    threshold : float
        A tactel belongs to a region when its (sanitised) force is strictly greater.
    limit : float
        Clip limit of finite forces (no moment sum can overflow below it).
    clean : float64[:, ::1]
        Output: the sanitised image.
    mask : bool[:, ::1]
        Output: the largest region (all False without one).
    work : int32[::1]
        Scratch space of ``3 rows cols + 1`` entries: labels, flood-fill stack, region sizes.
    near_x, near_y : float
        NaN: the largest region wins. Otherwise the point ``[column, row]`` (tactels) whose
        nearest region wins: the region with the tactel closest to it (ties: the larger region,
        then the one met first in row-major order).
    along_x, along_y, half_length : float
        The moments (not the mask, the area or ``m1``) count only the region's tactels within
        ``half_length`` tactels of ``(near_x, near_y)`` along the unit vector ``(along_x,
        along_y)`` (the part of a line around a point on it); ``inf``: the whole region.

    Returns
    -------
    tuple
        ``(invalid, changed, area, m1, mw, mx, my, mxx, mxy, myy, load, loaded, ox, oy)``: the
        number of NaN / infinite / negative tactels, whether ``clean`` differs from ``img``, the
        region's tactel count, its force, and its sums of ``f``, ``f x``, ``f y``, ``f x²``,
        ``f xy``, ``f y²`` (x = column, y = row) within the window; the force and tactel count of
        every region together (the pad's load); the sums of ``f x`` and ``f y`` over the other
        regions.
    """
    rows, cols = img.shape
    n = rows * cols
    invalid = 0
    changed = False
    for i in range(rows):
        for j in range(cols):
            v = img[i, j]
            if not v >= 0.0 or v == np.inf:
                invalid += 1
                v = 0.0
                changed = True
            elif v > limit:
                v = limit
                changed = True
            clean[i, j] = v
    # Flood fill from each unlabelled tactel in row-major order, so regions are numbered 1, 2,
    # ... in the order of their first tactel (as scipy.ndimage.label numbers them). work[:n]
    # holds the labels, work[n:2n] the stack, work[2n + k] the size of region k.
    work[:n] = 0
    count = 0
    best = 0
    best_size = 0
    tie = False
    nearest = near_x == near_x and near_y == near_y
    best_d2 = np.inf
    for i0 in range(rows):
        for j0 in range(cols):
            p = i0 * cols + j0
            if work[p] != 0 or not clean[i0, j0] > threshold:
                continue
            count += 1
            work[p] = count
            work[n] = p
            top = 1
            size = 0
            d2 = np.inf
            while top > 0:
                top -= 1
                size += 1
                q = work[n + top]
                i = q // cols
                j = q - i * cols
                if nearest:
                    dx = j - near_x
                    dy = i - near_y
                    if dx * dx + dy * dy < d2:
                        d2 = dx * dx + dy * dy
                for ni in range(max(i - 1, 0), min(i + 2, rows)):
                    for nj in range(max(j - 1, 0), min(j + 2, cols)):
                        r = ni * cols + nj
                        if work[r] == 0 and clean[ni, nj] > threshold:
                            work[r] = count
                            work[n + top] = r
                            top += 1
            work[2 * n + count] = size
            if nearest:
                if d2 < best_d2 or (d2 == best_d2 and size > best_size):
                    best, best_size, best_d2 = count, size, d2
            elif size > best_size:
                best, best_size, tie = count, size, False
            elif size == best_size:
                tie = True
    if tie:
        # A tie in size: the larger force wins, then the smaller label. The forces are summed in
        # row-major order, as numpy's bincount sums them, so that equal sums compare equal.
        best_force = -1.0
        for k in range(1, count + 1):
            if work[2 * n + k] == best_size:
                force = 0.0
                for i in range(rows):
                    for j in range(cols):
                        if work[i * cols + j] == k:
                            force += clean[i, j]
                if force > best_force:
                    best, best_force = k, force
    area = 0
    loaded = 0
    load = m1 = mw = mx = my = mxx = mxy = myy = ox = oy = 0.0
    windowed = half_length < np.inf
    for i in range(rows):
        y = float(i)
        for j in range(cols):
            label = work[i * cols + j]
            inside = best > 0 and label == best
            mask[i, j] = inside
            if label > 0:
                loaded += 1
                load += clean[i, j]
                if not inside:
                    ox += clean[i, j] * float(j)
                    oy += clean[i, j] * y
            if inside:
                x = float(j)
                v = clean[i, j]
                area += 1
                m1 += v
                if windowed and abs((x - near_x) * along_x + (y - near_y) * along_y) > half_length:
                    continue
                mw += v
                mx += v * x
                my += v * y
                mxx += v * (x * x)
                mxy += v * (x * y)
                myy += v * (y * y)
    return invalid, changed, area, m1, mw, mx, my, mxx, mxy, myy, load, loaded, ox, oy


@njit(cache=True, nogil=True, error_model="numpy")
def windowed_line_sums(image, mask, ux, uy, ox, oy, inv_half_width):
    """Weighted sums of a line fit across an axis: with ``t = ((x - ox) ux + (y - oy) uy) *
    inv_half_width`` the position along the axis from the window's centre ``(ox, oy)`` (in
    half-widths), ``d = (y - oy) ux - (x - ox) uy`` the distance across it (tactels) and the
    weight ``w`` the region's force times ``max(0, 1 - |t|)`` (a triangular window), the sums
    of ``w t^k`` for ``k = 0 … 6`` and of ``w d t^k`` for ``k = 0 … 3``: the normal equations of
    a weighted polynomial ``d(t)`` of degree up to 3.

    Parameters
    ----------
    image : float64[:, ::1]
        Force image (finite, >= 0).
    mask : bool[:, ::1]
        The region.
    ux, uy : float
        Unit vector along the axis (x = column, y = row).
    ox, oy : float
        The window's centre on the axis (tactels).
    inv_half_width : float
        One over the window's half-width (1 / tactels).

    Returns
    -------
    float64[11]
        ``[Σw, Σw t, …, Σw t^6, Σw d, Σw d t, Σw d t², Σw d t³]``.
    """
    rows, cols = image.shape
    out = np.zeros(11)
    for i in range(rows):
        dy = float(i) - oy
        for j in range(cols):
            if mask[i, j]:
                dx = float(j) - ox
                t = (dx * ux + dy * uy) * inv_half_width
                w = 1.0 - abs(t)
                if w > 0.0:
                    v = image[i, j] * w
                    d = dy * ux - dx * uy
                    for k in range(7):
                        out[k] += v
                        if k < 4:
                            out[7 + k] += v * d
                        v *= t
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def line_fit_offset(sums, degree, min_pivot):
    """The fitted distance across the axis at the window's centre (tactels) from the sums of
    :func:`windowed_line_sums`: the constant term of the weighted least-squares polynomial of
    ``degree`` (0 to 3), by a Cholesky solve of its normal equations. While a pivot falls to
    ``min_pivot`` of its diagonal entry or below (fewer distinct positions along the axis than
    the polynomial needs) the degree drops by one; NaN without weight."""
    if not sums[0] > 0.0:
        return np.nan
    low = np.zeros((4, 4))
    y = np.zeros(4)
    n = min(max(degree, 0), 3) + 1
    while n > 0:
        ok = True
        for i in range(n):
            for j in range(i + 1):
                acc = sums[i + j]
                for k in range(j):
                    acc -= low[i, k] * low[j, k]
                if i == j:
                    if not acc > min_pivot * sums[2 * i]:
                        ok = False
                        break
                    low[i, i] = np.sqrt(acc)
                else:
                    low[i, j] = acc / low[j, j]
            if not ok:
                break
        if ok:
            for i in range(n):  # forward: L y = b
                acc = sums[7 + i]
                for k in range(i):
                    acc -= low[i, k] * y[k]
                y[i] = acc / low[i, i]
            for i in range(n - 1, -1, -1):  # back: Lᵀ x = y, in place
                acc = y[i]
                for k in range(i + 1, n):
                    acc -= low[k, i] * y[k]
                y[i] = acc / low[i, i]
            return y[0]
        n -= 1
    return np.nan
