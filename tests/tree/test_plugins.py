"""Node types of one's own: installed plugins (entry points), ``--plugin`` modules, clashes."""

from __future__ import annotations

import sys
import textwrap

import pytest

from tactile_bt.cli import main
from tactile_bt.errors import PluginError
from tactile_bt.tree import registry
from tactile_bt.tree.loader import load_tree

LEAF = '''
from py_trees.common import Status
from tactile_bt.tree import POSITIVE, Parameter, TactileBehaviour


class Wait(TactileBehaviour):
    """Succeed after ``hold_s`` of mission time."""

    default_name = "wait_for"
    hold_s = Parameter(0.1, bound=POSITIVE, doc="How long to wait (s).")

    def initialise(self):
        self.started = self.now

    def update(self):
        return Status.SUCCESS if self.now - self.started >= self.hold_s else Status.RUNNING
'''
TREE = "root:\n  sequence:\n    children:\n      - wait_for: {hold_s: 50 ms}\n"


@pytest.fixture
def plugin_dist(tmp_path, monkeypatch, node_registry):
    """A package ``my_leaves`` installed (a dist-info with an entry point) on a path of its own."""
    (tmp_path / "my_leaves.py").write_text(LEAF)
    info = tmp_path / "my_leaves-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-leaves\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[tactile_bt.behaviours]\nwait_for = my_leaves:Wait\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    sys.modules.pop("my_leaves", None)


def test_an_installed_plugin_adds_its_node_type_when_trees_load(plugin_dist, tmp_path):
    assert registry.load_entry_points(force=True) == ["wait_for"]
    tree = load_tree(tmp_path / "t.yaml", text=TREE)
    leaf = tree.root.children[0]
    assert type(leaf).__name__ == "Wait" and leaf.hold_s == pytest.approx(0.05)  # units as for built-ins


def test_a_plugin_that_clashes_with_a_built_in_names_both(plugin_dist):
    info = plugin_dist / "my_leaves-1.0.dist-info" / "entry_points.txt"
    info.write_text("[tactile_bt.behaviours]\napproach = my_leaves:Wait\n")
    with pytest.raises(PluginError, match=r"'approach' of entry point 'approach = my_leaves:Wait' of my-leaves 1\.0 "
                                          r"clashes with 'approach' of the built-in tactile_bt\.tree\.behaviours"):
        registry.load_entry_points(force=True)


def test_a_plugin_that_cannot_be_imported_names_its_entry_point(plugin_dist):
    (plugin_dist / "my_leaves.py").write_text("raise RuntimeError('broken on purpose')\n")
    with pytest.raises(PluginError, match=r"entry point 'wait_for = my_leaves:Wait' of my-leaves 1\.0: cannot be "
                                          r"loaded: RuntimeError: broken on purpose"):
        registry.load_entry_points(force=True)


def test_plugin_option_imports_a_file_that_registers_its_leaf(tmp_path, node_registry, capsys):
    module = tmp_path / "wait_leaf.py"
    module.write_text(LEAF + "\nfrom tactile_bt.tree import register_node\nregister_node('wait_for', Wait)\n")
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    assert main(["tree", str(tree)]) == 2
    assert "unknown node type 'wait_for'" in capsys.readouterr().err
    assert main(["tree", str(tree), "--plugin", str(module)]) == 0
    assert "wait_for" in capsys.readouterr().out
    sys.modules.pop("wait_leaf", None)


def test_plugin_option_errors_are_one_line(tmp_path, capsys):
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    assert main(["tree", str(tree), "--plugin", "no_such_module_here"]) == 2
    assert capsys.readouterr().err.strip() == ("error: --plugin no_such_module_here: no module named "
                                              "'no_such_module_here' (give a module on the import path, or the "
                                              "path of a .py file)")
    broken = tmp_path / "broken.py"
    broken.write_text(textwrap.dedent("""
        raise ValueError("nope")
    """))
    assert main(["tree", str(tree), "--plugin", str(broken)]) == 2
    assert "importing it failed: ValueError: nope" in capsys.readouterr().err


def test_a_mission_runs_a_plugin_leaf_to_success(tmp_path, node_registry):
    from tactile_bt import run_mission

    module = tmp_path / "wait_leaf2.py"
    module.write_text(LEAF + "\nfrom tactile_bt.tree import register_node\nregister_node('wait_for', Wait)\n")
    registry.import_plugin(str(module))
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    result = run_mission(tree, "sim/pen.yaml", duration=1.0, seed=0)
    assert result.report["status"] == "success" and result.report["sim_time_s"] < 0.2
    sys.modules.pop("wait_leaf2", None)
