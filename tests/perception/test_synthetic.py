"""Tests of tactile_bt.perception.synthetic: generators with ground truth, and the accuracy requirements."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.perception.features import extract, wrap_half_pi
from tactile_bt.experiments.accuracy import cop_accuracy, orientation_comparison
from tactile_bt.perception.synthetic import add_spurious_blob, blob_contact, line_contact, sensor_effects

PAD = (defaults.ROWS, defaults.COLS)
EIGHT = np.ones((3, 3), dtype=bool)


def test_line_contact_carries_the_force_and_is_centred():
    img = line_contact((7.3, 8.2), math.radians(30), 9.0, 2.0, 2.0)
    assert img.shape == PAD and np.all(img >= 0)
    assert_allclose(img.sum(), 2.0, rtol=1e-12)
    rows, cols = np.indices(PAD)
    # the centroid is the segment centre up to the 8x8 sub-sampling (~2e-4 tactel)
    assert_allclose([(img * cols).sum() / 2.0, (img * rows).sum() / 2.0], [7.3, 8.2], atol=1e-3)
    # ~0.05 N per loaded tactel over ~40 tactels: the paper's p = 1
    loaded = img > defaults.CONTACT_THRESHOLD_N
    assert 30 <= loaded.sum() <= 50
    assert 0.03 < img[loaded].mean() < 0.07


def test_line_contact_clipped_by_the_border_keeps_its_normalisation():
    img = line_contact((0.0, 7.5), 0.0, 8.0, 2.0, 2.0)
    assert 0.5 < img.sum() < 1.5  # about half of the contact is off the pad


def test_zero_length_line_is_round_and_blob_sums():
    disk = line_contact((7.5, 7.5), 0.7, 0.0, 2.5, 1.0)
    assert_allclose(disk, disk.T, atol=1e-12)
    blob = blob_contact((9.1, 6.2), 1.2, 2.0, shape=(12, 20))  # x = column, y = row
    assert blob.shape == (12, 20)
    assert_allclose(blob.sum(), 2.0, rtol=1e-9)
    with pytest.raises(ValueError):
        blob_contact((7, 7), 0.0, 1.0)
    with pytest.raises(ValueError):
        line_contact((7, 7), 0.0, 5.0, -1.0, 1.0)


def test_sensor_effects_noise_is_small_against_the_threshold():
    rng = np.random.default_rng(0)
    frames = np.array([sensor_effects(np.zeros(PAD), rng) for _ in range(50)])
    assert np.all(np.isfinite(frames)) and np.all(frames >= 0)
    assert frames.max() < 0.5 * defaults.CONTACT_THRESHOLD_N  # a few mN at most
    assert 0.0002 < frames.std() < 0.002
    assert not extract(frames[0]).in_contact


def test_sensor_effects_quantises_and_saturates():
    cal = TactelCalibration.nominal()
    img = np.linspace(0.0, 0.4, 256).reshape(PAD)
    out = sensor_effects(img, np.random.default_rng(1), cal, noise_counts=0.0)
    raw = cal.raw_from_force(out)
    assert_allclose(raw, np.rint(raw), atol=1e-6)  # integer counts
    assert_allclose(out.max(), 0.25, rtol=1e-9)  # saturated at ADC_MAX
    small = img < 0.2
    assert_allclose(out[small], img[small], atol=1e-4)
    a = sensor_effects(img, np.random.default_rng(5))
    b = sensor_effects(img, np.random.default_rng(5))
    assert_array_equal(a, b)


def test_spurious_blob_is_one_separate_tactel():
    rng = np.random.default_rng(2)
    img = line_contact((7.5, 7.5), 0.5, 9.0, 2.0, 2.0)
    spiky = add_spurious_blob(img, rng, force_n=0.1)
    diff = spiky - img
    assert np.count_nonzero(diff) == 1
    assert_allclose(diff.sum(), 0.1, rtol=1e-12)
    _, n = ndimage.label(spiky > defaults.CONTACT_THRESHOLD_N, EIGHT)
    assert n == 2
    assert_array_equal(img, line_contact((7.5, 7.5), 0.5, 9.0, 2.0, 2.0))  # input untouched
    with pytest.raises(ValueError):
        add_spurious_blob(np.ones(PAD), rng)


# ---------------------------------------------------------------------------- accuracy
def test_cop_accuracy_requirement():
    res = cop_accuracy(trials=60, seed=0)
    assert res["line_rms_px"] <= 0.05, res
    assert res["blob_rms_px"] <= 0.05, res


def test_orientation_accuracy_requirement_paper_fig4():
    res = orientation_comparison(trials=20, seed=0)
    assert res["angles_deg"] == [30.0, 45.0, 60.0, 75.0, 90.0, 120.0, 150.0]
    assert res["moments_nan"] == 0 and res["hough_nan"] == 0
    assert np.max(res["moments"]) <= 0.5, res
    assert np.max(res["hough"]) <= 5.0, res
    assert 30 <= res["mean_area"] <= 50  # ~2 N over ~40 tactels


def test_accuracy_with_per_tactel_calibration():
    rng = np.random.default_rng(4)
    cal = TactelCalibration.random(rng)
    cop_err, ang_err = [], []
    for k in range(30):
        truth = rng.uniform(-math.pi / 2, math.pi / 2)
        centre = rng.uniform(6.5, 8.5, 2)
        img = line_contact(centre, truth, (6, 9, 12)[k % 3], 2.0, 2.0)
        img = sensor_effects(add_spurious_blob(img, rng), rng, cal)
        f = extract(img)
        cop_err.append(np.hypot(*(f.cop_px - centre)))
        ang_err.append(abs(math.degrees(wrap_half_pi(f.orientation - truth))))
    assert math.sqrt(np.mean(np.square(cop_err))) <= 0.05
    assert np.mean(ang_err) <= 0.5


def test_studies_are_reproducible():
    assert cop_accuracy(trials=6, seed=3) == cop_accuracy(trials=6, seed=3)
    a = orientation_comparison(angles_deg=(45,), trials=3, seed=1)
    b = orientation_comparison(angles_deg=(45,), trials=3, seed=1)
    assert a == b
