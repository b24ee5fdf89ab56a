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


def test_bench_reports_sweep_throughput_with_one_and_two_workers_as_a_ratio():
    from tactile_bt.experiments.bench import bench_sweep

    w = bench_sweep(runs=2, duration=0.3, repeats=1)
    assert w["runs"] == 2 and w["workers"] == 2 and w["runs_per_s_1_worker"] > 0
    if w["runs_per_s_n_workers"] is not None:  # with the cluster extra
        assert w["speedup"] == pytest.approx(w["runs_per_s_n_workers"] / w["runs_per_s_1_worker"])
    line = format_bench({**_MINIMAL, "sweep": w}).splitlines()[-1]
    assert line.startswith("sweep throughput") and "runs/s with 1 worker" in line


#: The figures format_bench needs, as bench --quick gives them (values do not matter here).
_MINIMAL = {
    "features": {"extract_moments_us": 1.0, "regionprops_baseline_us": 2.0, "speedup_vs_regionprops": 2.0,
                 "target_speedup": 4.0, "extract_hough_us": 3.0},
    "control_cycle": {"control_cycle_us": 1.0, "share_of_frame_period": 0.1},
    **{key: {"mount": mount, "real_time_factor": 5.0, "target_real_time_factor": 25.0, "per_cycle_us": {}}
       for key, mount in (("cable_mission", "lwr4"), ("cable_mission_ideal_mount", "cartesian"))},
}
