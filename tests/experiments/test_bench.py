"""tactile-bt bench produces its figures (no timing is asserted: speed is measured, not tested)."""

import json

import pytest

import sys

from tactile_bt.experiments.bench import (bench_control_cycle, bench_features, bench_first_run, bench_mission,
                                          bench_scan, format_bench)


@pytest.mark.slow
def test_bench_figures_are_ratios_measured_in_one_run():
    figures = {
        "features": bench_features(repeats=1, number=5),
        "control_cycle": bench_control_cycle(repeats=1, number=5),
        "cable_mission": bench_mission(duration=0.5),
        "cable_mission_ideal_mount": bench_mission(duration=0.5, ideal=True),
        "stripe_scan": bench_scan(duration=0.5, stage_seconds=0.2),
    }
    f = figures["features"]
    assert f["speedup_vs_regionprops"] == pytest.approx(f["regionprops_baseline_us"] / f["extract_moments_us"])
    c = figures["control_cycle"]
    assert c["share_of_frame_period"] == pytest.approx(c["control_cycle_us"] / c["frame_period_1900hz_us"])
    for key, mount in (("cable_mission", "lwr4"), ("cable_mission_ideal_mount", "cartesian"), ("stripe_scan", "lwr4")):
        m = figures[key]
        assert m["mount"] == mount
        assert m["sim_time_s"] == 0.5 and m["real_time_factor"] > 0
        assert set(m["per_cycle_us"]) >= {"simulated_sensor", "control_loop", "mount_move"}
        for stage, us in m["per_cycle_us"].items():  # each stage also as a share of the 4 ms cycle
            assert m["share_of_cycle_period"][stage] == pytest.approx(us / m["cycle_period_us"])
    assert figures["stripe_scan"]["target_real_time_factor"] == 15.0
    json.dumps(figures)  # what `bench --json` prints
    text = format_bench(figures)
    assert "real time" in text and "stripe scan" in text


def test_bench_reports_sweep_throughput_with_one_and_two_workers_as_a_ratio():
    from tactile_bt.experiments.bench import bench_sweep

    w = bench_sweep(runs=2, duration=0.3, repeats=1)
    assert w["runs"] == 2 and w["workers"] == 2 and w["runs_per_s_1_worker"] > 0
    if w["runs_per_s_n_workers"] is not None:  # with the cluster extra
        assert w["speedup"] == pytest.approx(w["runs_per_s_n_workers"] / w["runs_per_s_1_worker"])
    line = format_bench({**_MINIMAL, "sweep": w}).splitlines()[-1]
    assert line.startswith("sweep throughput") and "runs/s with 1 worker" in line


def test_first_run_times_a_fresh_process_with_an_empty_then_a_filled_cache(tmp_path):
    """The cold/warm figure, with a stand-in command (the real one compiles for many seconds)."""
    marker = tmp_path / "runs"
    script = ("import os, pathlib; d = pathlib.Path(os.environ['NUMBA_CACHE_DIR']); "
              f"p = pathlib.Path({str(marker)!r}); p.write_text(p.read_text() + d.name + ' ' + "
              "str(sorted(x.name for x in d.iterdir())) + chr(10) if p.exists() else d.name + ' []' + chr(10)); "
              "(d / 'filled').write_text('x')")
    r = bench_first_run(command=[sys.executable, "-c", script])
    first, second = marker.read_text().splitlines()
    assert first.split()[0] == second.split()[0]  # the same cache directory ...
    assert first.endswith("[]") and "filled" in second  # ... empty the first time, filled the second
    assert r["cold_over_warm"] == pytest.approx(r["cold_cache_s"] / r["warm_cache_s"])
    line = format_bench({**_MINIMAL, "first_run": {**r, "mission_s": 20.0, "cold_real_time_factor": 1.0,
                                                   "warm_real_time_factor": 2.0}})
    assert "first run" in line and "empty kernel cache" in line
    assert r["view_s"] is None  # a stand-in command has no render to time


def test_the_main_command_figure_adds_the_render_to_the_mission():
    r = {"command": "", "mission_s": 20.0, "cold_cache_s": 9.0, "warm_cache_s": 2.5, "cold_over_warm": 3.6,
         "cold_real_time_factor": 2.2, "warm_real_time_factor": 8.0, "view_s": 2.0,
         "main_command_cold_s": 11.0, "main_command_warm_s": 4.5}
    line = format_bench({**_MINIMAL, "first_run": r}).splitlines()[-1]
    assert line.startswith("main command") and "11.0 s the first time" in line and "render: 2.0 s" in line


#: The figures format_bench needs, as bench --quick gives them (values do not matter here).
_MINIMAL = {
    "features": {"extract_moments_us": 1.0, "regionprops_baseline_us": 2.0, "speedup_vs_regionprops": 2.0,
                 "target_speedup": 4.0, "extract_hough_us": 3.0},
    "control_cycle": {"control_cycle_us": 1.0, "share_of_frame_period": 0.1},
    **{key: {"mount": mount, "real_time_factor": 5.0, "target_real_time_factor": 25.0, "per_cycle_us": {}}
       for key, mount in (("cable_mission", "lwr4"), ("cable_mission_ideal_mount", "cartesian"))},
}
