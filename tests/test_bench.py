"""tactile-bt bench produces its figures (no timing is asserted: speed is measured, not tested)."""

import json

import pytest

from tactile_bt.experiments.bench import bench_control_cycle, bench_features, bench_mission, format_bench


def test_bench_figures_are_ratios_measured_in_one_run():
    figures = {
        "features": bench_features(repeats=1, number=5),
        "control_cycle": bench_control_cycle(repeats=1, number=5),
        "cable_mission": bench_mission(duration=0.5),
        "cable_mission_ideal_mount": bench_mission(duration=0.5, ideal=True),
    }
    f = figures["features"]
    assert f["speedup_vs_regionprops"] == pytest.approx(f["regionprops_baseline_us"] / f["extract_moments_us"])
    c = figures["control_cycle"]
    assert c["share_of_frame_period"] == pytest.approx(c["control_cycle_us"] / c["frame_period_1900hz_us"])
    for key, mount in (("cable_mission", "lwr4"), ("cable_mission_ideal_mount", "cartesian")):
        m = figures[key]
        assert m["mount"] == mount
        assert m["sim_time_s"] == 0.5 and m["real_time_factor"] > 0
        assert set(m["per_cycle_us"]) >= {"simulated_sensor", "control_loop", "mount_move"}
    json.dumps(figures)  # what `bench --json` prints
    assert "real time" in format_bench(figures)
