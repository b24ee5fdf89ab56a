"""Tests of tactile_bt.perception.smoothing: moving averages of scalars, axis angles and contact features."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt import defaults
from tactile_bt.perception.features import ContactFeatures, extract, wrap_half_pi
from tactile_bt.perception.smoothing import AngleMovingAverage, FeatureSmoother, MovingAverage
from tactile_bt.perception.synthetic import line_contact


def test_moving_average_window_nan_and_reset():
    m = MovingAverage(3)
    assert math.isnan(m.value) and len(m) == 0
    assert m.push(1.0) == 1.0
    assert m.push(2.0) == 1.5
    assert m.push(math.nan) == 1.5  # ignored
    assert m.push(math.inf) == 1.5  # ignored
    assert m.push(6.0) == 3.0
    assert m.push(7.0) == 5.0  # 1.0 dropped: last three finite samples
    assert len(m) == 3
    m.reset()
    assert math.isnan(m.value)
    assert m.push(4.0) == 4.0
    with pytest.raises(ValueError):
        MovingAverage(0)


def test_moving_average_default_is_ten_samples_and_does_not_drift():
    m = MovingAverage()
    assert m.n == defaults.SMOOTHING_SAMPLES == 10
    rng = np.random.default_rng(0)
    x = 1e6 + rng.standard_normal(20_000)
    for v in x:
        m.push(v)
    assert_allclose(m.value, np.mean(x[-10:]), rtol=0, atol=1e-9)


def test_angle_average_across_the_wrap():
    a = AngleMovingAverage(4)
    for deg in (88.0, -88.0, 89.0, -89.0):
        a.push(math.radians(deg))
    v = a.value
    assert -math.pi / 2 < v <= math.pi / 2
    assert abs(wrap_half_pi(v - math.pi / 2)) < 1e-12  # +-90 deg, not the naive 0
    b = AngleMovingAverage(2)
    b.push(math.radians(80.0))
    assert_allclose(b.push(math.radians(-70.0)), math.radians(-85.0), atol=1e-12)


def test_angle_average_window_nan_and_cancellation():
    a = AngleMovingAverage(2)
    assert math.isnan(a.value)
    a.push(0.1)
    assert_allclose(a.push(math.nan), 0.1)
    a.push(0.3)
    assert_allclose(a.value, 0.2, atol=1e-12)
    a.push(0.5)  # 0.1 drops out
    assert_allclose(a.value, 0.4, atol=1e-12)
    a.reset()
    a.push(0.0)
    assert math.isnan(a.push(math.pi / 2))  # perpendicular axes: no mean axis


def _features(pressure_scale=1.0, angle=0.3, centre=(7.5, 7.5), method="moments"):
    return extract(line_contact(centre, angle, 8.0, 2.0, 2.0 * pressure_scale), method=method)


def test_smoother_averages_the_last_ten_pressures_and_angles():
    s = FeatureSmoother()
    raw = [_features(1.0 + 0.05 * k, angle=0.2 + 0.01 * k) for k in range(15)]
    out = [s(f) for f in raw]
    last = raw[-10:]
    assert_allclose(out[-1].pressure, np.mean([f.pressure for f in last]), rtol=1e-12)
    assert_allclose(out[-1].force, np.mean([f.force for f in last]), rtol=1e-12)
    assert_allclose(out[-1].orientation, np.mean([f.orientation for f in last]), atol=1e-4)
    # COP, area and mask pass through unsmoothed
    assert out[-1].cop_px is raw[-1].cop_px and out[-1].area == raw[-1].area
    assert out[0].pressure == raw[0].pressure


def test_smoother_resets_on_contact_loss():
    s = FeatureSmoother()
    for _ in range(5):
        s(_features(3.0))
    lost = ContactFeatures.no_contact()
    assert s(lost) is lost
    fresh = _features(1.0, angle=-0.4)
    out = s(fresh)
    assert out.pressure == fresh.pressure and out.force == fresh.force
    assert_allclose(out.orientation, fresh.orientation)


def test_smoother_keeps_angle_average_when_orientation_missing():
    s = FeatureSmoother(3)
    a, b = _features(angle=0.1), _features(angle=0.4)
    s(a)
    s(a)
    no_angle = s(_features(angle=0.1, method=None))
    assert math.isnan(no_angle.orientation)
    out = s(b)
    # the NaN frame did not enter the angle window: the mean axis of (a, a, b)
    angles = 2.0 * np.array([a.orientation, a.orientation, b.orientation])
    truth = 0.5 * math.atan2(np.sin(angles).mean(), np.cos(angles).mean())
    assert_allclose(out.orientation, truth, atol=1e-12)
    assert_allclose(out.pressure, np.mean([a.pressure, a.pressure, b.pressure]), rtol=1e-12)


def test_smoothed_features_keep_every_other_field():
    """The smoother builds its result field by field: every field but the three smoothed ones
    is the frame's own object."""
    smoother = FeatureSmoother(3)
    frames = [extract(line_contact((7.0 + 0.1 * k, 8.0), 0.3, 8.0, 2.0, 1.0 + k)) for k in range(3)]
    for f in frames:
        g = smoother(f)
    smoothed = {"force", "pressure", "orientation"}
    for field in dataclasses.fields(ContactFeatures):
        if field.name not in smoothed:
            assert getattr(g, field.name) is getattr(f, field.name), field.name
    assert g.force == pytest.approx(np.mean([h.force for h in frames]))
    assert g.pressure == pytest.approx(np.mean([h.pressure for h in frames]))
