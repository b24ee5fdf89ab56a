"""`tactile-bt sweep`: the spec and its errors, the table on every executor, error rows, resume.

Missions are 0.5-1 s long; the Dask tests share one in-process LocalCluster (threads, loopback)."""

from __future__ import annotations

import csv
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tactile_bt.cli import main
from tactile_bt.errors import CommandLineError, YamlError
from tactile_bt.experiments import executors
from tactile_bt.experiments.executors import InProcess, make_executor, run_all
from tactile_bt.experiments.sweep import RESULTS, SUMMARY_PNG, format_summary, load_spec, plan, run_sweep

REPO = Path(__file__).resolve().parents[2]
#: Columns that differ between two runs of the same mission: measured wall time.
WALL = ("wall_time_s", "real_time_factor")

SPEC = f"""\
name: tiny
tree: {REPO}/trees/force_hold.yaml
scene: {REPO}/sim/pen.yaml
duration: 1.5
seeds: [0, 1]
grid:
  objects.0.stiffness: [1.0e4, 1.0e6]
"""


def _spec(tmp_path: Path, text: str = SPEC, name: str = "spec.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def _table(out: Path) -> list[dict]:
    with open(out / RESULTS, newline="") as f:
        rows = list(csv.DictReader(f))
    return sorted(({k: v for k, v in r.items() if k not in WALL} for r in rows), key=lambda r: r["run_id"])


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,  # in-process, no network
                                  dashboard_address=None, scheduler_kwargs={"dashboard": False,
                                                                            "dashboard_address": "127.0.0.1:0"}) as c:
        with distributed.Client(c, set_as_default=False, timeout=30) as client:
            yield client


@pytest.fixture(scope="module")
def serial_table(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    result = run_sweep(_spec(out), out / "sweep", executor=InProcess())
    assert result.ran == 4 and result.errors == 0
    return out / "sweep"


# --------------------------------------------------------------------------- the table
def test_the_table_has_a_row_per_run_with_grid_seed_status_and_flattened_metrics(serial_table):
    rows = _table(serial_table)
    assert len(rows) == 4
    assert {(r["objects.0.stiffness"], r["seed"]) for r in rows} == {
        ("10000.0", "0"), ("10000.0", "1"), ("1000000.0", "0"), ("1000000.0", "1")}
    for r in rows:
        assert r["scene"].endswith("sim/pen.yaml") and r["status"] == "completed" and r["reason"] == ""
        assert float(r["sim_time_s"]) == pytest.approx(1.5)
        assert float(r["metrics.pressure_pa.std"]) > 0
        assert "metrics.pressure_pa.response_time_s" in r
    header = (serial_table / RESULTS).read_text().splitlines()[0].split(",")
    assert header[:4] == ["run_id", "scene", "objects.0.stiffness", "seed"]
    assert "wall_time_s" in header
    assert (serial_table / SUMMARY_PNG).stat().st_size > 0


def test_a_sweep_on_a_local_dask_cluster_gives_the_same_table(tmp_path, cluster, serial_table):
    executor = executors.DaskExecutor(client=cluster)
    result = run_sweep(_spec(tmp_path), tmp_path / "sweep", executor=executor)
    assert result.ran == 4 and result.errors == 0
    # The simulator is deterministic per seed: the same code on any executor gives the same
    # numbers, digit for digit (floats are written with repr); only the wall times differ.
    assert _table(tmp_path / "sweep") == _table(serial_table)


def test_a_second_run_skips_the_finished_runs(tmp_path, serial_table, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    (out / RESULTS).write_text((serial_table / RESULTS).read_text())
    code = main(["sweep", str(_spec(tmp_path)), "--out", str(out), "--workers", "1"])
    captured = capsys.readouterr()
    assert code == 0
    assert "skipped 4 of 4 runs" in captured.err
    assert "0 ran now, 4 skipped" in captured.out
    assert _table(out) == _table(serial_table)


def test_tree_parameters_and_several_scenes_in_the_grid(tmp_path):
    spec = _spec(tmp_path, f"""\
        tree: {REPO}/trees/force_hold.yaml
        scenes: [{REPO}/sim/pen.yaml, {REPO}/sim/toy_box.yaml]
        duration: 0.6
        seeds: {{first: 3, count: 1}}
        grid:
          tree.force_hold.target_pa: [1500, 2 kPa]
          mount.rpy_deg: [[180, 0, 0]]
        set:
          mount.damping: 0.3
        """)
    result = run_sweep(spec, tmp_path / "out", keep_runs=True)
    rows = _table(tmp_path / "out")
    assert len(rows) == 4 and result.errors == 0
    # SI numbers in the grid's column; the text as written beside them, for the values with a unit
    assert {(r["tree.force_hold.target_pa"], r["tree.force_hold.target_pa (as written)"]) for r in rows} == {
        ("1500", ""), ("2000.0", "2 kPa")}
    assert "mount.rpy_deg (as written)" not in rows[0]
    assert {r["seed"] for r in rows} == {"3"}
    assert {Path(r["scene"]).name for r in rows} == {"pen.yaml", "toy_box.yaml"}
    run = next(r for r in result.runs if dict(r.values)["tree.force_hold.target_pa"] == 1500)
    assert run.params == (("force_hold.target_pa", 1500),)
    assert run.overrides == ("mount.damping=0.3", "mount.rpy_deg=[180, 0, 0]")
    assert all((tmp_path / "out" / "runs" / r["run_id"] / "report.json").exists() for r in rows)
    assert {r["mount.rpy_deg"] for r in rows} == {"[180, 0, 0]"}
    summary = format_summary(result).splitlines()
    assert summary[0].startswith("| scene | tree.force_hold.target_pa | mount.rpy_deg | runs | errors |")
    assert len(summary) == 2 + 4 and "| 1500 | [180, 0, 0] | 1 | 0 |" in summary[2]


# --------------------------------------------------------------------------- faults
def _raise_for_seed_1(real):
    def run_mission(*args, **kwargs):
        if kwargs.get("seed") == 1:
            raise RuntimeError("the simulator broke")
        return real(*args, **kwargs)
    return run_mission


@pytest.mark.parametrize("where", ["in-process", "dask"])
def test_a_run_that_raises_becomes_an_error_row_and_the_sweep_goes_on(tmp_path, monkeypatch, where, request):
    import tactile_bt.mission.run as mission_run

    monkeypatch.setattr(mission_run, "run_mission", _raise_for_seed_1(mission_run.run_mission))
    executor = executors.DaskExecutor(client=request.getfixturevalue("cluster")) if where == "dask" else None
    result = run_sweep(_spec(tmp_path), tmp_path / "out", executor=executor)
    rows = _table(tmp_path / "out")
    assert result.ran == 4 and result.errors == 2
    errors = [r for r in rows if r["status"] == "error"]
    assert {r["seed"] for r in errors} == {"1"}
    assert all(r["reason"] == "RuntimeError: the simulator broke" for r in errors)
    assert all(r["status"] == "completed" for r in rows if r["seed"] == "0")


def test_a_run_past_its_timeout_is_an_error_row(tmp_path):
    spec = _spec(tmp_path, SPEC.replace("duration: 1.5", "duration: 2.0\ntimeout_s: 0.05"))
    result = run_sweep(spec, tmp_path / "out")
    rows = _table(tmp_path / "out")
    assert result.errors == 4
    assert all(r["status"] == "error" and r["reason"].startswith("timed out") for r in rows)


def test_error_rows_are_kept_on_a_rerun_unless_retry_errors(tmp_path, monkeypatch):
    import tactile_bt.mission.run as mission_run

    real = mission_run.run_mission
    monkeypatch.setattr(mission_run, "run_mission", _raise_for_seed_1(real))
    run_sweep(_spec(tmp_path), tmp_path / "out")
    monkeypatch.setattr(mission_run, "run_mission", real)
    again = run_sweep(_spec(tmp_path), tmp_path / "out")
    assert again.ran == 0 and again.errors == 2
    retried = run_sweep(_spec(tmp_path), tmp_path / "out", retry_errors=True)
    assert retried.ran == 2 and retried.skipped == 2 and retried.errors == 0
    assert len(_table(tmp_path / "out")) == 4


def test_resume_after_an_interrupted_sweep(tmp_path, serial_table):
    def ctrl_c_after_two(done, total, note=""):
        if done == 2:
            raise KeyboardInterrupt

    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(_spec(tmp_path), out, progress=ctrl_c_after_two)
    assert len(_table(out)) == 2  # the finished runs are on disk
    with open(out / RESULTS, "a") as f:  # and a line torn by a crash is dropped
        f.write("deadbeef,sim/pe")
    result = run_sweep(_spec(tmp_path), out)
    assert (result.skipped, result.ran) == (2, 2)
    assert any("torn" in n for n in result.notes)
    assert _table(out) == _table(serial_table)


def test_ctrl_c_on_a_dask_cluster_cancels_the_runs_in_flight(tmp_path, cluster):
    def ctrl_c_after_one(done, total, note=""):
        raise KeyboardInterrupt

    executor = executors.DaskExecutor(client=cluster)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(_spec(tmp_path), tmp_path / "out", executor=executor, progress=ctrl_c_after_one)
    assert len(_table(tmp_path / "out")) == 1
    result = run_sweep(_spec(tmp_path), tmp_path / "out", executor=executor)
    assert (result.skipped, result.ran) == (1, 3)


def test_the_cli_ends_a_ctrl_c_with_one_line_and_code_130(tmp_path, monkeypatch, capsys):
    import tactile_bt.experiments.sweep as sweep

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep, "run_sweep", interrupted)
    assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--workers", "1"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("interrupted: the finished runs are in")


# --------------------------------------------------------------------------- the spec
BAD_SPECS = [
    ("tree: x\n", 1, "needs 'seeds'"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\nduraton: 3\n", 4,
     "unknown field 'duraton' (did you mean 'duration'?)"),
    (f"tree: trees/nope.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\n", 1, "tree: file 'trees/nope.yaml' not found"),
    (f"tree: {REPO}/trees/force_hold.yaml\nseeds: [0]\n", 1, "needs 'scene'"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0, -1]\n", 3, "seeds[1]: expected a seed"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [2, 2]\n", 3, "listed twice"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: []\n", 3, "non-empty list of seeds"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\nduration: -3\n", 4,
     "duration: expected a finite number > 0"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\nduration: 0.001\n", 4,
     "0 cycles"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ntimeout_s: .nan\n", 4,
     "timeout_s: expected a finite number > 0"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ngrid:\n"
     "  objects.0.stiffnes: [1.0e4]\n", 5, "unknown field 'objects.0.stiffnes' (did you mean 'stiffness'?)"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ngrid:\n"
     "  objects.0.stiffness: [1.0e4, -1]\n", 5, "objects.0.stiffness=-1"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ngrid:\n"
     "  objects.0.stiffness: 1.0e4\n", 5, "expected a non-empty list of values"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ngrid:\n"
     "  tree.force_hold.target_pa: [2000, -5]\n", 5, "target_pa must be > 0"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ngrid:\n"
     "  tree.hodl.kp: [1]\n", 5, "no node named 'hodl'"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\ngrid:\n"
     "  seed: [1, 2]\n", 5, "the seeds come from 'seeds:'"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0]\nset:\n"
     "  mount.type: warp_drive\n", 5, "set: mount.type"),
    (f"tree: {REPO}/trees/force_hold.yaml\nscene: {REPO}/sim/pen.yaml\nseeds: [0\n", 4, "invalid YAML"),
]


@pytest.mark.parametrize("text, line, message", BAD_SPECS, ids=[m for _, _, m in BAD_SPECS])
def test_spec_errors_name_the_file_line_and_field(tmp_path, text, line, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(YamlError) as info:
        load_spec(path)
    assert info.value.file == str(path) and info.value.line == line
    assert str(info.value).startswith(f"{path}:{line}:")
    assert message in str(info.value)


@pytest.mark.parametrize("args, message", [
    (["--workers", "0"], "expected an integer >= 1"),
    (["--scheduler", "not an address"], "expected a Dask scheduler address"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "not allowed with argument"),
])
def test_bad_executor_options_end_with_one_line(tmp_path, capsys, args, message):
    with pytest.raises(SystemExit) as info:
        main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), *args])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("problem", ["spec", "out"])
def test_the_cli_reports_a_bad_spec_or_out_in_one_line(tmp_path, capsys, problem):
    spec = _spec(tmp_path, "tree: x\nseeds: [0]\nscene: y\n") if problem == "spec" else _spec(tmp_path)
    out = tmp_path / "out"
    if problem == "out":
        out.write_text("a file")
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
    assert (f"{spec}:1:7: tree: file 'x' not found" in err[0]) if problem == "spec" else (str(out) in err[0])


def test_the_run_id_depends_on_what_decides_the_run_only(tmp_path):
    spec = load_spec(_spec(tmp_path))
    ids = [r.run_id for r in plan(spec)]
    assert len(set(ids)) == 4
    longer = load_spec(_spec(tmp_path, SPEC + "timeout_s: 30\n", "b.yaml"))
    assert [r.run_id for r in plan(longer, tmp_path, keep_runs=True)] == ids  # timeout and outputs aside
    more_seeds = load_spec(_spec(tmp_path, SPEC.replace("[0, 1]", "[0, 1, 2]"), "c.yaml"))
    assert set(ids) < {r.run_id for r in plan(more_seeds)}  # extending a sweep keeps its finished runs
    other = load_spec(_spec(tmp_path, SPEC.replace("duration: 1.5", "duration: 1.4"), "d.yaml"))
    assert not set(ids) & {r.run_id for r in plan(other)}


def test_paths_are_relative_to_the_spec_else_to_the_current_directory(tmp_path, monkeypatch):
    (tmp_path / "studies").mkdir()
    spec = _spec(tmp_path / "studies", "tree: ../trees/force_hold.yaml\nscene: sim/pen.yaml\nseeds: [0]\n")
    (tmp_path / "trees").mkdir()
    (tmp_path / "trees" / "force_hold.yaml").write_text((REPO / "trees" / "force_hold.yaml").read_text())
    (tmp_path / "trees" / "lib").symlink_to(REPO / "trees" / "lib")
    monkeypatch.chdir(REPO)
    loaded = load_spec(spec)
    assert loaded.tree == str((tmp_path / "trees" / "force_hold.yaml").resolve())
    assert loaded.scenes == (("sim/pen.yaml", str(REPO / "sim" / "pen.yaml")),)


# --------------------------------------------------------------------------- executors
def test_run_all_keeps_the_order_and_raises_the_first_error():
    assert run_all(abs, [-3, 2, -1]) == [3, 2, 1]
    with pytest.raises(TypeError):
        run_all(abs, [1, "x", 2])


def test_workers_above_one_without_dask_is_a_clear_error(monkeypatch):
    monkeypatch.setattr(executors, "dask_available", lambda: False)
    assert isinstance(make_executor(1), InProcess)
    assert isinstance(make_executor(None, note=lambda message: None), InProcess)
    with pytest.raises(CommandLineError, match=r"--workers 2 needs Dask: pip install '\.\[cluster\]'"):
        make_executor(2)
    with pytest.raises(CommandLineError, match="--scheduler"):
        make_executor(scheduler="tcp://127.0.0.1:8786")


def test_a_sweep_on_one_worker_imports_no_dask(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        sys.modules["dask"] = sys.modules["distributed"] = None  # as if not installed
        from tactile_bt.cli import main
        code = main(["sweep", {str(_spec(tmp_path, SPEC.replace("[0, 1]", "[0]")))!r}, "--out",
                     {str(tmp_path / "out")!r}, "--workers", "1"])
        assert code == 0, code
        """)
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120,
                          env={**__import__("os").environ, "PYTHONPATH": str(REPO)})
    assert done.returncode == 0, done.stderr
    assert len(_table(tmp_path / "out")) == 2


def test_only_the_executors_import_dask():
    import re

    import tactile_bt

    package = Path(tactile_bt.__file__).resolve().parent
    importing = [p.relative_to(package).as_posix() for p in package.rglob("*.py")
                 if re.search(r"^\s*(import|from)\s+(dask|distributed)\b", p.read_text(encoding="utf-8"), re.M)]
    assert importing == ["experiments/executors.py"]


@pytest.mark.parametrize("path", sorted((REPO / "studies").glob("*.yaml")), ids=lambda p: p.name)
def test_every_shipped_spec_is_valid(path, monkeypatch):
    monkeypatch.chdir(REPO)  # the shipped specs name files from the repository's root
    spec = load_spec(path)
    assert plan(spec) and spec.seeds
