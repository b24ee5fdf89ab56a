"""Tests of tactile_bt.perception.features: contact region, COP, pressure, orientation, robustness (speed: ``tactile-bt bench``)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose, assert_array_equal

from tactile_bt import defaults
from tactile_bt.perception import features
from tactile_bt.perception.features import ContactFeatures, extract, wrap_half_pi
from tactile_bt.perception.baseline import extract_with_regionprops
from tactile_bt.perception.synthetic import add_spurious_blob, blob_contact, line_contact, sensor_effects
from tactile_bt.sense.geometry import PadGeometry

PAD = (defaults.ROWS, defaults.COLS)


def angle_error(a: float, b: float) -> float:
    """Absolute difference of two axis angles modulo pi, in rad."""
    return abs(wrap_half_pi(a - b))


# ---------------------------------------------------------------------------- basics
def test_empty_frame_is_no_contact():
    f = extract(np.zeros(PAD))
    assert not f.in_contact
    assert f.force == 0.0 and f.area == 0 and f.pressure == 0.0
    assert np.all(np.isnan(f.cop_px)) and np.all(np.isnan(f.cop))
    assert math.isnan(f.orientation)
    assert f.mask.shape == PAD and not f.mask.any()


def test_below_threshold_is_no_contact_and_threshold_is_strict():
    img = np.full(PAD, defaults.CONTACT_THRESHOLD_N)
    assert not extract(img).in_contact  # equal to the threshold is not above it
    img[3, 4] = np.nextafter(defaults.CONTACT_THRESHOLD_N, 1.0)
    f = extract(img)
    assert f.in_contact and f.area == 1
    assert_array_equal(f.cop_px, [4.0, 3.0])  # [x, y] = [column, row]


def test_no_contact_constructor():
    f = ContactFeatures.no_contact((4, 6))
    assert not f.in_contact and f.mask.shape == (4, 6) and f.method is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        f.force = 1.0  # immutable


def test_pressure_is_force_over_region_area():
    img = line_contact((7.2, 8.4), 0.4, 8.0, 2.0, 2.0)
    f = extract(img)
    assert f.area == int(f.mask.sum())
    assert_allclose(f.force, img[f.mask].sum(), rtol=1e-12)
    assert_allclose(f.pressure, f.force / (f.area * defaults.PITCH_M**2), rtol=1e-12)
    assert 25 <= f.area <= 60  # a realistic ~40-tactel contact
    # a custom pitch changes pressure and metric COP, not the tactel features
    g = extract(img, pad=PadGeometry(16, 16, 0.01))
    assert_allclose(g.pressure, f.pressure / 4.0, rtol=1e-12)
    assert_allclose(g.cop, 2.0 * f.cop, rtol=1e-12)
    assert g.pad.pitch == 0.01 and f.pad == PadGeometry()


@pytest.mark.parametrize("pad", [PadGeometry(12, 16), PadGeometry(16, 12), PadGeometry(8, 8, 0.005)])
def test_a_pad_of_another_shape_than_the_image_is_an_error(pad):
    with pytest.raises(ValueError, match=r"16x16 tactels, the pad"):
        extract(np.zeros(PAD), pad=pad)
    with pytest.raises(ValueError, match="the pad"):
        extract_with_regionprops(np.zeros(PAD), pad=pad)


def test_a_pitch_in_place_of_the_pad_is_an_error():
    with pytest.raises(TypeError, match="PadGeometry"):
        extract(np.zeros(PAD), 0.008, "moments", 0.005)


@pytest.mark.parametrize("centre", [(7.5, 7.5), (3.25, 10.6), (11.9, 4.1), (6.0, 6.0)])
def test_cop_tracks_the_contact(centre):
    f = extract(blob_contact(centre, 1.3, 2.0))
    assert_allclose(f.cop_px, centre, atol=0.02)


def test_cop_moves_with_the_contact_in_the_sensor_frame():
    xs = np.linspace(5.0, 10.0, 11)
    cops = np.array([extract(blob_contact((x, 7.5), 1.5, 2.0)).cop for x in xs])
    # moving along the columns moves the metric COP along +x only, by the pitch per tactel
    assert_allclose(np.diff(cops[:, 0]), (xs[1] - xs[0]) * defaults.PITCH_M, atol=1e-4)
    assert_allclose(cops[:, 1], 0.0, atol=1e-5)
    centred = extract(blob_contact((7.5, 7.5), 1.5, 2.0))
    assert_allclose(centred.cop, [0.0, 0.0], atol=1e-6)
    down = extract(blob_contact((7.5, 10.5), 1.5, 2.0))  # +3 rows -> +y
    assert_allclose(down.cop, [0.0, 3 * defaults.PITCH_M], atol=1e-5)


def test_cop_metres_on_a_non_square_pad():
    img = np.zeros((4, 6))
    img[0, 5] = 1.0
    f = extract(img)
    assert_allclose(f.cop, [(5 - 2.5) * defaults.PITCH_M, (0 - 1.5) * defaults.PITCH_M])
    assert f.pad == PadGeometry(4, 6)  # without a pad: the default pitch, the image's shape
    g = extract(img, pad=PadGeometry(4, 6, 0.004))
    assert_allclose(g.cop, [(5 - 2.5) * 0.004, (0 - 1.5) * 0.004])
    assert_allclose(g.cop, g.pad.px_to_m(g.cop_px))


def test_spurious_blob_is_ignored():
    rng = np.random.default_rng(3)
    clean = line_contact((7.5, 7.0), 1.0, 9.0, 2.0, 2.0)
    spiky = add_spurious_blob(clean, rng, force_n=0.2)
    a, b = extract(clean), extract(spiky)
    assert_array_equal(a.mask, b.mask)
    assert a.area == b.area
    assert_allclose([a.force, *a.cop_px, a.orientation], [b.force, *b.cop_px, b.orientation], rtol=1e-12, atol=1e-12)


def test_largest_region_wins_and_ties_go_to_the_larger_force():
    img = np.zeros(PAD)
    img[1, 1:4] = 0.05  # 3 tactels, 0.15 N
    img[10, 10:12] = 1.0  # 2 tactels, 2 N
    f = extract(img)
    assert f.area == 3
    assert_allclose(f.force, 0.15, rtol=1e-12)
    img[10, 12] = 1.0  # now a tie in size: 3 tactels, 3 N wins
    f = extract(img)
    assert f.area == 3
    assert_allclose(f.force, 3.0, rtol=1e-12)
    assert_allclose(f.cop_px, [11.0, 10.0])


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, (16, 16), elements=st.sampled_from([0.0, 0.0, 0.0, 0.0, 0.3, 1.0])),
       st.floats(0.0, 15.0), st.floats(0.0, 15.0), st.floats(-math.pi, math.pi), st.floats(0.5, 20.0))
def test_the_region_nearest_a_point_and_its_part_in_a_window(img, x, y, angle, half):
    """``near_px``: the region with the tactel nearest the point (ties: the larger region, then
    the first in row-major order); ``window_px``: COP of its tactels within the window along the
    axis (all of them when none is), pressure of every region together."""
    from scipy import ndimage

    threshold = defaults.CONTACT_THRESHOLD_N
    labels, n = ndimage.label(img > threshold, structure=np.ones((3, 3)))
    ux, uy = math.cos(angle), math.sin(angle)
    f = extract(img, near_px=(x, y), window_px=(ux, uy, half))
    if n == 0:
        assert not f.in_contact
        return
    rows, cols = np.indices(img.shape)
    d2 = (cols - x) ** 2 + (rows - y) ** 2
    best = min(range(1, n + 1), key=lambda k: (d2[labels == k].min(), -np.count_nonzero(labels == k), k))
    region = labels == best
    assert_array_equal(f.mask, region)
    inside = region & (np.abs((cols - x) * ux + (rows - y) * uy) <= half)
    if not inside.any():
        inside = region
    w = img * inside
    assert_allclose(f.cop_px, [np.sum(w * cols) / w.sum(), np.sum(w * rows) / w.sum()], rtol=1e-9, atol=1e-9)
    loaded = labels > 0
    assert_allclose(f.pressure, img[loaded].sum() / (loaded.sum() * f.pad.pitch ** 2), rtol=1e-9)
    assert_allclose(f.force, img[region].sum(), rtol=1e-12)


def test_diagonal_neighbours_are_connected():
    img = np.zeros(PAD)
    img[[2, 3, 4, 5], [2, 3, 4, 5]] = 0.1
    img[12, 12] = 0.3
    f = extract(img)
    assert f.area == 4
    assert_allclose(f.orientation, math.pi / 4, atol=1e-12)


# ---------------------------------------------------------------------------- orientation
@pytest.mark.parametrize("method", ["moments", "hough"])
def test_orientation_convention_x_towards_y(method):
    img = np.zeros(PAD)
    img[5:7, 2:13] = 0.05  # horizontal bar, 2 tactels wide
    assert angle_error(extract(img, method=method).orientation, 0.0) < math.radians(1)
    diag = np.zeros(PAD)
    for k in range(3, 13):  # rows and columns increase together: +45 deg (x towards y)
        diag[k, k - 1 : k + 1] = 0.05
    assert angle_error(extract(diag, method=method).orientation, math.pi / 4) < math.radians(2)
    anti = diag[:, ::-1]
    assert angle_error(extract(anti, method=method).orientation, -math.pi / 4) < math.radians(2)


@pytest.mark.parametrize("method", ["moments", "hough"])
def test_vertical_line_wraps_to_plus_half_pi(method):
    img = np.zeros(PAD)
    img[2:14, 7:9] = 0.05
    a = extract(img, method=method).orientation
    assert -math.pi / 2 < a <= math.pi / 2
    assert angle_error(a, math.pi / 2) < math.radians(1)


@pytest.mark.parametrize("method", ["moments", "hough"])
@pytest.mark.parametrize("deg", [85.0, 88.0, 89.5, 90.0, 90.5, 92.0, 95.0, -89.0])
def test_angles_near_ninety_degrees_wrap(method, deg):
    rng = np.random.default_rng(int(deg * 10) % 997)
    truth = math.radians(deg)
    img = sensor_effects(line_contact((7.5, 7.5), truth, 9.0, 2.0, 2.0), rng)
    a = extract(img, method=method).orientation
    assert -math.pi / 2 < a <= math.pi / 2
    tol = math.radians(1.0 if method == "moments" else 3.0)  # single frame; means in test_synthetic
    assert angle_error(a, truth) < tol


@pytest.mark.parametrize("method", ["moments", "hough"])
def test_round_blob_has_no_orientation(method):
    rng = np.random.default_rng(11)
    for centre in [(7.5, 7.5), (7.0, 8.0), (6.3, 8.8)]:
        for sigma in (1.0, 1.5, 2.0):
            img = sensor_effects(blob_contact(centre, sigma, 2.0), rng)
            f = extract(img, method=method)
            assert f.in_contact and math.isnan(f.orientation)


def test_degenerate_regions():
    img = np.zeros(PAD)
    img[4, 4] = 0.1  # single tactel: no axis
    assert math.isnan(extract(img).orientation)
    img[4:6, 4:6] = 0.1  # 2x2 square: no dominant axis
    assert math.isnan(extract(img).orientation)
    img[4:6, 4:7] = 0.1  # 2x3 bar: dominant axis along x
    assert_allclose(extract(img).orientation, 0.0, atol=1e-12)


def test_method_none_skips_orientation(monkeypatch):
    img = line_contact((7.5, 7.5), 0.5, 9.0, 2.0, 2.0)
    f = extract(img, method=None)
    assert f.method is None and math.isnan(f.orientation)
    g = extract(img)
    # The moments path computes the COP from its own matrix products: equal to rounding.
    assert g.method == "moments"
    assert_allclose(f.force, g.force, rtol=1e-12)
    assert_allclose(f.cop_px, g.cop_px, rtol=0, atol=1e-12)

    def boom(*args, **kwargs):
        raise AssertionError("Hough must not run")

    monkeypatch.setattr(features, "hough_orientation", boom)
    extract(img, method=None)
    extract(img, method="moments")


# ---------------------------------------------------------------------------- robustness
def test_invalid_tactels_are_zeroed_and_counted():
    img = line_contact((7.5, 7.5), 0.3, 9.0, 2.0, 2.0)
    dirty = img.copy()
    dirty[0, 0] = np.nan
    dirty[15, 0] = np.inf
    dirty[0, 15] = -np.inf
    dirty[15, 15] = -0.5
    f = extract(dirty)
    assert f.invalid_tactels == 4
    for v in (f.force, f.pressure, *f.cop_px, f.orientation):
        assert math.isfinite(v)
    ref = extract(np.where(np.isfinite(dirty) & (dirty >= 0), dirty, 0.0))
    assert_allclose([f.force, *f.cop_px], [ref.force, *ref.cop_px], rtol=1e-12, atol=1e-12)
    # inf at the contact centre is replaced, not propagated
    dirty[7, 7] = np.inf
    g = extract(dirty)
    assert g.invalid_tactels == 5 and math.isfinite(g.force) and np.all(np.isfinite(g.cop_px))
    huge = extract(np.full(PAD, 1e308))  # finite but overflowing sums stay finite
    assert huge.in_contact and huge.area == 256 and math.isfinite(huge.force)
    assert_allclose(huge.cop_px, [7.5, 7.5])
    all_nan = extract(np.full(PAD, np.nan))
    assert not all_nan.in_contact and all_nan.invalid_tactels == 256


def test_input_is_not_modified_and_lists_work():
    img = np.zeros(PAD)
    img[3, 3] = np.nan
    img[5, 5:9] = 0.1
    before = img.copy()
    extract(img)
    assert_array_equal(np.isnan(img), np.isnan(before))
    assert extract(img.tolist()).area == 4
    assert extract(np.zeros(PAD, dtype=np.int16)).in_contact is False


def test_wrong_input_raises_clear_errors():
    with pytest.raises(ValueError, match="2-D"):
        extract(np.zeros(16))
    with pytest.raises(ValueError, match="2-D"):
        extract(np.zeros((2, 16, 16)))
    with pytest.raises(ValueError, match="method"):
        extract(np.zeros(PAD), method="pca")


@settings(max_examples=150, deadline=None)
@given(
    arrays(
        np.float64,
        PAD,
        elements=st.floats(allow_nan=True, allow_infinity=True, width=64),
    ),
    st.sampled_from(["moments", "hough", None]),
)
def test_never_raises_and_never_leaks_nan(img, method):
    f = extract(img, method=method)
    assert math.isfinite(f.force) and f.force >= 0
    assert math.isfinite(f.pressure) and f.pressure >= 0
    assert f.invalid_tactels == int(np.count_nonzero(~np.isfinite(img) | (img < 0)))
    if f.in_contact:
        assert np.all(np.isfinite(f.cop_px)) and np.all(np.isfinite(f.cop))
        assert 0 <= f.cop_px[0] <= 15 and 0 <= f.cop_px[1] <= 15
        assert f.area == f.mask.sum() > 0
    a = f.orientation
    assert math.isnan(a) or -math.pi / 2 < a <= math.pi / 2


# ---------------------------------------------------------------------------- wrap_half_pi
def test_wrap_half_pi_scalars_and_arrays():
    assert wrap_half_pi(math.pi / 2) == math.pi / 2
    assert wrap_half_pi(-math.pi / 2) == math.pi / 2
    assert_allclose(wrap_half_pi(math.pi), 0.0, atol=1e-15)
    assert_allclose(wrap_half_pi(3 * math.pi / 4), -math.pi / 4)
    assert_allclose(wrap_half_pi(-100.0), -100.0 + 32 * math.pi)
    assert math.isnan(wrap_half_pi(math.nan))
    assert isinstance(wrap_half_pi(np.float64(1.0)), float)
    a = np.linspace(-10, 10, 1001)
    w = wrap_half_pi(a)
    assert w.shape == a.shape
    assert np.all((w > -math.pi / 2) & (w <= math.pi / 2))
    assert_allclose(np.sin(2 * w), np.sin(2 * a), atol=1e-12)
    assert_allclose(np.cos(2 * w), np.cos(2 * a), atol=1e-12)


# ---------------------------------------------------------------------------- baseline
def _random_frames(n, seed):
    rng = np.random.default_rng(seed)
    for k in range(n):
        if k % 3 == 2:
            img = blob_contact(rng.uniform(5, 10, 2), rng.uniform(0.8, 2.0), 2.0)
        else:
            centre, angle, length = rng.uniform(6, 9, 2), rng.uniform(-3, 3), rng.uniform(0, 9)
            img = line_contact(centre, angle, length, 2.0, 2.0)
        img = sensor_effects(add_spurious_blob(img, rng), rng)
        if k % 4 == 0:
            img[rng.integers(16), rng.integers(16)] = np.nan
        yield img


def test_regionprops_baseline_agrees():
    for img in _random_frames(40, seed=5):
        a, b = extract(img), extract_with_regionprops(img)
        assert a.in_contact == b.in_contact
        assert_array_equal(a.mask, b.mask)
        assert a.area == b.area and a.invalid_tactels == b.invalid_tactels
        assert_allclose([a.force, a.pressure], [b.force, b.pressure], rtol=1e-12)
        assert_allclose(a.cop_px, b.cop_px, atol=1e-10)
        assert math.isnan(a.orientation) == math.isnan(b.orientation)
        if not math.isnan(a.orientation):
            assert angle_error(a.orientation, b.orientation) < 1e-9
    assert not extract_with_regionprops(np.zeros(PAD)).in_contact


@pytest.mark.parametrize("seed", range(12))
def test_the_other_regions_are_everything_above_the_threshold_outside_the_largest(seed):
    # a contact and up to three spurious blobs, seeded: the figures extraction keeps for the
    # other regions match a count of the image outside the largest region and its fringe
    from tactile_bt.tree.behaviours.contact_points import _dilated, other_contact

    rng = np.random.default_rng(seed)
    image = blob_contact(rng.uniform(3, 12, 2), rng.uniform(1.5, 3.0), 2.0)
    for _ in range(rng.integers(0, 4)):
        image = add_spurious_blob(image, rng)
    f = extract(image, defaults.CONTACT_THRESHOLD_N)
    outside = f.image[(f.image > defaults.CONTACT_THRESHOLD_N) & ~_dilated(f.mask)]  # counted anew
    counted = (float(outside.sum()), int(outside.size)) if outside.size else (0.0, 0)
    assert f.others_tactels == counted[1]
    assert_allclose(f.others_force, counted[0], rtol=1e-12, atol=1e-12)
    assert other_contact(f) == ((f.others_force, f.others_tactels) if f.others_tactels else (0.0, 0))


def bridged(seed: int):
    """Features of two contacts near opposite borders (a flat pad bridging a hollow), seeded."""
    rng = np.random.default_rng(seed)
    image = blob_contact(rng.uniform((2, 2), (4, 13)), 0.7, 2.0) + blob_contact(rng.uniform((11, 2), (13, 13)), 0.7, 1.0)
    f = extract(image, defaults.CONTACT_THRESHOLD_N)
    assert f.others_tactels > 0
    return f


@pytest.mark.parametrize("seed", range(6))
def test_the_centre_of_every_region_together_is_the_force_weighted_centre_of_the_image(seed):
    # two contacts on the pad (a flat pad bridging a hollow): the centre of pressure of both
    # together is the force-weighted centre of every tactel above the threshold, whichever is
    # the largest
    f = bridged(seed)
    used = np.where(f.image > defaults.CONTACT_THRESHOLD_N, f.image, 0.0)
    rows, cols = np.indices(used.shape)
    expected = f.pad.xy_px_to_m(float((used * cols).sum() / used.sum()), float((used * rows).sum() / used.sum()))
    assert_allclose(f.load_cop_xy, expected, atol=1e-9)
    # one region: the largest region's own centre
    single = extract(blob_contact((7.5, 7.5), 2.0, 2.0), defaults.CONTACT_THRESHOLD_N)
    assert single.others_tactels == 0 and single.load_cop_xy == single.cop_xy


@pytest.mark.parametrize("seed", range(4))
def test_the_lesser_share_is_the_lighter_side_s_part_of_the_whole_load(seed):
    # a pad bridging a hollow rests on two contacts: the lighter side's share of the load, the
    # same whichever of the two is the largest region; 0 with one region
    f = bridged(seed)
    total = f.force + f.others_force
    assert_allclose(f.lesser_share, min(f.force, f.others_force) / total, rtol=1e-12)
    assert 0.0 < f.lesser_share <= 0.5
    single = extract(blob_contact((7.5, 7.5), 2.0, 2.0), defaults.CONTACT_THRESHOLD_N)
    assert single.lesser_share == 0.0
