"""The command line with careless input: option values, output paths, reused output
directories, interrupted runs, runs that never touch anything. Every error is one line."""

from __future__ import annotations

import json
import runpy
from pathlib import Path

import pytest

from tactile_bt import load_tree
from tactile_bt.cli import main
from tactile_bt.mission.outputs import OUTPUT_FILES

ROOT = Path(__file__).resolve().parents[2]
FORCE_HOLD = str(ROOT / "trees" / "force_hold.yaml")
PEN = str(ROOT / "sim" / "pen.yaml")


def _one_error_line(err: str, *words: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err
    errors = [line for line in lines if "error:" in line]
    assert len(errors) == 1, err
    for word in words:
        assert word in errors[0], (word, errors[0])


@pytest.mark.parametrize("argv, option", [
    (["run", FORCE_HOLD, "--scene", PEN, "--out", "OUT", "--duration", "-3"], "--duration"),
    (["run", FORCE_HOLD, "--scene", PEN, "--out", "OUT", "--duration", "0"], "--duration"),
    (["run", FORCE_HOLD, "--scene", PEN, "--out", "OUT", "--duration", "nan"], "--duration"),
    (["run", FORCE_HOLD, "--scene", PEN, "--out", "OUT", "--seed", "-1"], "--seed"),
    (["run", FORCE_HOLD, "--scene", PEN, "--out", "OUT", "--seed", "1.5"], "--seed"),
    (["accuracy", "--trials", "0"], "--trials"),
    (["paper", "--trials", "0"], "--trials"),
    (["paper", "--duration", "-1"], "--duration"),
    (["paper", "--workers", "0"], "--workers"),
])
def test_bad_option_values_end_with_one_error_line(argv, option, tmp_path, capsys):
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in argv]
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    _one_error_line(capsys.readouterr().err, option)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, words", [
    (["run", FORCE_HOLD], ["tactile-bt run: error:", "--scene", "--out"]),
    (["run", FORCE_HOLD, "--scene", PEN, "--out", "OUT", "--duration", "-3"], ["tactile-bt run: error:", "--duration"]),
    (["view"], ["tactile-bt view: error:", "dir"]),
    (["frobnicate"], ["tactile-bt: error:", "frobnicate"]),
    (["sensor", "stream", "--rate", "fast"], ["tactile-bt sensor stream: error:", "--rate"]),
])
def test_argument_errors_are_one_line_without_the_usage_block(argv, words, tmp_path, capsys):
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in argv]
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "usage:" not in err, err
    assert all(word in err for word in words), err
    assert "--help" in err


def test_help_still_shows_the_usage(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["run", "--help"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.startswith("usage: tactile-bt run")


@pytest.mark.parametrize("duration", ["1e-9", "1e7"])
def test_a_budget_of_no_cycle_or_too_many_is_refused(duration, tmp_path, capsys):
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--duration", duration, "--out", str(tmp_path / "out")]) == 2
    _one_error_line(capsys.readouterr().err, "duration")
    assert not (tmp_path / "out").exists()


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert "tactile-bt" in capsys.readouterr().out


@pytest.mark.parametrize("make_path", [
    lambda tmp: tmp / "a_file",                 # the output directory is a file
    lambda tmp: tmp / "a_file" / "out",         # ... or lies under one
])
def test_unwritable_out_fails_before_the_mission(make_path, tmp_path, capsys, monkeypatch):
    (tmp_path / "a_file").write_text("keep me")
    import tactile_bt.mission.run as mission

    def no_world(*args, **kwargs):  # the mission must not start
        raise AssertionError("the mission ran")

    monkeypatch.setattr(mission.ControlLoop, "__init__", no_world)
    out = make_path(tmp_path)
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--out", str(out)]) == 2
    _one_error_line(capsys.readouterr().err, str(tmp_path / "a_file"))
    assert (tmp_path / "a_file").read_text() == "keep me"


@pytest.mark.parametrize("argv", [
    ["paper", "--trials", "1", "--out", "BAD"],
    ["stability", "--no-rates", "--out", "BAD/sub"],
    ["sweep", str(ROOT / "studies" / "pen_stiffness.yaml"), "--workers", "1", "--out", "BAD"],
    ["view", "DIR", "--png", "BAD/x.png"],
    ["accuracy", "--trials", "1", "--png", "BAD/x.png"],
    ["tree", str(ROOT / "trees" / "force_hold.yaml"), "--dot", "BAD/x.dot"],
])
def test_unwritable_png_fails_before_the_work(argv, tmp_path, capsys):
    (tmp_path / "a_file").write_text("")
    argv = [a.replace("BAD", str(tmp_path / "a_file")).replace("DIR", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    _one_error_line(capsys.readouterr().err, argv[-2])


def test_reused_out_holds_only_the_new_run(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUT_FILES:  # as an earlier scan left them
        (out / name).write_text("stale")
    (out / "notes.txt").write_text("mine")
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--duration", "0.4", "--out", str(out)]) == 0
    for name in ("report.json", "log.npz", "errors.png"):
        assert (out / name).read_bytes() != b"stale"
    for name in ("contacts.ply", "surface.ply", "render.png"):  # force hold records nothing
        assert not (out / name).exists(), name
    assert (out / "notes.txt").read_text() == "mine"


def test_report_names_the_scene_so_view_works_from_anywhere(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    monkeypatch.chdir(ROOT)
    assert main(["run", "trees/force_hold.yaml", "--scene", "sim/pen.yaml", "--duration", "0.4", "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert Path(report["scene"]).is_absolute()
    monkeypatch.chdir(tmp_path)
    from tactile_bt.sim.scene import load_scene

    assert load_scene(report["scene"]).name == "pen"


def test_a_run_that_never_touches_says_so(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["run", FORCE_HOLD, "--scene", PEN, "--duration", "0.3", "--set", "mount.position=[0, 0, 0.1]",
                 "--out", str(out)])
    assert code == 1
    assert "no contact was made" in capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "failure" and report["reason"] == "no contact was made"


@pytest.fixture
def ctrl_c_after_0_2_s(monkeypatch):
    """Ctrl-C once the mission's progress passes 0.2 s of mission time."""
    import tactile_bt.progress

    def interrupt(self, done, total=None, note=""):
        if done > 0.2:
            raise KeyboardInterrupt

    monkeypatch.setattr(tactile_bt.progress.Progress, "__call__", interrupt)


def test_ctrl_c_keeps_every_cycle_so_far(tmp_path, capsys, ctrl_c_after_0_2_s):
    out = tmp_path / "out"
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--duration", "5", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err and "interrupted" in err and len(err.strip().splitlines()) == 1
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "interrupted" and 50 < report["ticks"] < 1250
    import numpy as np

    assert len(np.load(out / "log.npz")["t"]) == report["ticks"]


@pytest.mark.parametrize("earlier", [(), ("report.json", "log.npz")])
def test_ctrl_c_while_the_scene_loads_claims_no_outputs(earlier, tmp_path, capsys, monkeypatch):
    """Nothing of this run exists yet: the message says so, and names what an earlier run left."""
    import tactile_bt.sim.scene

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tactile_bt.sim.scene, "load_scene", interrupt)
    out = tmp_path / "out"
    out.mkdir()
    for name in earlier:
        (out / name).write_text("an earlier run")
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--duration", "5", "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "every cycle" not in err, err
    assert err.startswith("interrupted before the mission started; nothing was written")
    if earlier:
        assert err.endswith(f"{out} still holds an earlier run's report.json, log.npz"), err
    assert sorted(p.name for p in out.iterdir()) == sorted(earlier)
    assert all((out / name).read_text() == "an earlier run" for name in earlier)


def test_ctrl_c_in_the_mission_leaves_only_this_runs_outputs_and_names_them(tmp_path, capsys, ctrl_c_after_0_2_s):
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUT_FILES:  # as an earlier scan left them
        (out / name).write_text("stale")
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--duration", "5", "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip()
    written = sorted(p.name for p in out.iterdir())
    assert written == sorted(["report.json", "log.npz", "errors.png", "tree.png"])  # a force hold records no contacts
    assert err.startswith("interrupted at 0.2") and f"{out} holds this run's report.json, log.npz, errors.png" in err
    assert json.loads((out / "report.json").read_text())["status"] == "interrupted"


def test_progress_off_a_terminal_is_one_line_now_and_then():
    import io

    from tactile_bt.progress import Progress

    stream = io.StringIO()
    progress = Progress(10.0, label="mission time", every_s=0.0, delay_s=0.0, stream=stream)
    for t in (1.0, 5.0, 10.0):
        progress(t)
    progress.close()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 3 and lines[-1].startswith("mission time: 10.0/10.0 s (100 %)")
    assert "\r" not in stream.getvalue()


def test_progress_says_once_that_it_compiles_instead_of_standing_at_zero():
    import io
    import time

    from tactile_bt.progress import Progress

    stream = io.StringIO()
    progress = Progress(40.0, label="mission time", every_s=0.05, delay_s=0.0, stream=stream)
    progress.stage("compiling kernels")
    progress.stage("compiling kernels")
    time.sleep(0.1)  # the compile: longer than every_s
    progress(0.0)
    lines = stream.getvalue().splitlines()
    assert lines == ["mission time: compiling kernels ..."]
    time.sleep(0.1)
    progress(20.0)
    assert stream.getvalue().splitlines()[1].startswith("mission time: 20.0/40.0 s (50 %)")


def test_a_run_on_a_cold_kernel_cache_says_it_compiles(tmp_path, capsys, monkeypatch):
    from tactile_bt.sim import warmup

    monkeypatch.setattr(warmup, "compiling", lambda: True)
    assert main(["run", FORCE_HOLD, "--scene", PEN, "--duration", "0.2", "--out", str(tmp_path / "out")]) in (0, 1)
    err = capsys.readouterr().err
    assert err.count("mission time: compiling the simulator's kernels (once after an install) ...") == 1, err
    assert "0.0/0.2" not in err


def _shape(node):
    """Type, name and children of a tree, for comparing two authored trees."""
    return (type(node).__name__, node.name, [_shape(c) for c in node.children])


def test_the_python_example_builds_the_yaml_tree():
    module = runpy.run_path(str(ROOT / "examples" / "author_tree.py"), run_name="example")
    authored = module["build_tree"]().root
    loaded = load_tree(ROOT / "trees" / "cable_follow.yaml").root
    assert _shape(authored) == _shape(loaded)
    for a, b in zip(authored.iterate(), loaded.iterate()):
        for attr in ("P", "kp", "ki", "kd", "target_pa", "target_rad", "twist", "point", "grace_s",
                     "pressure_pa", "speed_mps", "timeout_s"):
            if hasattr(b, attr):
                va, vb = getattr(a, attr), getattr(b, attr)
                import numpy as np

                np.testing.assert_allclose(np.asarray(va, dtype=float) if not isinstance(va, str) else 0,
                                           np.asarray(vb, dtype=float) if not isinstance(vb, str) else 0,
                                           rtol=1e-6, err_msg=f"{b.name}.{attr}")
                if isinstance(vb, str):
                    assert va == vb
