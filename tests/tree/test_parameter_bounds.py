"""Leaf parameters: finite numbers with the sign physics demands, quoted numbers, and tree files
that are not UTF-8 — from YAML, from the blackboard and from Python, each with file:line:column."""

import inspect
import math

import numpy as np
import py_trees
import pytest

from tactile_bt import load_tree
from tactile_bt.tree.behaviours import DECORATORS, LEAVES, ForceHold, Repeat, Retry, TactileServo
from tactile_bt.tree.parameters import FINITE, Bound, convert_parameter, parameters_of
from tactile_bt.errors import ParameterValueError
from tactile_bt.cli import main
from tactile_bt.errors import TreeError
from tactile_bt.testing import LeafHarness, make_features

FILE = "trees/x.yaml"



def load_error(text: str) -> TreeError:
    with pytest.raises(TreeError) as info:
        load_tree(FILE, text=text)
    return info.value


# --------------------------------------------------------------------------------- bad values from YAML

HOLD = """\
root:
  parallel:
    name: follow
    children:
      - force_hold: {name: hold, {param}: {value}}
"""


@pytest.mark.parametrize(
    "param,value,needle",
    [
        ("target_pa", ".nan", "target_pa must be finite and > 0 (got nan Pa)"),
        ("target_pa", ".inf", "target_pa must be finite and > 0 (got inf Pa)"),
        ("target_pa", "1e400", "target_pa must be finite and > 0 (got inf Pa)"),
        ("target_pa", "-2000", "target_pa must be > 0 (got -2000.0 Pa)"),
        ("target_pa", "-2 kPa", "target_pa must be > 0 (got -2000.0 Pa)"),
        ("target_pa", "0", "target_pa must be > 0 (got 0.0 Pa)"),
        ("target_pa", '"-1e400"', "target_pa must be finite and > 0 (got -inf Pa)"),
        ("kp", "-1e-5", "kp must not be negative (got -1e-05 (m/s)/Pa)"),
        ("ki", ".nan", "ki must be finite and >= 0 (got nan (m/s)/(Pa·s))"),
        ("band", "0", "band must be > 0 (got 0.0 Pa)"),
        ("dwell_s", "-0.5", "dwell_s must not be negative (got -0.5 s)"),
        ("output_limit", "0", "output_limit must be > 0 or inf (got 0.0 m/s)"),
        ("output_limit", ".nan", "output_limit must be > 0 or inf (got nan m/s)"),
    ],
)
def test_bad_force_hold_values_name_file_line_column_node_and_parameter(param, value, needle):
    text = HOLD.replace("{param}", param).replace("{value}", value)
    err = load_error(text)
    column = text.splitlines()[4].index(value) + 1
    assert (err.file, err.line, err.column) == (FILE, 5, column)
    assert str(err) == f"{FILE}:5:{column}: force_hold 'hold': {needle}"
    assert err.field == f"force_hold.{param}"


@pytest.mark.parametrize(
    "node,needle",
    [
        ("approach: {speed_mps: 0}", "approach 'approach': speed_mps must be (0, 0.05] (got 0.0 m/s)"),
        ("approach: {speed_mps: 10}",  # meant as mm/s: the twist limit would cap it
         "approach 'approach': speed_mps must be (0, 0.05] (got 10.0 m/s); the pad moves at most 0.05 m/s"),
        ("approach: {pressure_pa: -800}", "approach 'approach': pressure_pa must be > 0"),
        ("approach: {timeout_s: .inf}", "timeout_s must be finite and > 0 (got inf s)"),
        ("approach: {max_travel_m: .nan}", "max_travel_m must be finite and > 0"),
        ("align_edge: {target_rad: .nan}", "target_rad must be finite (got nan rad)"),
        ("centre: {target_m: [0, .nan]}", "centre 'centre': target_m[1] must be finite (got nan m)"),
        ("roll: {roll_radius: 0}", "roll_radius must be > 0"),
        ("tactile_servo: {kp: [1, 1, -1e-6, 1]}", "tactile_servo 'tactile_servo': kp[2] must not be negative"),
        ("tactile_servo: {band: [0.0005, 0.0005, 0, 0.03]}", "band[2] must be > 0 (got 0.0)"),
        ("tactile_servo: {target_pa: -1}", "target_pa must be > 0"),
        ("guided_slide: {twist: [0, .inf, 0, 0, 0, 0]}", "twist[1] must be finite (got inf m/s)"),
        ("guided_slide: {distance_m: -1 mm}", "distance_m must not be negative (got -0.001 m)"),
        ("guided_slide: {duration_s: .nan}", "duration_s must be finite and >= 0"),
        ("record_contacts: {region_level: 0}", "region_level must be (0, 1] (got 0.0)"),
        ("record_contacts: {voxel_m: -1 mm}", "voxel_m must not be negative"),
        ("scan_direction: {speed_mps: -0.02}", "speed_mps must be > 0"),
        ("scan_direction: {direction: [1, .nan, 0]}", "direction[1] must be finite"),
        ("tilt_limit: {max_tilt_rad: 200 deg}", "max_tilt_rad must be [0, π]"),
        ("contact_shrank: {min_area_ratio: 1}", "min_area_ratio must be [0, 1)"),
        ("contact_stalled: {window_s: -1}", "window_s must be > 0"),
        ("coverage_stalled: {window_s: 0}", "window_s must be > 0"),
        ("coverage_stalled: {min_samples: -1}", "min_samples must not be negative (got -1)"),
        ("contact_lost: {grace_s: -0.1}", "contact_lost 'contact_lost': grace_s must not be negative (got -0.1 s)"),
        ("force_limit: {limit_n: 0 mN}", "force_limit 'force_limit': limit_n must be > 0 (got 0.0 N)"),
        ("mission_timeout: {duration_s: .inf, child: {force_hold: }}",
         "mission_timeout 'mission_timeout': duration_s must be finite and > 0 (got inf s)"),
        ("retry: {num_failures: 0, child: {force_hold: }}", "retry 'retry': num_failures must be >= 1 (got 0)"),
        ("repeat: {num_success: -2, child: {force_hold: }}", "num_success must be >= 1 or -1 (got -2)"),
    ],
)
def test_bad_values_of_every_kind_of_node(node, needle):
    err = load_error(f"root:\n  {node}\n")
    assert err.line == 2 and needle in str(err), str(err)
    assert str(err).startswith(f"{FILE}:2:{err.column}: ")


def test_a_bad_value_in_a_subtree_names_the_value_and_the_use():
    err = load_error("""\
subtrees:
  hold:
    params: {target: 2000}
    root: {force_hold: {target_pa: $target}}
root:
  hold: {target: -5}
""")
    assert (err.line, err.column) == (6, 18)
    assert "force_hold 'hold': target_pa must be > 0 (got -5.0 Pa)" in str(err)
    assert "in subtree 'hold', used at trees/x.yaml:6:3" in str(err)


@pytest.mark.parametrize(
    "node,attribute,expected",
    [
        ("force_hold: {output_limit: .inf}", "pid.output_limit", [math.inf]),  # inf = no limit
        ("repeat: {num_success: -1, child: {force_hold: }}", "num_success", -1),  # -1 = forever
        ("guided_slide: {twist: [0, -0.02, 0, 0, 0, -0.1]}", "_twist", (0.0, -0.02, 0.0, 0.0, 0.0, -0.1)),
        ("centre: {target_m: [-1 px, -2 mm]}", "target_m", (-0.005, -0.002)),
        ("align_edge: {target_rad: -45 deg}", "target_rad", -math.pi / 4),
        ("tilt_limit: {max_tilt_rad: 180 deg}", "max_tilt_rad", math.pi),
        ("guided_slide: {distance_m: 0, duration_s: 0}", "distance_m", 0.0),
    ],
)
def test_signed_and_limit_values_that_are_allowed(node, attribute, expected):
    leaf = load_tree(FILE, text=f"root:\n  {node}\n").root
    value = leaf
    for part in attribute.split("."):
        value = getattr(value, part)
    assert value == pytest.approx(expected)


# --------------------------------------------------------------------------------- quoted numbers


@pytest.mark.parametrize(
    "node,attribute,expected",
    [
        ('force_hold: {target_pa: "1500"}', "target_pa", 1500.0),
        ('force_hold: {target_pa: "1.5 kPa"}', "target_pa", 1500.0),
        ('force_hold: {target_pa: "1500Pa"}', "target_pa", 1500.0),
        ('force_hold: {target_pa: "2e3"}', "target_pa", 2000.0),
        ("force_hold: {target_pa: ' 1800 '}", "target_pa", 1800.0),
        ('approach: {speed_mps: "0.01"}', "speed_mps", 0.01),
        ('align_edge: {target_rad: "-0.5"}', "target_rad", -0.5),
        ('centre: {target_m: ["0.001", "-1 mm"]}', "target_m", (0.001, -0.001)),
    ],
)
def test_quoted_numbers_are_numbers_in_the_si_unit(node, attribute, expected):
    leaf = load_tree(FILE, text=f"root:\n  {node}\n").root
    assert getattr(leaf, attribute) == pytest.approx(expected)


def test_a_quoted_number_for_a_parameter_without_unit():
    leaf = load_tree(FILE, text='root:\n  force_hold: {kp: "5e-5", ki: "0"}\n').root
    assert leaf.pid.kp == [5e-5] and leaf.pid.ki == [0.0]


@pytest.mark.parametrize(
    "value,needle",
    [
        ('"15 00"', "expected a number in Pa"),
        ('"1500 Pascal"', "unit 'Pascal' does not fit a value in Pa"),
        ('"nan"', "expected a number in Pa"),
        ('"-3 kPa"', "target_pa must be > 0 (got -3000.0 Pa)"),
    ],
)
def test_quoted_values_that_are_not_good_numbers(value, needle):
    err = load_error(f"root:\n  force_hold: {{target_pa: {value}}}\n")
    assert (err.line, err.column) == (2, 27) and needle in str(err)


# --------------------------------------------------------------------------------- every class


def test_physical_signs_are_declared_where_physics_demands():
    """A spot check of the table: the reference documents the same bounds (docs/trees.md)."""
    def bound(type_name, param):
        return str({p.name: p for p in parameters_of({**LEAVES, **DECORATORS}[type_name])}[param].bound)

    assert bound("force_hold", "target_pa") == "> 0"
    assert bound("tactile_servo", "target_pa") == "> 0"
    assert bound("approach", "pressure_pa") == "> 0"
    assert bound("force_hold", "kp") == ">= 0"
    assert bound("force_hold", "band") == "> 0"
    assert bound("force_hold", "output_limit") == "> 0 or inf"
    assert bound("force_limit", "limit_n") == "> 0"
    assert bound("mission_timeout", "duration_s") == "> 0"
    assert bound("guided_slide", "twist") == "finite"  # signed: the sign is the direction
    assert bound("align_edge", "target_rad") == "finite"


@pytest.mark.parametrize(
    "make,needle",
    [
        (lambda: ForceHold(name="hold", target_pa=-2000.0), "force_hold 'hold': target_pa must be > 0 (got -2000.0 Pa)"),
        (lambda: ForceHold(target_pa=float("nan")), "force_hold 'force_hold': target_pa must be finite and > 0"),
        (lambda: ForceHold(kp=float("inf")), "kp must be finite and >= 0"),
        (lambda: TactileServo(kp=np.array([1.0, 1.0, -1.0, 1.0])), "kp[2] must not be negative"),
        (lambda: Retry(ForceHold(), num_failures=0), "retry 'retry': num_failures must be >= 1 (got 0)"),
        (lambda: Repeat(ForceHold(), name="again", num_success=0), "repeat 'again': num_success must be >= 1 or -1"),
    ],
)
def test_python_construction_gets_the_same_checks(make, needle):
    with pytest.raises(ParameterValueError) as info:
        make()
    assert needle in str(info.value)
    assert isinstance(info.value, ValueError)


def test_a_subclass_redeclares_a_default_and_keeps_the_checks():
    class Gentle(ForceHold):
        target_pa = ForceHold.target_pa.replace(default=500.0)
        kp = ForceHold.kp.replace(default=1e-5)

    assert Gentle().target_pa == 500.0 and Gentle().name == "gentle" and Gentle().pid.kp == [1e-5]
    with pytest.raises(ParameterValueError, match="Gentle 'soft': target_pa must be > 0"):
        Gentle(name="soft", target_pa=-1.0)
    assert list(inspect.signature(Gentle).parameters)[:2] == ["name", "target_pa"]


def test_convert_parameter_and_bounds_directly():
    assert convert_parameter("1500", float, "Pa") == 1500.0
    assert convert_parameter("2 kPa", float, "Pa", Bound(0.0, low_open=True), "target_pa") == 2000.0
    with pytest.raises(ParameterValueError, match=r"^target_pa must be > 0 \(got -1.0 Pa\)$"):
        convert_parameter(-1, float, "Pa", Bound(0.0, low_open=True), "target_pa")
    with pytest.raises(ParameterValueError, match="must be finite"):
        convert_parameter(float("nan"), float)  # every float is finite unless its bound allows inf
    with pytest.raises(ParameterValueError, match=r"value\[1\] must be finite"):
        convert_parameter([0.0, float("inf")], tuple)
    assert str(FINITE) == "finite" and str(Bound(0, 1, high_open=True)) == "[0, 1)"


# --------------------------------------------------------------------------------- blackboard


@pytest.mark.parametrize(
    "value,needle",
    [
        (-2000.0, "target_pa must be > 0 (got -2000.0 Pa)"),
        (float("nan"), "target_pa must be finite and > 0 (got nan Pa)"),
        (math.inf, "target_pa must be finite and > 0 (got inf Pa)"),
        ("1500", None),  # a quoted number works there too
    ],
)
def test_blackboard_values_get_the_same_checks(value, needle):
    from tactile_bt.errors import BlackboardReferenceError

    tree = load_tree(FILE, text='root:\n  force_hold: {name: hold, target_pa: "@/goal/pressure"}\n')
    h = LeafHarness(tree)
    h.set("/goal/pressure", value)
    if needle is None:
        h.tick(make_features(pressure=1000.0))
        assert tree.root.target_pa == 1500.0
        return
    with pytest.raises(BlackboardReferenceError) as info:
        h.tick()
    message = str(info.value)
    assert message.startswith(f"{FILE}:2:39: hold.target_pa: bad value from blackboard key '/goal/pressure': ")
    assert needle in message


# --------------------------------------------------------------------------------- not UTF-8


def test_a_tree_file_that_is_not_utf8_is_a_one_line_error(tmp_path, capsys):
    bad = tmp_path / "latin1.yaml"
    bad.write_bytes("# pressure for the café scene\nroot:\n  force_hold: {target_pa: 2000}\n".encode("latin-1"))
    with pytest.raises(TreeError) as info:
        load_tree(bad)
    err = info.value
    offset = "# pressure for the caf".__len__()
    assert (err.file, err.line, err.column) == (str(bad), 1, offset + 1)
    assert f"byte 0xe9 at byte offset {offset}" in str(err)
    assert main(["tree", str(bad)]) == 2
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {bad}:1:{offset + 1}: not UTF-8")
    assert "Traceback" not in out.err


def test_a_bad_byte_after_utf8_text_counts_lines_and_characters(tmp_path):
    bad = tmp_path / "mixed.yaml"
    bad.write_bytes("root:\n  force_hold: {target_pa: 2000}  # 2 kPa, π\n# \xff\n".encode("utf-8").replace(b"\xc3\xbf", b"\xff"))
    with pytest.raises(TreeError) as info:
        load_tree(bad)
    assert (info.value.line, info.value.column) == (3, 3)


def test_a_utf8_byte_order_mark_is_fine_and_a_nul_byte_is_a_located_error(tmp_path):
    bom = tmp_path / "bom.yaml"
    bom.write_bytes(b"\xef\xbb\xbfroot:\n  force_hold: {target_pa: 1900}\n")
    assert load_tree(bom).root.target_pa == 1900.0
    nul = tmp_path / "nul.yaml"
    nul.write_bytes(b"root:\n  force_hold: {target_pa: 19\x0000}\n")
    with pytest.raises(TreeError, match=r"nul.yaml:2:29: invalid YAML: the character U\+0000"):
        load_tree(nul)


def test_a_scene_file_that_is_not_utf8_is_a_one_line_error_too(tmp_path, capsys):
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    scene = tmp_path / "scene.yaml"
    scene.write_bytes((root / "sim" / "cable.yaml").read_bytes() + b"# \xff\n")
    code = main(["run", str(root / "trees" / "force_hold.yaml"), "--scene", str(scene), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.startswith(f"error: {scene}:") and "not UTF-8" in err and len(err.strip().splitlines()) == 1


def test_python_trees_get_no_blackboard_writer_by_accident():
    tree = load_tree(FILE, text="root:\n  force_hold:\n")
    assert isinstance(tree, py_trees.trees.BehaviourTree) and tree.blackboard_values == {}
