"""Watching a mission: node status per tick and tree.png, the rerun recording read back with
rerun's own reader, runs compared side by side, and what node status logging costs."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import py_trees
import pytest
from py_trees.common import Status

from tactile_bt import run_mission
from tactile_bt.cli import main
from tactile_bt.errors import TactileBtError
from tactile_bt.mission.node_status import STATUS_CODES, STATUS_NAMES, NodeStatusLog

ROOT = Path(__file__).resolve().parents[2]
CABLE_TREE = ROOT / "trees" / "cable_follow.yaml"
CABLE_SCENE = ROOT / "sim" / "cable.yaml"
PNG = b"\x89PNG\r\n\x1a\n"


def rrd_rows(path: Path) -> dict[str, int]:
    """Rows per entity path of a recording (its timeline data; static rows left out), read with
    rerun's reader."""
    import rerun.chunk

    store = rerun.chunk.RrdReader(path).store()
    rows: dict[str, int] = {}
    for line in store.summary().splitlines():
        m = re.match(r"(\S+) rows=(\d+) static=(\w+)", line)
        if m and m[3] == "False":
            rows[m[1]] = rows.get(m[1], 0) + int(m[2])
    return rows


@pytest.fixture(scope="module")
def watched(tmp_path_factory):
    """``tactile-bt run`` of the cable mission for 2 s with ``--rerun``."""
    tmp = tmp_path_factory.mktemp("watched")
    rc = main(["run", str(CABLE_TREE), "--scene", str(CABLE_SCENE), "--duration", "2", "--seed", "0",
               "--rerun", str(tmp / "a.rrd"), "--out", str(tmp / "a")])
    assert rc == 0
    return tmp


def test_every_run_logs_each_nodes_status_per_tick_in_tree_order(watched):
    with np.load(watched / "a" / "log.npz") as log:
        names, status, t = list(log["node_names"]), log["node_status"], log["t"]
        depth = log["node_depth"]
    assert status.dtype == np.uint8 and status.shape == (len(t), len(names))
    assert names[0] == "cable_follow" and depth[0] == 0
    assert names.index("cable_follow/follow_cable/approach") < names.index("cable_follow/follow_cable/follow_or_recover/attempt/follow/guided_slide")
    assert all(depth[i] == names[i].count("/") for i in range(len(names)))
    approach = status[:, names.index("cable_follow/follow_cable/approach")]
    # The approach runs from the first tick until it touches, then has succeeded for good.
    assert approach[0] == STATUS_CODES[Status.RUNNING]
    done = np.flatnonzero(approach == STATUS_CODES[Status.SUCCESS])
    assert 0 < done[0] < len(t) and np.all(approach[done[0]:] == STATUS_CODES[Status.SUCCESS])
    # The guided slide only starts once the approach and the settling are over.
    slide = status[:, names.index("cable_follow/follow_cable/follow_or_recover/attempt/follow/guided_slide")]
    assert np.all(slide[:done[0] + 1] == STATUS_CODES[Status.INVALID])
    assert status.max() < len(STATUS_NAMES)


def test_every_run_draws_tree_png(watched):
    png = watched / "a" / "tree.png"
    assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000


def test_the_rerun_recording_holds_what_the_loop_saw(watched):
    rows = rrd_rows(watched / "a.rrd")
    for entity in ("/tactile/force_image", "/tactile/force_image/region", "/tactile/force_image/cop", "/pad",
                   "/contacts", "/tree/status", *(f"/features/{n}" for n in ("pressure_pa", "cop_x_px", "cop_y_px",
                                                                             "orientation_rad"))):
        assert entity in rows, entity
    # 2 s at the default 50 Hz: a force image per logged frame, every fifth of the 500 cycles.
    assert rows["/tactile/force_image"] == 100
    assert rows["/pad"] == rows["/features/pressure_pa"] == 100
    # The approach, the settling and the follow start in 2 s: at least three status changes.
    assert rows["/tree/status"] >= 3


def test_node_status_log_forward_fills_what_it_saw_every_tick():
    rng = np.random.default_rng(3)
    leaves = [py_trees.behaviours.Dummy(f"leaf{i}") for i in range(4)]
    root = py_trees.composites.Sequence("root", memory=False, children=leaves[:2])
    branch = py_trees.composites.Selector("branch", memory=False, children=leaves[2:])
    root.add_child(branch)
    log = NodeStatusLog(root, 50)
    assert log.names == ("root", "root/leaf0", "root/leaf1", "root/branch", "root/branch/leaf2",
                         "root/branch/leaf3")
    nodes = [root, leaves[0], leaves[1], branch, leaves[2], leaves[3]]
    seen = []
    for k in range(50):
        if rng.random() < 0.3:  # statuses change now and then
            for node in nodes:
                node.status = list(Status)[rng.integers(4)]
        seen.append([STATUS_CODES[n.status] for n in nodes])
        log.record(k)
    assert np.array_equal(log.arrays()["node_status"], np.array(seen, dtype=np.uint8))


def test_replay_writes_tree_png_and_a_rerun_recording(tmp_path):
    run_mission(CABLE_TREE, CABLE_SCENE, duration=1.0, seed=0, recording=tmp_path / "r.tbr")
    rc = main(["replay", str(tmp_path / "r.tbr"), "--tree", str(CABLE_TREE), "--out", str(tmp_path / "replay"),
               "--rerun", str(tmp_path / "replay.rrd"), "--rerun-rate", "25"])
    assert rc == 0
    assert (tmp_path / "replay" / "tree.png").read_bytes()[:8] == PNG
    with np.load(tmp_path / "replay" / "log.npz") as log:
        assert log["node_status"].shape == (250, len(log["node_names"]))
    rows = rrd_rows(tmp_path / "replay.rrd")
    assert rows["/tactile/force_image"] == 25  # 1 s at 25 Hz
    assert "/tree/status" in rows


def test_rerun_options_fail_before_the_mission_with_a_clear_message(tmp_path, capsys, monkeypatch):
    run = ["run", str(CABLE_TREE), "--scene", str(CABLE_SCENE), "--duration", "0.2", "--out", str(tmp_path / "out")]
    assert main([*run, "--rerun", str(tmp_path)]) == 2
    assert f"--rerun {tmp_path} is a directory" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "rerun", None)  # as if rerun-sdk were not installed
    assert main([*run, "--rerun", str(tmp_path / "a.rrd")]) == 2
    assert "pip install 'tactile_bt[viewer]'" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_compare_puts_two_runs_side_by_side(watched, tmp_path):
    rc = main(["run", str(CABLE_TREE), "--scene", str(CABLE_SCENE), "--duration", "2", "--seed", "1",
               "--out", str(tmp_path / "b")])
    assert rc == 0
    a, b = str(watched / "a"), str(tmp_path / "b")
    assert main(["compare", a, b, "--out", str(tmp_path / "c")]) == 0
    md = (tmp_path / "c" / "compare.md").read_text()
    outcome = [line for line in md.splitlines() if line.startswith(f"| {a} ") or line.startswith(f"| {b} ")]
    assert len(outcome) == 2 + 2 * 4  # the outcome table, and one row per run in each feature's table
    assert "| 0 | completed |" in outcome[0] and "| 1 | completed |" in outcome[1]
    for name in ("pressure_pa", "cop_x_px", "cop_y_px", "orientation_rad"):
        assert f"## {name}" in md
    assert (tmp_path / "c" / "compare.png").read_bytes()[:8] == PNG


def test_a_sweeps_output_counts_as_its_runs(watched, tmp_path):
    from tactile_bt.experiments.compare import find_runs

    sweep = tmp_path / "sweep"
    for run_id in ("r1", "r0"):
        shutil.copytree(watched / "a", sweep / "runs" / run_id)
    runs = find_runs([sweep, watched / "a"])
    assert [r.label for r in runs] == [f"{sweep}/r0", f"{sweep}/r1", str(watched / "a")]
    (tmp_path / "empty").mkdir()
    with pytest.raises(TactileBtError, match="empty holds no report.json"):
        find_runs([tmp_path / "empty", sweep])


def test_a_plain_run_does_not_import_rerun(tmp_path):
    code = (
        "import sys; from tactile_bt.cli import main;"
        f"main(['run', {str(CABLE_TREE)!r}, '--scene', {str(CABLE_SCENE)!r}, '--duration', '0.3',"
        f" '--out', {str(tmp_path / 'out')!r}]);"
        "print('rerun' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"
    assert (tmp_path / "out" / "tree.png").exists()


def test_bench_shows_the_cable_mission_with_and_without_node_status():
    from tactile_bt.experiments.bench import bench_node_status, format_bench

    figures = bench_node_status(duration=0.3, repeats=1)
    assert figures["real_time_factor_with"] > 0 and figures["real_time_factor_without"] > 0
    assert figures["drop"] == pytest.approx(1 - figures["real_time_factor_with"] / figures["real_time_factor_without"])
    minimal = {"features": {"extract_moments_us": 1.0, "regionprops_baseline_us": 2.0, "speedup_vs_regionprops": 2.0,
                            "target_speedup": 4.0, "extract_hough_us": 3.0},
               "control_cycle": {"control_cycle_us": 1.0, "share_of_frame_period": 0.1}}
    line = format_bench({**minimal, "node_status": figures}).splitlines()[-1]
    assert line.startswith("node status log") and "without" in line and "with," in line
