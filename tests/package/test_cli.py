"""The tactile-bt command line: run, tree, accuracy, and its error messages."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tactile_bt.cli import main
from tactile_bt.contacts.ply import read_ply_points

ROOT = Path(__file__).resolve().parents[2]
TREE = str(ROOT / "trees" / "cable_follow.yaml")
SCENE = str(ROOT / "sim" / "cable.yaml")


def test_run_writes_outputs_and_applies_overrides(tmp_path, capsys):
    code = main(["run", TREE, "--scene", SCENE, "--duration", "2", "--seed", "2",
                 "--set", "objects.1.stiffness=1e5", "--out", str(tmp_path)])
    assert code == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["seed"] == 2 and report["ticks"] == 500
    for name in ("log.npz", "errors.png", "contacts.ply"):
        assert (tmp_path / name).exists()
    assert "x real time" in capsys.readouterr().out


@pytest.mark.slow
def test_the_command_ends_with_every_output_complete(tmp_path):
    """The command's process skips the interpreter's teardown: nothing it wrote may be cut."""
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "tactile_bt.cli", "run", TREE, "--scene", SCENE, "--duration", "2",
                           "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode in (0, 1), done.stderr  # (1: a mission this short ends on its budget)
    assert done.stdout.rstrip().endswith(f"outputs in {out}")
    report = json.loads((out / "report.json").read_text())
    with np.load(out / "log.npz") as log:
        assert len(log["t"]) == report["ticks"]
    assert len(read_ply_points(out / "contacts.ply")[1]) > 0
    assert (out / "errors.png").read_bytes().endswith(b"IEND\xaeB`\x82")
    view = subprocess.run([sys.executable, "-m", "tactile_bt.cli", "view", str(out), "--png", str(out / "render.png")],
                          capture_output=True, text=True, timeout=600)
    assert view.returncode == 0, view.stderr
    assert (out / "render.png").read_bytes().endswith(b"IEND\xaeB`\x82")


def test_bad_override_names_the_field(tmp_path, capsys):
    code = main(["run", TREE, "--scene", SCENE, "--set", "objects.1.stifness=1e5", "--out", str(tmp_path)])
    assert code == 2
    err = capsys.readouterr().err
    assert "stifness" in err and "stiffness" in err


def test_tree_prints_and_bad_tree_names_file_and_line(tmp_path, capsys):
    assert main(["tree", TREE]) == 0
    assert "force_hold" in capsys.readouterr().out
    bad = tmp_path / "bad.yaml"
    bad.write_text("root:\n  sequence:\n    children:\n      - approach: {}\n      - force_hodl: {}\n")
    assert main(["tree", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:5" in err and "force_hold" in err


def test_missing_scene_file_is_a_clear_error(tmp_path, capsys):
    assert main(["run", TREE, "--scene", str(tmp_path / "nope.yaml"), "--out", str(tmp_path)]) == 2
    assert "nope.yaml" in capsys.readouterr().err
