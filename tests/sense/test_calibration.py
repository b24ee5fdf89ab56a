"""Tests of tactile_bt.sense.calibration: per-tactel characteristic, inverse, saturation, files."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from tactile_bt import defaults
from tactile_bt.sense.calibration import NOMINAL_SATURATION_N, TactelCalibration

PAD = (defaults.ROWS, defaults.COLS)


def test_nominal_saturates_at_adc_max_near_a_quarter_newton():
    cal = TactelCalibration.nominal()
    assert cal.shape == PAD
    assert_allclose(NOMINAL_SATURATION_N, 0.25)  # 10 kPa on a 25 mm^2 tactel
    assert_allclose(cal.raw_from_force(np.full(PAD, 0.25)), defaults.ADC_MAX, rtol=1e-12)
    assert_allclose(cal.saturation_force, 0.25, rtol=1e-9)
    # linear-ish up to 0.1 N: within 20 % of the tangent at zero
    slope0 = cal.span / cal.force_scale
    gain_01 = (cal.raw_from_force(np.full(PAD, 0.1)) - cal.offset) / 0.1
    assert np.all(gain_01 > 0.8 * slope0)
    # one ADC count is well below a millinewton at zero force
    assert np.all(1.0 / slope0 < 1e-4)


def test_characteristic_is_monotonic_and_squashed():
    cal = TactelCalibration.nominal(1, 1)
    f = np.linspace(0.0, 0.25, 101)
    raw = np.array([cal.raw_from_force(np.full((1, 1), v))[0, 0] for v in f])
    assert np.all(np.diff(raw) > 0)
    assert np.all(np.diff(raw, 2) < 0)  # concave: saturating


def test_round_trip_raw_force_raw():
    rng = np.random.default_rng(1)
    cal = TactelCalibration.random(rng)
    raw = rng.uniform(cal.offset, cal.saturation_raw)
    assert_allclose(cal.raw_from_force(cal.force_from_raw(raw)), raw, rtol=0, atol=1e-8)
    force = rng.uniform(0.0, 1.0, PAD) * cal.saturation_force
    assert_allclose(cal.force_from_raw(cal.raw_from_force(force)), force, rtol=1e-9, atol=1e-12)


def test_round_trip_on_stacks_of_frames():
    cal = TactelCalibration.nominal()
    force = np.linspace(0.0, 0.2, 3 * 256).reshape(3, *PAD)
    assert_allclose(cal.force_from_raw(cal.raw_from_force(force)), force, atol=1e-12)


def test_below_offset_and_saturation_are_finite():
    cal = TactelCalibration.random(np.random.default_rng(2))
    raw = np.full(PAD, -50.0)
    assert_array_equal(cal.force_from_raw(raw), 0.0)
    assert_array_equal(cal.force_from_raw(cal.offset), 0.0)
    for top in (defaults.ADC_MAX, 1e9, np.inf):
        f = cal.force_from_raw(np.full(PAD, top, dtype=float))
        assert np.all(np.isfinite(f))
        assert_allclose(f, cal.saturation_force)
    f = cal.force_from_raw(np.full(PAD, np.nan))
    assert_array_equal(f, 0.0)
    assert np.all(np.isfinite(cal.saturation_force)) and np.all(cal.saturation_force > 0)


def test_negative_force_reads_as_zero():
    cal = TactelCalibration.nominal()
    assert_array_equal(cal.raw_from_force(np.full(PAD, -1.0)), cal.offset)


def test_random_is_per_tactel_and_reproducible():
    a = TactelCalibration.random(np.random.default_rng(7))
    b = TactelCalibration.random(np.random.default_rng(7))
    c = TactelCalibration.random(np.random.default_rng(8))
    for name in ("offset", "span", "force_scale"):
        assert_array_equal(getattr(a, name), getattr(b, name))
        assert not np.array_equal(getattr(a, name), getattr(c, name))
        assert np.unique(getattr(a, name)).size == 256  # every tactel its own
    same_force = a.raw_from_force(np.full(PAD, 0.05))
    assert np.std(same_force) > 50  # counts: the tactels really differ
    nominal = TactelCalibration.random(np.random.default_rng(7), spread=0.0)
    assert_array_equal(nominal.span, TactelCalibration.nominal().span)
    assert TactelCalibration.random(np.random.default_rng(0), rows=4, cols=5).shape == (4, 5)


def test_save_load_round_trip(tmp_path):
    cal = TactelCalibration.random(np.random.default_rng(3))
    path = tmp_path / "cal.npz"
    cal.save(path)
    back = TactelCalibration.load(path)
    for name in ("offset", "span", "force_scale"):
        assert_array_equal(getattr(back, name), getattr(cal, name))


def test_load_errors_name_the_file_and_field(tmp_path):
    path = tmp_path / "broken.npz"
    np.savez(path, offset=np.zeros(PAD), span=np.ones(PAD))
    with pytest.raises(ValueError, match=r"broken\.npz.*force_scale"):
        TactelCalibration.load(path)
    bad = tmp_path / "bad_values.npz"
    np.savez(bad, offset=np.zeros(PAD), span=-np.ones(PAD), force_scale=np.ones(PAD))
    with pytest.raises(ValueError, match=r"bad_values\.npz.*span"):
        TactelCalibration.load(bad)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="junk.npz"):
        TactelCalibration.load(junk)
    with pytest.raises(FileNotFoundError):
        TactelCalibration.load(tmp_path / "missing.npz")


def test_constructor_validates():
    ones = np.ones(PAD)
    with pytest.raises(ValueError, match="span"):
        TactelCalibration(ones, 0 * ones, ones)
    with pytest.raises(ValueError, match="shape"):
        TactelCalibration(ones, np.ones((4, 4)), ones)
    with pytest.raises(ValueError, match="NaN"):
        TactelCalibration(ones, ones * math.nan, ones)
    with pytest.raises(ValueError, match="2-D"):
        TactelCalibration(np.ones(3), np.ones(3), np.ones(3))
    cal = TactelCalibration.nominal()
    with pytest.raises(ValueError):
        cal.offset[0, 0] = 5.0  # parameters are read-only
