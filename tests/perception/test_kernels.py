"""The compiled kernels give the answers of the numpy / scipy implementations they replaced
(``tests/oracles.py``), on random inputs with NaN, infinite, negative and saturated values.

Tolerances (the kernels sum in another order than numpy's matrix products, nothing else):

* contact region, area, invalid-tactel count and sanitised image: exact;
* force, pressure, centre of pressure and local contact point: ``rtol 1e-12`` (COP and point
  also ``atol 1e-12`` px);
* orientation: the central moments agree to ``MU_TOL = 1e-13 max(rows, cols)²`` px² (they come
  from raw moments of up to ``max(rows, cols)²`` by cancellation), so the angle agrees modulo
  pi to ``MU_TOL / hypot(mu20 - mu02, 2 mu11) + 1e-12`` rad, and "no dominant axis" (NaN) is
  decided alike unless the region lies within ``MU_TOL`` of the anisotropy threshold.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose, assert_array_equal

import oracles
from tactile_bt import defaults
from tactile_bt.perception.features import MIN_ANISOTROPY, extract, line_spans_window, local_contact_point, wrap_half_pi
from tactile_bt.sense.geometry import PadGeometry

PAD = (defaults.ROWS, defaults.COLS)
RTOL = 1e-12

#: Tactel values: any float, the threshold's neighbourhood, a few exact levels (ties in size and
#: force, flat plateaus) and values beyond the clip limit of the moment sums.
LEVELS = [0.0, -0.0, 0.01, 0.02, 0.5, 1.0, 2.0, -1.0, math.nan, math.inf, -math.inf, 1e300, 5e-324]
TACTEL = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(0.0, 0.5),
    st.sampled_from(LEVELS),
)


def frames(shape=PAD):
    """Force images: random tactels, or sparse exact levels (many separate regions and ties)."""
    dense = arrays(np.float64, shape, elements=TACTEL)
    sparse = arrays(np.float64, shape, elements=st.sampled_from([0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, math.nan]))
    return st.one_of(dense, sparse)


@st.composite
def small_frames(draw):
    rows, cols = draw(st.integers(1, 9)), draw(st.integers(1, 9))
    return draw(frames((rows, cols)))


def assert_same_features(ours, ref, min_anisotropy=MIN_ANISOTROPY):
    assert ours.in_contact == ref.in_contact
    assert ours.invalid_tactels == ref.invalid_tactels
    assert ours.area == ref.area
    assert ours.method == ref.method and ours.pad == ref.pad
    assert_array_equal(ours.mask, ref.mask)
    if not ref.in_contact:
        assert ours.force == 0.0 and ours.pressure == 0.0 and math.isnan(ours.orientation)
        assert np.all(np.isnan(ours.cop_px))
        return
    assert_array_equal(ours.image, ref.image)
    assert_allclose(ours.force, ref.force, rtol=RTOL, atol=0)
    assert_allclose(ours.pressure, ref.pressure, rtol=RTOL, atol=0)
    assert_allclose(ours.cop_px, ref.cop_px, rtol=RTOL, atol=1e-12)
    a, b = ours.orientation, ref.orientation
    if ref.method is None:
        assert math.isnan(a) and math.isnan(b)
        return
    mu20, mu11, mu02 = oracles.central_moments(ref)
    mu_tol = 1e-13 * max(ref.mask.shape) ** 2
    spread, trace = math.hypot(mu20 - mu02, 2.0 * mu11), mu20 + mu02
    if math.isnan(a) != math.isnan(b):
        # Only a region on the edge of the "no dominant axis" test may fall either way.
        assert trace <= 2 * mu_tol or abs(spread - min_anisotropy * trace) <= 4 * mu_tol, (a, b, spread, trace)
    elif not math.isnan(b) and ref.method == "moments":
        assert abs(wrap_half_pi(a - b)) <= mu_tol / spread + 1e-12, (a, b, spread)
    elif not math.isnan(b):  # Hough on the same image and region
        assert a == b


# ---------------------------------------------------------------------------- features
@settings(max_examples=400, deadline=None)
@given(frames(), st.sampled_from(["moments", None]),
       st.sampled_from([defaults.CONTACT_THRESHOLD_N, 0.0, 0.5, -1.0, 1e300]))
def test_extract_matches_scipy_labelling_and_moments(img, method, threshold):
    assert_same_features(extract(img, threshold, method), oracles.extract(img, threshold, method))


@settings(max_examples=200, deadline=None)
@given(small_frames(), st.sampled_from(["moments", None]))
def test_extract_matches_on_other_pad_shapes(img, method):
    pad = PadGeometry(*img.shape, pitch=0.003)
    assert_same_features(extract(img, method=method, pad=pad), oracles.extract(img, method=method, pad=pad))


@settings(max_examples=40, deadline=None)
@given(frames())
def test_extract_hough_matches(img):
    assert_same_features(extract(img, method="hough"), oracles.extract(img, method="hough"))


def test_ties_are_broken_like_scipy():
    """Equal sizes: the larger force wins; equal sizes and forces: the region met first."""
    img = np.zeros(PAD)
    img[2, 2:4] = 1.0   # size 2, force 2
    img[8, 8:10] = 1.5  # size 2, force 3: wins
    img[12, 1:3] = 1.5  # the same again, met later
    for f in (extract(img), oracles.extract(img)):
        assert f.area == 2 and f.mask[8, 8] and not f.mask[12, 1]
    img[8, 8:10] = img[12, 1:3] = 1.0
    for f in (extract(img), oracles.extract(img)):
        assert f.mask[2, 2] and f.force == 2.0


def test_extract_of_views_and_read_only_frames():
    img = np.zeros((16, 32))
    img[4:7, 2:20] = 0.1
    view = img[:, ::2]  # not contiguous
    assert_same_features(extract(view), oracles.extract(view))
    frozen = np.array(view)
    frozen.setflags(write=False)
    assert_same_features(extract(frozen), oracles.extract(frozen))
    assert_same_features(extract(np.asfortranarray(view)), oracles.extract(view))


def test_image_is_the_input_unless_sanitised():
    img = np.zeros(PAD)
    img[3:6, 3:9] = 0.2
    assert extract(img).image is img
    img[0, 0] = math.nan
    f = extract(img)
    assert f.image is not img and f.image[0, 0] == 0.0 and f.invalid_tactels == 1


# ---------------------------------------------------------------------------- local contact point
def _well_posed(f, window_px: float, degree: int) -> bool:
    """Whether the local fit of ``f`` has a well-conditioned design at ``degree``: then the
    compiled Cholesky solve and numpy's least squares must agree (near-singular designs may
    lower the degree in one and not the other)."""
    if not f.in_contact or f.orientation != f.orientation:
        return True
    ux, uy = math.cos(f.orientation), math.sin(f.orientation)
    ys, xs = np.nonzero(f.mask)
    px, py = f.pad.centre_px
    t = ((xs - px) * ux + (ys - py) * uy) / window_px  # along the axis from where it passes the centre
    w = f.image[ys, xs] * np.maximum(1.0 - np.abs(t), 0.0)
    keep = w > 0
    if keep.sum() <= degree:
        return False
    design = np.vander(t[keep], degree + 1, increasing=True) * np.sqrt(w[keep])[:, None]
    return bool(np.linalg.cond(design) < 1e6)


@settings(max_examples=200, deadline=None)
@given(frames(), st.floats(2.0, 16.0), st.integers(0, 3))
def test_local_contact_point_matches_numpy(img, window_px, degree):
    f = extract(img)
    assume(_well_posed(f, window_px, degree))
    assert_allclose(local_contact_point(f, window_px, degree), oracles.local_contact_point(f, window_px, degree),
                    rtol=0, atol=1e-9)


def test_a_line_ending_near_the_pad_centre_does_not_span_the_local_window():
    # a cable across the whole pad, and one whose tip lies 1 tactel past the pad centre (the pad
    # has slid onto the cable's end): there the windowed point slides towards the tip
    from tactile_bt.perception.synthetic import line_contact

    across = extract(line_contact((7.5, 7.5), math.pi / 2, 20.0, 1.5, 3.0))
    assert line_spans_window(across)
    tip = extract(line_contact((7.5, 13.5), math.pi / 2, 10.0, 1.5, 3.0))  # from y = 8.5 to 18.5 (off the pad)
    assert np.isfinite(tip.orientation) and not line_spans_window(tip)
    assert not line_spans_window(extract(np.zeros((16, 16))))


def test_local_contact_point_of_a_bent_line():
    rows, cols = np.mgrid[0:16, 0:16]
    img = np.where(np.abs(cols - (7.0 + 0.02 * (rows - 7.5) ** 2)) < 1.0, 0.1, 0.0)
    f = extract(img)
    assert not math.isnan(f.orientation)
    ours = local_contact_point(f)
    assert_allclose(ours, oracles.local_contact_point(f), rtol=0, atol=1e-9)
    assert abs(ours[0] - f.cop_px[0]) > 0.1  # the local point is off the chord's COP


def test_local_contact_point_of_a_straight_line_is_on_it_for_every_degree():
    """A straight line across the pad at a sub-tactel offset, slightly inclined: every degree of
    the fit puts the point on the line where it crosses the row through the pad centre."""
    from tactile_bt.perception.synthetic import line_contact

    f = extract(line_contact((7.3, 7.5), math.pi / 2 + 0.05, 20.0, 1.5, 3.0))
    truth = 7.3  # the line passes through (7.3, 7.5), the centre row
    for degree in range(4):
        x, y = local_contact_point(f, degree=degree)
        assert abs(y - 7.5) < 0.05 and abs(x - truth) < 0.05


def test_local_contact_point_lowers_the_degree_where_the_window_is_too_short():
    """A window narrower than a tactel holds one position along the line: the fit is the
    weighted centroid across it there, never a singular solve."""
    from tactile_bt.perception.synthetic import line_contact

    f = extract(line_contact((7.5, 7.5), math.pi / 2, 20.0, 1.5, 3.0))
    point = local_contact_point(f, window_px=0.3, degree=3)
    assert np.all(np.isfinite(point))
    assert_allclose(point, local_contact_point(f, window_px=0.3, degree=0), atol=1e-12)
