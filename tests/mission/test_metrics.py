"""Metrics of the paper's Tables I–III (response time, steady-state error, std) and the cable
path error, on constructed series with known answers."""

import numpy as np
import pytest

from tactile_bt.mission.metrics import feature_metrics, path_error, response_time
from tactile_bt.sim.objects import Cable, polyline_from_segments

DT = 0.004  # 250 Hz


def decay(t, e0=1000.0, tau=0.2):
    return e0 * np.exp(-t / tau)


# --------------------------------------------------------------------------------- response_time


def test_response_time_of_an_exponential_decay():
    t = np.arange(0.0, 5.0, DT)
    e = decay(t)
    exact = 0.2 * np.log(1000.0 / 100.0)  # |e| = band at t = τ ln(e0 / band) = 0.4605 s
    rt = response_time(t, e, band=100.0, dwell=0.5)
    assert exact <= rt < exact + DT  # the first sample inside the band


def test_response_time_counts_from_the_first_sample():
    t = 12.0 + np.arange(0.0, 5.0, DT)
    e = -decay(t - 12.0)  # negative errors: the band is on |e|
    rt = response_time(t, e, band=100.0, dwell=0.5)
    assert rt == pytest.approx(0.2 * np.log(10.0), abs=DT)


def test_late_excursion_after_settling_keeps_the_response_time_but_shows_in_the_std():
    """Documented definition: the first entry into the band that lasts for the dwell. A later
    disturbance does not move the response time; it belongs to the steady state (its std)."""
    t = np.arange(0.0, 6.0, DT)
    e = decay(t)
    late = (t >= 3.0) & (t < 3.2)
    e_late = e.copy()
    e_late[late] = 250.0  # a disturbance long after the first settling
    rt = response_time(t, e_late, band=100.0, dwell=0.5)
    assert rt == response_time(t, e, band=100.0, dwell=0.5)
    assert rt == pytest.approx(0.2 * np.log(10.0), abs=DT)
    quiet = feature_metrics(t, e, band=100.0, dwell=0.5)
    disturbed = feature_metrics(t, e_late, band=100.0, dwell=0.5)
    assert disturbed["response_time_s"] == quiet["response_time_s"]
    assert disturbed["std"] > 3 * quiet["std"]
    assert disturbed["steady_state_error"] > quiet["steady_state_error"]


def test_excursion_before_the_dwell_is_complete_delays_the_response_time():
    t = np.arange(0.0, 6.0, DT)
    e = decay(t)
    e[(t >= 0.7) & (t < 0.8)] = 250.0  # leaves the band 0.24 s after entering it
    rt = response_time(t, e, band=100.0, dwell=0.5)
    assert rt == pytest.approx(0.8, abs=DT / 2)


def test_short_visits_inside_the_band_do_not_count():
    """An oscillation that dips into the band for less than the dwell, then settles at 2 s."""
    t = np.arange(0.0, 5.0, DT)
    e = np.where(t < 2.0, 300.0 * np.cos(2 * np.pi * 2.0 * t), 10.0)  # inside ~0.05 s per dip
    rt = response_time(t, e, band=100.0, dwell=0.2)
    assert rt == pytest.approx(2.0, abs=DT / 2)
    # with a dwell shorter than a dip the first dip counts
    assert response_time(t, e, band=100.0, dwell=0.01) < 0.2


def test_never_settling_is_nan():
    t = np.arange(0.0, 5.0, DT)
    assert np.isnan(response_time(t, np.full_like(t, 500.0), band=100.0))
    # dips into the band, but never for the dwell, and ends outside it
    e = 300.0 * np.cos(2 * np.pi * 2.0 * t)
    e[-50:] = 300.0
    assert np.isnan(response_time(t, e, band=100.0, dwell=0.2))


def test_a_last_instant_inside_the_band_is_not_settling():
    t = np.arange(0.0, 5.0, DT)
    e = np.full_like(t, 500.0)
    e[-3:] = 0.0  # inside the band for the last 8 ms only, dwell 0.5 s
    assert np.isnan(response_time(t, e, band=100.0, dwell=0.5))


def test_nan_samples_count_as_outside_the_band():
    t = np.arange(0.0, 3.0, DT)
    e = np.zeros_like(t)
    e[(t >= 1.0) & (t < 1.1)] = np.nan  # features undefined for 0.1 s
    assert response_time(t, e, band=1.0, dwell=1.5) == pytest.approx(1.1, abs=DT / 2)
    assert np.isnan(response_time(t, np.full_like(t, np.nan), band=1.0))


def test_inside_from_the_start_is_zero():
    t = np.arange(0.0, 2.0, DT)
    assert response_time(t, np.zeros_like(t), band=1.0, dwell=0.5) == 0.0


# --------------------------------------------------------------------------------- feature_metrics


def constructed_series(rng):
    """Not controlled for 1 s (NaN), 1 s outside the band, then offset ± noise until t0 + 20 s,
    then a large error that lies outside the 20 s window."""
    t = np.arange(0.0, 25.0, 0.01)
    e = np.full_like(t, np.nan)
    e[(t >= 1.0 - 1e-9)] = 500.0
    steady = t >= 2.0 - 1e-9
    noise = rng.choice([-1.0, 1.0], size=steady.sum())
    e[steady] = 20.0 + 5.0 * noise
    e[t > 21.5] = 1.0e4  # beyond t0 + 20 s: must not count
    return t, e, noise


def test_feature_metrics_window_steady_state_and_std():
    rng = np.random.default_rng(0)
    t, e, _ = constructed_series(rng)
    m = feature_metrics(t, e, band=100.0, window_s=20.0, dwell=0.5)
    assert m["start_s"] == pytest.approx(1.0)
    assert m["response_time_s"] == pytest.approx(1.0, abs=0.011)
    assert m["window_s"] == pytest.approx(20.0, abs=0.011)
    # the steady part: 20 ± 5 (random signs), from t = 2 s to t0 + 20 s = 21 s
    window = (t >= 2.0 - 1e-9) & (t <= 21.0 + 1e-9)
    ref = e[window]
    assert m["steady_state_error"] == pytest.approx(ref.mean(), abs=1e-9)
    assert m["std"] == pytest.approx(ref.std(), abs=1e-9)
    assert m["steady_state_error"] == pytest.approx(20.0, abs=0.5)
    assert m["std"] == pytest.approx(5.0, abs=0.05)
    assert m["band"] == 100.0


def test_feature_metrics_ignores_nan_gaps_in_the_tail():
    rng = np.random.default_rng(1)
    t, e, _ = constructed_series(rng)
    e_gap = e.copy()
    e_gap[(t > 10.0) & (t < 10.05)] = np.nan  # features undefined briefly after settling
    m = feature_metrics(t, e_gap, band=100.0, window_s=20.0, dwell=0.5)
    assert np.isfinite(m["steady_state_error"]) and np.isfinite(m["std"])
    assert m["steady_state_error"] == pytest.approx(20.0, abs=0.5)


def test_feature_metrics_of_a_feature_that_never_settles():
    t = np.arange(0.0, 5.0, 0.01)
    m = feature_metrics(t, np.full_like(t, 500.0), band=100.0)
    assert np.isnan(m["response_time_s"])
    assert np.isnan(m["steady_state_error"]) and np.isnan(m["std"])


def test_feature_metrics_of_an_uncontrolled_feature_is_none():
    t = np.arange(0.0, 5.0, 0.01)
    assert feature_metrics(t, np.full_like(t, np.nan), band=1.0) is None


# --------------------------------------------------------------------------------- path_error


@pytest.fixture(scope="module")
def straight_cable():
    return Cable(path=polyline_from_segments((0.0, 0.0), 0.0, [{"straight": 0.2}]), radius=0.003)


def test_path_error_of_points_at_a_known_offset(straight_cable):
    x = np.linspace(0.05, 0.15, 101)
    offsets = np.where(np.arange(101) % 2 == 0, 0.002, -0.001)
    pts = np.stack((x, offsets), axis=1)
    pe = path_error(pts, straight_cable)
    assert pe["mean"] == pytest.approx(np.mean(np.abs(offsets)), abs=1e-12)
    assert pe["max"] == pytest.approx(0.002, abs=1e-12)
    assert pe["p95"] == pytest.approx(0.002, abs=1e-12)
    assert pe["followed_m"] == pytest.approx(0.1, abs=0.0011)
    assert pe["cable_length_m"] == pytest.approx(0.2)


def test_path_error_on_a_bend():
    R = 0.08
    cable = Cable(path=polyline_from_segments((0.0, 0.0), 0.0, [{"arc": {"radius": R, "angle_deg": 90}}]))
    phi = np.linspace(-np.pi / 2 + 0.1, -0.1, 50)  # centre of the arc at (0, R)
    rho = R + 0.003
    pts = np.stack((rho * np.cos(phi), R + rho * np.sin(phi)), axis=1)
    pe = path_error(pts, cable)
    assert pe["mean"] == pytest.approx(0.003, abs=2e-5)
    assert pe["max"] == pytest.approx(0.003, abs=2e-5)
    assert pe["followed_m"] == pytest.approx(R * (np.pi / 2 - 0.2), abs=0.002)


def test_path_error_without_points(straight_cable):
    pe = path_error(np.empty((0, 2)), straight_cable)
    assert np.isnan(pe["mean"]) and np.isnan(pe["max"])
    assert pe["followed_m"] == 0.0


def _report(**kw):
    from tactile_bt.mission.report import FeatureMetrics, MissionReport

    base = dict(tree="t.yaml", scene="s.yaml", seed=0, status="success", reason="", sim_time_s=1.0,
                wall_time_s=0.1, real_time_factor=10.0, ticks=250, contacts=0, metrics={})
    base["metrics"] = {name: FeatureMetrics(*m) for name, m in kw.pop("metrics", {}).items()}
    return MissionReport(**base, **kw)


def test_the_summary_says_a_feature_never_settled_instead_of_printing_nan():
    nan = float("nan")
    report = _report(metrics={"pressure_pa": (-0.2, 30.6, 0.07, 200.0, 0.5, 20.0),
                              "orientation_rad": (nan, nan, nan, 0.0524, 0.5, 3.0)})
    lines = report.summary_lines()
    assert lines[0].split() == ["pressure_pa", "steady-state", "-0.2", "std", "30.6", "response", "0.07", "s"]
    assert lines[1].split()[0] == "orientation_rad" and "never settled within ±0.0524 rad in 3.00 s" in lines[1]
    assert not any("nan" in line for line in lines)


@pytest.mark.parametrize("region, words", [
    ({"normal": [0.0, 0.0, 1.0], "max_angle_deg": 10}, "of the scan region (normals within 10° of [0, 0, 1])"),
    ("whole object", "of the whole object"),
])
def test_the_summary_describes_the_scan_region_in_words(region, words):
    rec = {"method": "delaunay", "points": 100, "chamfer_m": 1e-3, "hausdorff_m": 2e-3, "coverage": 1.0,
           "region": region}
    line = _report(reconstruction=rec).summary_lines()[-1]
    assert line.endswith(f"coverage 1.000 {words}"), line
    assert "{" not in line


def test_force_figures_measure_the_pressure_against_the_held_target_after_the_approach():
    from tactile_bt.mission.metrics import force_figures

    dt = 0.004
    t = np.arange(0, 4.0, dt)
    pressure = np.full(len(t), 600.0)
    error = pressure - 500.0  # logged as measured - target: an adapted target of 500 Pa
    error[t < 1.0] = np.nan  # the approach: no target held
    pressure[t < 1.0] = 5000.0  # whatever the approach pressed does not count
    pressure[(t >= 2.0) & (t < 2.2)] = 1200.0  # 0.2 s above twice the target
    error = np.where(np.isnan(error), np.nan, pressure - 500.0)
    force = np.full(len(t), 2.0)
    force[t < 1.0] = 30.0
    twist = np.zeros((len(t), 6))
    twist[(t >= 3.0), 3] = np.where(np.arange(np.sum(t >= 3.0)) % 2, 1.0, -1.0)  # ωx chatters for 1 s
    log = {"t": t, "pressure_pa": pressure, "error_pressure_pa": error, "force_n": force, "twist_s": twist}
    f = force_figures(log)
    assert f["target_min_pa"] == pytest.approx(500.0) and f["target_max_pa"] == pytest.approx(500.0)
    assert f["longest_over_s"] == pytest.approx(0.2, abs=1.5 * dt)
    assert f["over_share"] == pytest.approx(0.2 / 3.0, abs=0.01)
    assert f["peak_force_n"] == 2.0 and f["peak_ratio"] == pytest.approx(2.4)
    assert not f["ok"]  # 0.2 s above twice the target: more than 0.1 s
    assert f["chatter_per_s"][3] == pytest.approx(250 / 3.0, rel=0.02)  # 250 sign changes in 3 s
    assert f["chatter_per_s"][4] == 0.0
    pressure[(t >= 2.0) & (t < 2.2)] = 600.0
    log["error_pressure_pa"] = np.where(np.isnan(error), np.nan, pressure - 500.0)
    assert force_figures(log)["ok"]
