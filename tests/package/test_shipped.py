"""The trees, scenes and studies that ship with the package: found from anywhere, listed, copied."""

from __future__ import annotations

from pathlib import Path

import pytest

from tactile_bt import shipped
from tactile_bt.cli import main


def test_a_shipped_path_is_found_from_another_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    found = shipped.resolve("sim/cable.yaml")
    assert found.is_absolute() and found == shipped.root() / "sim" / "cable.yaml"
    assert shipped.resolve("sim/no_such_scene.yaml") == Path("sim/no_such_scene.yaml")  # the usual error follows
    (tmp_path / "sim").mkdir()
    (tmp_path / "sim" / "cable.yaml").write_text("mine")
    assert shipped.resolve("sim/cable.yaml") == Path("sim/cable.yaml")  # a file here wins


def test_the_loaders_take_shipped_names_from_another_folder(tmp_path, monkeypatch):
    from tactile_bt.sim.scene import load_scene
    from tactile_bt.tree.loader import load_tree

    monkeypatch.chdir(tmp_path)
    assert load_tree("trees/scan_object.yaml").tree_name  # with its include, relative to the shipped file
    assert load_scene("sim/object.yaml")  # with its mesh


def test_a_missing_shipped_file_says_what_ships():
    with pytest.raises(FileNotFoundError, match="ships no such file.*'tactile-bt examples' lists them"):
        shipped.path("sim/nothing.yaml")


def test_examples_lists_every_shipped_file_with_its_summary(capsys):
    assert main(["examples"]) == 0
    out = capsys.readouterr().out
    assert "trees/cable_follow.yaml" in out and "sim/meshes/unknown_object.ply" in out
    assert "studies/pen_stiffness.yaml" in out and "Cable following (paper Sec. V-D)" in out


def test_examples_copy_keeps_the_folders_and_never_overwrites_unasked(tmp_path, capsys):
    target = tmp_path / "mine"
    assert main(["examples", "--copy", str(target)]) == 0
    assert (target / "trees" / "lib" / "common.yaml").is_file() and (target / "sim" / "cable.yaml").is_file()
    (target / "sim" / "cable.yaml").write_text("# edited\n")
    capsys.readouterr()
    assert main(["examples", "--copy", str(target)]) == 2
    assert "exists already" in capsys.readouterr().err
    assert (target / "sim" / "cable.yaml").read_text() == "# edited\n"
    assert main(["examples", "--copy", str(target), "--force"]) == 0
    assert (target / "sim" / "cable.yaml").read_text() != "# edited\n"


def test_a_sweep_spec_may_name_shipped_files(tmp_path, monkeypatch):
    from tactile_bt.experiments.sweep import load_spec

    monkeypatch.chdir(tmp_path)
    spec = load_spec(shipped.path("studies/pen_stiffness.yaml"))
    assert Path(spec.tree).is_file() and all(Path(file).is_file() for _, file in spec.scenes)
