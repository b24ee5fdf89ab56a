"""Setting tree parameters and blackboard keys from outside the file: load_tree(params=...,
blackboard=...), `tactile-bt run/tree --param NODE.PARAM=VALUE`, `run --blackboard KEY=VALUE`
and `tree --params`."""

import json
from pathlib import Path

import numpy as np
import pytest

from tactile_bt import load_tree
from tactile_bt.arguments import parse_assignments
from tactile_bt.tree.behaviours import ForceHold
from tactile_bt.cli import main
from tactile_bt.tree.loader import format_parameters
from tactile_bt.errors import TreeError
from tactile_bt.testing import LeafHarness, make_features

ROOT = Path(__file__).resolve().parents[2]
FORCE_TREE = ROOT / "trees" / "force_hold.yaml"
SCENE = ROOT / "sim" / "pen.yaml"
FILE = "x.yaml"

TREE = """\
include: [lib/common.yaml]
root:
  sequence:
    name: main
    children:
      - touch: {}
      - retry:
          name: again
          child:
            parallel:
              name: follow
              policy: success_on_one
              children:
                - force_hold: {name: hold, target_pa: 2000}
                - centre: {}
                - force_limit: {}
                - contact_lost: {grace_s: 0.3}
"""



def tree_with(params=None, blackboard=None, text=TREE):
    return load_tree(ROOT / "trees" / FILE, text=text, params=params, blackboard=blackboard)


def node(tree, name):
    return next(n for n in tree.root.iterate() if n.name == name)


# --------------------------------------------------------------------------------- --param


@pytest.mark.parametrize(
    "param,name,attribute,expected",
    [
        ("hold.target_pa=1.5 kPa", "hold", "target_pa", 1500.0),
        ("hold.target_pa=1800", "hold", "target_pa", 1800.0),
        ('hold.target_pa="1500"', "hold", "target_pa", 1500.0),
        ("force_hold.kp=5e-5", "hold", "pid.kp", [5e-5]),  # by type: the only force_hold
        ("touch.speed_mps=5 mm/s", "touch", "speed_mps", 0.005),  # a node made by a subtree
        ("approach.timeout_s=3", "touch", "timeout_s", 3.0),  # ... by its type
        ("centre.target_m=[1 px, -1 mm]", "centre", "target_m", (0.005, -0.001)),
        ("again.num_failures=5", "again", "num_failures", 5),  # a decorator
        ("hold.converge=true", "hold", "converge", True),
        ("hold.output_limit=.inf", "hold", "pid.output_limit", [np.inf]),
    ],
)
def test_a_param_sets_the_built_nodes_attribute(param, name, attribute, expected):
    value = node(tree_with([param]), name)
    for part in attribute.split("."):
        value = getattr(value, part)
    assert value == pytest.approx(expected)


def test_params_as_a_mapping_and_the_last_one_wins():
    tree = tree_with({"hold.target_pa": 900.0, "contact_lost.grace_s": "250 ms"})
    assert node(tree, "hold").target_pa == 900.0 and node(tree, "contact_lost").grace_s == 0.25
    assert node(tree_with(["hold.target_pa=900", "hold.target_pa=1 kPa"]), "hold").target_pa == 1000.0


def test_a_param_can_fix_a_bad_value_of_the_file():
    text = TREE.replace("target_pa: 2000", "target_pa: .nan")
    with pytest.raises(TreeError, match="target_pa must be finite"):
        tree_with(text=text)
    assert node(tree_with(["hold.target_pa=2 kPa"], text=text), "hold").target_pa == 2000.0


def test_a_name_shared_by_several_nodes_sets_them_all():
    text = """\
subtrees:
  press: {force_hold: {target_pa: 1000}}
root:
  sequence:
    children: [{press: {}}, {press: {}}, {force_hold: {name: other}}]
"""
    tree = tree_with(["press.target_pa=1200"], text=text)
    assert [n.target_pa for n in tree.root.iterate() if isinstance(n, ForceHold)] == [1200.0, 1200.0, 2000.0]


def test_a_param_can_be_a_blackboard_reference():
    tree = tree_with(["hold.target_pa=@/goal/pressure"])
    h = LeafHarness(tree)
    h.set("/goal/pressure", 1700.0)
    h.tick_until(lambda s: node(tree, "hold").status.name == "RUNNING", max_ticks=2000,
                 features=[make_features(pressure=900.0)])
    assert node(tree, "hold").target_pa == 1700.0


@pytest.mark.parametrize(
    "param,message",
    [
        ("hold.target_pa=-2000", "--param hold.target_pa: force_hold 'hold': target_pa must be > 0 (got -2000.0 Pa)"),
        ("hold.target_pa=.nan", "--param hold.target_pa: force_hold 'hold': target_pa must be finite and > 0 (got nan Pa)"),
        ("hold.target_pa=2 mm", "--param hold.target_pa: force_hold.target_pa: unit 'mm' does not fit a value in Pa"),
        ("hold.target_pa=[1", "--param hold.target_pa: cannot read the value '[1'"),
        ("hodl.target_pa=1", "--param hodl.target_pa: no node named 'hodl' (did you mean 'hold'?); "
                             "nodes: touch, again, hold, centre, force_limit, contact_lost"),
        ("hold.target_pas=1", "--param hold.target_pas: force_hold 'hold' has no parameter 'target_pas' "
                              "(did you mean 'target_pa'?); parameters: name, target_pa, target_key, all_regions"),
        ("again.child=1", "--param again.child: retry 'again' has no parameter 'child'"),
        ("follow.policy=success_on_all", "--param follow.policy: 'follow' is a parallel (a composite)"),
        ("hold=1", "--param hold: expected NODE.PARAM=VALUE"),
        ("hold.target_pa", "--param hold.target_pa: expected NODE.PARAM=VALUE"),
    ],
)
def test_bad_params_name_the_option(param, message):
    with pytest.raises(TreeError) as info:
        tree_with([param])
    assert str(info.value).startswith(message), str(info.value)
    assert info.value.line is None


def test_a_type_shared_by_nodes_of_different_names_is_ambiguous():
    text = "root:\n  sequence:\n    children: [{force_hold: {name: a}}, {force_hold: {name: b}}]\n"
    with pytest.raises(TreeError, match=r"--param force_hold.kp: 2 nodes are of type 'force_hold' \(named 'a', 'b'\)"):
        tree_with(["force_hold.kp=1e-5"], text=text)


# --------------------------------------------------------------------------------- --blackboard

BB_TREE = """\
root:
  parallel:
    children:
      - force_hold: {name: hold, target_pa: "@/goal/pressure"}
      - guided_slide: {twist_key: /planner/twist}
      - centre: {target_m: "@/goal/cop"}
"""


def test_blackboard_values_are_checked_and_written_when_the_tree_is_set_up():
    tree = tree_with(blackboard=["/goal/pressure=1.5 kPa", "planner/twist=[0, 0.01, 0, 0, 0, 0]",
                                 "/goal/cop=[1 px, 0]"], text=BB_TREE)
    assert tree.blackboard_values == {"/goal/pressure": 1500.0, "/planner/twist": (0, 0.01, 0, 0, 0, 0),
                                      "/goal/cop": (0.005, 0.0)}
    h = LeafHarness(tree)  # a whole tree: its setup() writes the values
    h.tick(make_features(pressure=1000.0))
    assert node(tree, "hold").target_pa == 1500.0
    assert h.errors["pressure_pa"] == pytest.approx(-500.0)
    np.testing.assert_allclose(h.twist_of("guided_slide"), [0, 0.01, 0, 0, 0, 0])


def test_the_mission_loop_writes_the_blackboard_values():
    from tactile_bt.sense.calibration import TactelCalibration
    from tactile_bt.mission.loop import ControlLoop

    tree = tree_with(blackboard={"/goal/pressure": 1600.0, "/planner/twist": [0.0] * 6, "/goal/cop": [0, 0]},
                     text=BB_TREE)
    loop = ControlLoop(tree, TactelCalibration.nominal(), 1.0 / 250.0)
    raw = np.zeros((16, 16), dtype=np.uint16)
    loop.cycle(raw, np.eye(4), 0.0)
    assert node(tree, "hold").target_pa == 1600.0


@pytest.mark.parametrize(
    "setting,message",
    [
        ("/goal/pressure=-5", "--blackboard /goal/pressure: force_hold 'hold': target_pa must be > 0 (got -5.0 Pa)"),
        ("/goal/pressure=high", "--blackboard /goal/pressure: force_hold.target_pa: expected a number in Pa"),
        ("/goal/presure=1", "--blackboard /goal/presure: the tree reads no blackboard key '/goal/presure' "
                            "(did you mean '/goal/pressure'?); it reads: /goal/pressure, /planner/twist, /goal/cop"),
        ("/goal pressure=1", "--blackboard /goal pressure: malformed blackboard key"),
        ("/goal/pressure", "--blackboard /goal/pressure: expected KEY=VALUE"),
        ("/planner/twist=[0, 0.01]", "--blackboard /planner/twist: guided_slide: twist must be 6 finite numbers"),
        ("/planner/twist=[0, .nan, 0, 0, 0, 0]", "--blackboard /planner/twist: guided_slide 'guided_slide': "
                                                 "twist[1] must be finite (got nan m/s)"),
        ("/goal/cop=[0, 0, 0]", "--blackboard /goal/cop: centre: target_m must be [x, y] in metres"),
    ],
)
def test_bad_blackboard_settings_name_the_option(setting, message):
    with pytest.raises(TreeError) as info:
        tree_with(blackboard=[setting], text=BB_TREE)
    assert str(info.value).startswith(message), str(info.value)


# --------------------------------------------------------------------------------- tree --params


def test_tree_params_prints_resolved_values_units_and_sources(capsys):
    assert main(["tree", str(FORCE_TREE), "--params", "--param", "force_hold.target_pa=1.5 kPa"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines()]
    assert ["node", "type", "parameter", "value", "unit", "source"] in rows
    assert ["force_hold", "force_hold", "target_pa", "1500", "Pa", "--param", "force_hold.target_pa"] in rows
    assert ["force_hold", "force_hold", "kp", "0.0001", "(m/s)/Pa", "default"] in rows
    assert ["hold_20s", "mission_timeout", "duration_s", "20", "s", f"{FORCE_TREE.relative_to(ROOT)}:17:23"] in [
        r[:5] + [r[5].replace(str(ROOT) + "/", "")] for r in rows if len(r) == 6]
    # the subtree's $param values, after substitution, in SI units
    assert any(r[:5] == ["touch", "approach", "pressure_pa", "800", "Pa"] for r in rows)


def test_format_parameters_lists_nodes_in_tree_order():
    tree = tree_with()
    names = list(dict.fromkeys(line.split()[0] for line in format_parameters(tree).splitlines()[1:]))
    assert names == ["main", "touch", "again", "follow", "hold", "centre", "force_limit", "contact_lost"]
    assert [r.name for r in tree.node_parameters][:3] == ["main", "touch", "again"]


# --------------------------------------------------------------------------------- the command line


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize(
    "option,needle",
    [
        (["--param", "hodl.target_pa=1"], "error: --param hodl.target_pa: no node named 'hodl'"),
        (["--param", "force_hold.target_pas=1"], "has no parameter 'target_pas' (did you mean 'target_pa'?)"),
        (["--param", "force_hold.target_pa=-2000"], "force_hold 'force_hold': target_pa must be > 0 (got -2000.0 Pa)"),
        (["--param", "force_hold.target_pa=lots"], "expected a number in Pa"),
        (["--blackboard", "/goal/pressure=1"], "the tree reads no blackboard key '/goal/pressure'"),
    ],
)
def test_run_with_bad_options_is_one_line_without_traceback(tmp_path, capsys, option, needle):
    code = main(["run", str(FORCE_TREE), "--scene", str(SCENE), "--duration", "0.1", *option, "--out", str(tmp_path)])
    assert code != 0
    assert needle in one_error_line(capsys)
    assert not (tmp_path / "report.json").exists()


@pytest.mark.parametrize(
    "option,needle",
    [
        (["--param", "hodl.target_pa=1"], "no node named 'hodl'"),
        (["--param", "force_hold.kp=-1"], "kp must not be negative"),
        (["--param", "hold.target_pa=1"], "'hold' is a parallel"),
    ],
)
def test_tree_with_bad_params_is_one_line_without_traceback(capsys, option, needle):
    assert main(["tree", str(FORCE_TREE), *option]) != 0
    assert needle in one_error_line(capsys)


def test_run_with_params_and_blackboard(tmp_path, capsys):
    tree = tmp_path / "hold.yaml"
    tree.write_text("""\
include: [%s]
root:
  sequence:
    children:
      - touch: {}
      - force_hold: {name: hold, target_pa: "@/goal/pressure"}
""" % (ROOT / "trees" / "lib" / "common.yaml"))
    code = main(["run", str(tree), "--scene", str(SCENE), "--duration", "0.5", "--param", "touch.timeout_s=2 s",
                 "--blackboard", "/goal/pressure=1.8 kPa", "--out", str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
    assert json.loads((tmp_path / "out" / "report.json").read_text())["ticks"] > 0


def test_params_and_blackboard_apply_to_tree_files_only():
    from tactile_bt import load_tree, run_mission

    tree = load_tree(str(ROOT / "examples" / "slide_and_record.yaml"), params=["slide_10s.duration_s=4"],
                     blackboard=["/goal/pressure=1900"])
    assert node(tree, "slide_10s").duration_s == 4.0
    assert tree.blackboard_values == {"/goal/pressure": 1900.0}
    with pytest.raises(ValueError, match="tree file"):
        run_mission(tree, str(SCENE), duration=0.01, params=["a.b=1"])


def test_assignments_are_read_without_a_tree():
    """The command-line part of --param and --blackboard: KEY=VALUE split at the first '=',
    the value read as YAML, a blackboard reference kept as text, an empty value None."""
    parsed = parse_assignments([" hold.target_pa = 1.5 kPa", "centre.target_m=[1 mm, 0]", "a.b=@/goal/x", "a.c=",
                                "a.d=x=y", "a.kp=5e-5"], "--param", "NODE.PARAM")
    assert [(key, source) for key, source, _ in parsed] == [
        ("hold.target_pa", "--param hold.target_pa"), ("centre.target_m", "--param centre.target_m"),
        ("a.b", "--param a.b"), ("a.c", "--param a.c"), ("a.d", "--param a.d"), ("a.kp", "--param a.kp")]
    assert [value for _, _, value in parsed] == ["1.5 kPa", ["1 mm", 0], "@/goal/x", None, "x=y", 5e-5]
