"""Every tree in trees/ (and examples/): it validates, `tactile-bt tree` prints it and writes its
dot graph, broken copies fail with file, line and field, and the paper's trees drive exactly the
rows of their projection matrix."""

import re
import shutil
from pathlib import Path

import numpy as np
import py_trees
import pytest
from py_trees.common import Status

from tactile_bt import load_tree
from tactile_bt.tree.behaviours import Approach, ContactLost, ServoLeaf
from tactile_bt.cli import main as cli
from tactile_bt.tree.reference import describe_nodes
from tactile_bt.tree.registry import NODE_TYPES
from tactile_bt.errors import TreeError
from tactile_bt.testing import LeafHarness, contact_frame, make_features

REPO = Path(__file__).resolve().parents[2]
TREES = sorted((REPO / "trees").glob("*.yaml"))
EXAMPLES = sorted((REPO / "examples").glob("*.yaml"))
LIBRARIES = sorted((REPO / "trees" / "lib").glob("*.yaml"))
#: The paper's experiments V-A to V-C: tree → diagonal of P (paper Sec. V).
PAPER = {
    "force_hold": (0, 0, 1, 0, 0, 0),
    "centre": (1, 1, 0, 0, 0, 0),
    "hybrid": (1, 1, 1, 0, 0, 0),
    "roll": (1, 1, 1, 1, 1, 0),
    "align_edge": (0, 0, 1, 0, 0, 1),
}
DT = 1.0 / 128.0



def ids(paths):
    return [str(p.relative_to(REPO)) for p in paths]


def test_the_paper_trees_exist():
    assert {p.stem for p in TREES} >= set(PAPER) | {"cable_follow"}


# --------------------------------------------------------------------------------- validation


@pytest.mark.parametrize("path", TREES + EXAMPLES, ids=ids(TREES + EXAMPLES))
def test_tree_validates_prints_and_writes_dot(path, tmp_path, capsys):
    tree = load_tree(path)
    assert isinstance(tree.root, py_trees.behaviour.Behaviour)
    dot = tmp_path / "tree.dot"
    assert cli(["tree", str(path), "--dot", str(dot)]) == 0
    out = capsys.readouterr().out
    assert tree.root.name in out
    text = dot.read_text()
    assert text.startswith("digraph") and text.rstrip().endswith("}")
    # one dot node per tree node (py_trees makes duplicate names unique)
    assert text.count("label=") == len(list(tree.root.iterate()))


@pytest.mark.parametrize("path", LIBRARIES, ids=ids(LIBRARIES))
def test_subtree_libraries_validate(path, tmp_path):
    """A library has no root: include it from a tree that uses each of its subtrees."""
    from tactile_bt.yamlutil import load_located

    names = list(load_located(path).value["subtrees"].value)
    tree = tmp_path / "uses_all.yaml"
    tree.write_text(f"include: [{path}]\nroot:\n  sequence:\n    children:\n"
                    + "".join(f"      - {n}: {{}}\n" for n in names))
    assert len(load_tree(tree).root.children) == len(names)


# --------------------------------------------------------------------------------- broken copies

_PARAMETERS = {p.name for doc in describe_nodes().values() if doc.kind != "composite" for p in doc.parameters}
_NUMBER = r"-?\d[\d.eE+-]*(?:\s*[A-Za-z°/]+)?"


def _copy(path: Path, tmp_path: Path) -> Path:
    """A copy of the tree with the files it includes, so relative includes still resolve."""
    shutil.copytree(REPO / "trees" / "lib", tmp_path / "trees" / "lib")
    folder = tmp_path / path.parent.name
    folder.mkdir(exist_ok=True)
    return folder / path.name


def _first(lines, pattern):
    """The first match in the tree's `root` section (not in subtree definitions)."""
    start = lines.index("root:")
    for i, line in enumerate(lines[start:], start):
        if line.lstrip().startswith("#"):
            continue
        m = re.search(pattern, line.split(" #")[0])
        if m:
            return i, m
    raise AssertionError(f"nothing matches {pattern}")


def _node_types(path: Path) -> set[str]:
    from tactile_bt.yamlutil import load_located

    doc = load_located(path)
    local = set(doc.value["subtrees"].value) if "subtrees" in doc.value else set()
    return set(NODE_TYPES) | local | {"touch"}


def break_node_type(path: Path, lines: list[str]):
    types = "|".join(sorted(_node_types(path) - {"subtree"}, key=len, reverse=True))
    i, m = _first(lines, rf"(?:^|[-{{\s])({types}):")
    lines[i] = lines[i][: m.start(1)] + m.group(1) + "x" + lines[i][m.end(1):]
    return i + 1, m.group(1) + "x", f"did you mean '{m.group(1)}'"


def break_parameter(path: Path, lines: list[str]):
    names = "|".join(sorted(_PARAMETERS - {"name", "child"}, key=len, reverse=True))
    i, m = _first(lines, rf"[{{\s]({names}):\s*{_NUMBER}")
    lines[i] = lines[i][: m.start(1)] + m.group(1) + "z" + lines[i][m.end(1):]
    return i + 1, m.group(1) + "z", f"did you mean '{m.group(1)}'"


def break_type(path: Path, lines: list[str]):
    names = "|".join(sorted(_PARAMETERS - {"name", "child"}, key=len, reverse=True))
    i, m = _first(lines, rf"[{{\s]({names}):\s*({_NUMBER})")
    lines[i] = lines[i][: m.start(2)] + '"plenty"' + lines[i][m.end(2):]
    return i + 1, m.group(1), "plenty"


@pytest.mark.parametrize("breaker", [break_node_type, break_parameter, break_type],
                         ids=["unknown-node", "misspelt-parameter", "wrong-type"])
@pytest.mark.parametrize("path", TREES + EXAMPLES, ids=ids(TREES + EXAMPLES))
def test_a_broken_copy_names_file_line_and_field(path, breaker, tmp_path, capsys):
    copy = _copy(path, tmp_path)
    lines = path.read_text(encoding="utf-8").splitlines()
    line, field, needle = breaker(path, lines)
    copy.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(TreeError) as info:
        load_tree(copy)
    err = info.value
    assert (err.file, err.line) == (str(copy), line), str(err)
    assert field in str(err) and needle in str(err)
    # the command line says the same and exits with status 2
    assert cli(["tree", str(copy)]) == 2
    assert f"{copy}:{line}:" in capsys.readouterr().err


def test_a_broken_shared_subtree_names_the_library_file(tmp_path):
    path = REPO / "trees" / "hybrid.yaml"
    copy = _copy(path, tmp_path)
    shutil.copy(path, copy)
    library = tmp_path / "trees" / "lib" / "common.yaml"
    text = library.read_text().replace("pressure_pa: $pressure_pa", "pressure_pas: $pressure_pa")
    library.write_text(text)
    with pytest.raises(TreeError) as info:
        load_tree(copy)
    line = text.splitlines().index("        pressure_pas: $pressure_pa") + 1
    assert (info.value.file, info.value.line) == (str(library.resolve()), line)
    assert "did you mean 'pressure_pa'" in str(info.value) and "in subtree 'touch'" in str(info.value)


# --------------------------------------------------------------------------------- the paper's trees


def servo_phase(root):
    """(approach, the parallel of the servo phase) of a paper tree."""
    approach, timeout = root.children
    return approach, timeout.decorated


@pytest.mark.parametrize("name,diagonal", PAPER.items())
def test_paper_tree_starts_with_approach_and_superimposes_its_projection(name, diagonal):
    root = load_tree(REPO / "trees" / f"{name}.yaml").root
    approach, parallel = servo_phase(root)
    assert isinstance(approach, Approach)
    assert isinstance(parallel, py_trees.composites.Parallel)
    servos = [c for c in parallel.children if isinstance(c, ServoLeaf)]
    rows = sorted(r for s in servos for r in s.rows)
    assert rows == [i for i, v in enumerate(diagonal) if v]  # each row driven by exactly one leaf
    assert any(isinstance(c, ContactLost) for c in parallel.children)
    assert root.children[1].duration_s == 20.0 and root.children[1].succeed


@pytest.mark.parametrize("name,diagonal", PAPER.items())
def test_paper_tree_runs_approach_then_drives_only_the_rows_of_p(name, diagonal):
    """Scripted: no contact, first touch (approach succeeds), then an off-centre, turned, too
    light line contact through the real perception — the twist has exactly the rows of P."""
    root = load_tree(REPO / "trees" / f"{name}.yaml").root
    approach, parallel = servo_phase(root)
    h = LeafHarness(root, dt=DT)
    for _ in range(5):
        assert h.tick(make_features(in_contact=False)) == Status.RUNNING
        assert h.twist.tolist() == [0, 0, approach.speed_mps, 0, 0, 0]
    h.tick(make_features(pressure=1000.0))
    assert approach.status == Status.SUCCESS
    frame = contact_frame(cop_px=(10.0, 5.5), force_n=1.0, orientation_rad=1.2)
    for _ in range(3):
        assert h.tick(frame=frame) == Status.RUNNING
    expected = {i for i, v in enumerate(diagonal) if v}
    assert set(np.flatnonzero(h.twist)) == expected
    # finally the mission-clock window ends the run with SUCCESS (contact kept all along)
    n = h.tick_until(lambda s: s != Status.RUNNING, max_ticks=int(21 / DT), frames=[frame])  # the last frame stays
    assert h.behaviour.status == Status.SUCCESS
    assert (n + 3) * DT == pytest.approx(20.0, abs=2 * DT)


@pytest.mark.parametrize("name", PAPER)
def test_paper_tree_fails_when_the_contact_is_lost(name):
    root = load_tree(REPO / "trees" / f"{name}.yaml").root
    h = LeafHarness(root, dt=DT)
    h.tick(make_features(pressure=1000.0))
    h.tick_for(0.5, features=iter(lambda: make_features(pressure=1500.0), None))
    assert h.tick_until(lambda s: s != Status.RUNNING, max_ticks=200,
                        features=iter(lambda: make_features(in_contact=False), None))
    assert h.behaviour.status == Status.FAILURE
