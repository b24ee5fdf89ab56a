"""Every stability case of `tactile-bt stability` stays finite and behaves: the stiffness sweep
settles within 2 s, each extreme case is survived or stopped by its guard."""

import pytest

from tactile_bt.experiments.stability import extreme_cases, run_case, stiffness_cases


@pytest.mark.parametrize("case", stiffness_cases(), ids=lambda c: c.name)
def test_force_hold_on_the_pen_settles_for_every_stiffness(case):
    row = run_case(case)
    assert row["finite"] and row["ok"], row["verdict"]
    assert row["response_time_s"] <= 2.0
    assert row["max_penetration_mm"] < 10.0  # no tunnelling through the 8 mm pen


@pytest.mark.parametrize("case", extreme_cases(), ids=lambda c: c.name)
def test_extreme_case_is_finite_and_as_expected(case):
    row = run_case(case)
    assert row["finite"], row["verdict"]
    assert row["ok"], row["verdict"]
    if case.name == "joint limit":
        assert row["min_joint_margin_deg"] == pytest.approx(0.0, abs=1e-6)  # driven into the limit
        assert row["min_joint_margin_deg"] >= -1e-6  # ... and never past it
    if case.name == "singularity":
        assert row["min_manipulability"] < 0.005  # the arm was stretched


def test_the_cable_mission_at_a_control_rate_gives_its_row():
    from tactile_bt.experiments.stability import run_rates

    (row,) = run_rates(rates=(100,), duration=3.0)
    assert row["rate_hz"] == 100 and row["finite"]
    assert row["path_error_mean_mm"] >= 0 and row["followed_mm"] > 0
    assert set(row) >= {"wall_time_s", "real_time_factor", "pressure_std", "pressure_steady_state_error"}


def test_the_table_prints_no_negative_zero():
    """A joint driven exactly into its limit has a margin of -1e-12 deg, not '-0.0'."""
    from tactile_bt.experiments.stability import _fmt

    assert _fmt(-1e-12, ".1f") == "0.0" and _fmt(-1e-12, "+.4f") == "+0.0000"
    assert _fmt(-0.25, ".1f") == "-0.2" and _fmt(None, ".1f") == _fmt(float("nan"), ".1f") == "–"
