"""The shape of a contact line on the pad, for ``cable_end``: where its tactels lie along a
direction, how far it reaches ahead of the pad centre, whether it touches the pad's leading
border, and its width, axis and centroid from second moments (one matrix product with a cached
basis: this runs every control cycle).

Layer: tree.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["line_reach", "along", "leading_border", "windowed_basis", "line_shape", "reach"]


@functools.lru_cache(maxsize=16)
def _grid(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Column and row index of every tactel of a ``shape`` pad, flattened (row-major), as floats."""
    rows, cols = np.indices(shape, dtype=float)
    return cols.ravel(), rows.ravel()


@functools.lru_cache(maxsize=16)
def along(shape: tuple[int, int], centre_px: tuple[float, float], direction_rad: float) -> np.ndarray:
    """Position of every tactel along ``direction_rad`` from the pad centre (tactels), flattened."""
    x, y = _grid(shape)
    return (x - centre_px[0]) * math.cos(direction_rad) + (y - centre_px[1]) * math.sin(direction_rad)


@functools.lru_cache(maxsize=16)
def leading_border(shape: tuple[int, int], centre_px: tuple[float, float], direction_rad: float) -> np.ndarray:
    """Flat indices of the border tactels of a ``shape`` pad ahead of its centre along
    ``direction_rad``: a line whose leading end lies inside the pad touches none of them."""
    rows, cols = shape
    border = np.zeros(shape, dtype=bool)
    border[0, :] = border[-1, :] = border[:, 0] = border[:, -1] = True
    ahead = along(shape, centre_px, direction_rad) > 0.5
    return np.flatnonzero(border.ravel() & ahead)


@functools.lru_cache(maxsize=16)
def _moment_basis(shape: tuple[int, int]) -> np.ndarray:
    """Rows 1, x, y, x², y², x·y over the tactels of a ``shape`` pad (x = column, y = row): one
    product with a mask gives every sum :func:`line_shape` needs."""
    x, y = _grid(shape)
    return np.stack((np.ones_like(x), x, y, x * x, y * y, x * y))


@functools.lru_cache(maxsize=16)
def windowed_basis(shape: tuple[int, int], centre_px: tuple[float, float], direction_rad: float,
                    window_px: float) -> np.ndarray:
    """:func:`_moment_basis` with the tactels farther than ``window_px`` from the pad centre
    along ``direction_rad`` left out (their columns zero)."""
    inside = np.abs(along(shape, centre_px, direction_rad)) <= window_px
    return _moment_basis(shape) * inside


def line_reach(mask: np.ndarray, centre_px: tuple[float, float], direction_rad: float) -> float:
    """How far (tactels) the contact region ``mask`` reaches ahead of the pad centre along
    ``direction_rad`` (sensor frame, from +x towards +y): the largest projection of its tactels,
    plus half a tactel (a tactel's far edge). ``-inf`` for an empty mask."""
    return reach(along(mask.shape, tuple(centre_px), float(direction_rad)), mask)


def reach(along: np.ndarray, mask: np.ndarray) -> float:
    """:func:`line_reach` from the tactels' positions ``along`` the direction (flattened)."""
    ahead = along[mask.ravel()]
    return float(ahead.max()) + 0.5 if ahead.size else -math.inf


def line_shape(mask: np.ndarray, basis: np.ndarray | None = None) -> tuple[float, float, float, float, float]:
    """Width ``sqrt(12 l2)`` across the major axis (tactels; the width of a uniform band with the
    same spread; inf without a major axis), axis angle (rad, from +x towards +y), centroid
    ``(x, y)`` (tactels) and count of the tactel positions of ``mask`` (second
    moments by one matrix product with ``basis``, default :func:`_moment_basis`; exact sums of
    small integers: this runs every control cycle)."""
    if basis is None:
        basis = _moment_basis(mask.shape)
    n, sum_x, sum_y, sum_xx, sum_yy, sum_xy = (basis @ mask.ravel().astype(float)).tolist()
    if n < 3:
        return math.inf, math.nan, math.nan, math.nan, n
    mx, my = sum_x / n, sum_y / n
    sxx = sum_xx / n - mx * mx
    syy = sum_yy / n - my * my
    sxy = sum_xy / n - mx * my
    total = sxx + syy
    spread = math.hypot(sxx - syy, 2.0 * sxy)
    if total <= 0 or spread <= 0:
        return math.inf, math.nan, mx, my, n
    minor = max(0.5 * (total - spread), 0.0)
    return math.sqrt(12.0 * minor), 0.5 * math.atan2(2.0 * sxy, sxx - syy), mx, my, n
