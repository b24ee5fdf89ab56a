"""YAML trees: trees/cable_follow.yaml, and errors that name file, line and the closest name."""

from pathlib import Path

import numpy as np
import py_trees
import pytest
from numpy.testing import assert_allclose
from py_trees.common import Status

from tactile_bt import load_tree
from tactile_bt.behaviours import (
    AlignEdge,
    Approach,
    Centre,
    ContactLost,
    ForceHold,
    GuidedSlide,
    MissionTimeout,
    RecordContacts,
)
from tactile_bt.loader import NODE_TYPES, TreeError
from tactile_bt.testing import LeafHarness, make_features

REPO = Path(__file__).resolve().parents[1]
CABLE_TREE = REPO / "trees" / "cable_follow.yaml"
FILE = "my_tree.yaml"


@pytest.fixture(autouse=True)
def fresh_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def load_error(text: str) -> TreeError:
    with pytest.raises(TreeError) as info:
        load_tree(FILE, text=text)
    return info.value


def shape(node):
    """(type, name, children) of a tree, for structural comparison."""
    return (type(node).__name__, node.name, [shape(c) for c in node.children])


# --------------------------------------------------------------------------------- cable_follow


def test_cable_follow_loads_with_the_expected_nodes():
    tree = load_tree(CABLE_TREE)
    assert isinstance(tree, py_trees.trees.BehaviourTree)
    root = tree.root
    assert isinstance(root, py_trees.composites.Sequence) and root.name == "cable_follow"
    assert root.memory is True
    approach, follow = root.children
    assert isinstance(approach, Approach)
    assert (approach.speed_mps, approach.pressure_pa, approach.timeout_s) == (0.01, 800.0, 5.0)
    assert isinstance(follow, py_trees.composites.Parallel) and follow.name == "follow"
    assert isinstance(follow.policy, py_trees.common.ParallelPolicy.SuccessOnOne)
    assert [type(c) for c in follow.children] == [ForceHold, Centre, AlignEdge, GuidedSlide, RecordContacts, ContactLost]
    hold, centre, align, slide, record, lost = follow.children
    assert record.point == "local"
    assert hold.target_pa == 2000.0
    assert centre.target_m == (0.0, 0.0)
    assert align.target_rad == pytest.approx(np.pi / 2)
    assert_allclose(slide.twist, [0.0, 0.02, 0.0, 0.0, 0.0, 0.0])
    assert lost.grace_s == 0.3
    assert tree.tree_name == "cable_follow"


def python_cable_follow():
    """The cable tree written in Python with the same classes."""
    follow = py_trees.composites.Parallel(
        name="follow",
        policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[
            ForceHold(target_pa=2000),
            Centre(target_m=[0.0, 0.0]),
            AlignEdge(target_rad=1.5707963),
            GuidedSlide(twist=[0.0, 0.02, 0.0, 0.0, 0.0, 0.0]),
            RecordContacts(point="local"),
            ContactLost(grace_s=0.3),
        ],
    )
    approach = Approach(speed_mps=0.01, pressure_pa=800, timeout_s=5.0)
    return py_trees.trees.BehaviourTree(py_trees.composites.Sequence(name="cable_follow", memory=True,
                                                                     children=[approach, follow]))


def run_script(tree):
    """Tick a tree through approach, following and losing the contact; statuses and twists."""
    rng = np.random.default_rng(5)
    script = [make_features(in_contact=False)] * 5 + [make_features(pressure=p) for p in (300.0, 900.0)]
    script += [
        make_features(pressure=p, cop_px=c, orientation=a)
        for p, c, a in zip(rng.uniform(1500, 2500, 40), rng.uniform(5, 10, (40, 2)), rng.uniform(1.2, 1.9, 40))
    ]
    script += [make_features(in_contact=False)] * 100
    h = LeafHarness(tree.root)
    statuses, twists = [], []
    for f in script:
        statuses.append(h.tick(f))
        twists.append(h.twist.copy())
        if statuses[-1] != Status.RUNNING:
            break
    return statuses, np.array(twists), h.contacts.data.copy()


def test_python_built_tree_matches_and_behaves_like_the_yaml_one():
    yaml_tree = load_tree(CABLE_TREE)
    py_tree = python_cable_follow()
    assert shape(yaml_tree.root) == shape(py_tree.root)
    s_yaml, tw_yaml, c_yaml = run_script(yaml_tree)
    py_trees.blackboard.Blackboard.clear()
    s_py, tw_py, c_py = run_script(py_tree)
    assert s_yaml == s_py
    assert_allclose(tw_yaml, tw_py, rtol=0, atol=0)
    assert_allclose(c_yaml, c_py, rtol=0, atol=0)
    # the scripted mission: approach, follow with a non-zero twist, then contact lost → FAILURE
    assert s_yaml[-1] == Status.FAILURE
    # the follow branch starts in the tick where approach succeeds (900 Pa), then 40 more
    assert len(c_yaml) == 41
    assert tw_yaml[:5, 2].tolist() == [0.01] * 5


def test_every_registered_type_is_a_node_type():
    for name in ("approach", "force_hold", "centre", "roll", "align_edge", "tactile_servo", "guided_slide",
                 "record_contacts", "contact_lost", "force_limit", "mission_timeout", "sequence", "selector",
                 "parallel"):
        assert name in NODE_TYPES


def test_minimal_tree_from_text_with_defaults_and_scientific_numbers():
    tree = load_tree(FILE, text="root:\n  force_hold: {target_pa: 2e3, kp: 1e-6}\n")
    assert isinstance(tree.root, ForceHold)
    assert tree.root.target_pa == 2000.0
    assert tree.root.pid.kp == [1e-6]
    tree = load_tree(FILE, text="root:\n  force_hold:\n")  # no parameters: all defaults
    assert tree.root.target_pa == 2000.0
    assert tree.tree_name == "my_tree"


def test_tactile_servo_with_an_explicit_projection():
    text = """\
root:
  tactile_servo:
    P: [0, 0, 1, 0, 0, 1]
    target_pa: 1500
    kp: [3.0, 3.0, 2.0e-6, 4.0]
"""
    leaf = load_tree(FILE, text=text).root
    h = LeafHarness(leaf)
    h.tick(make_features(pressure=1000.0, cop_px=(12.0, 3.0), orientation=1.2))
    twist = h.twist
    assert twist[2] > 0 and twist[5] < 0
    assert twist[[0, 1, 3, 4]].tolist() == [0.0, 0.0, 0.0, 0.0]


def test_tactile_servo_bad_projection_names_the_line():
    err = load_error("root:\n  tactile_servo:\n    P: [0, 0, 2, 0, 0, 1]\n")
    assert err.line == 2 and "P" in str(err)


def test_decorator_with_child_builds():
    text = """\
root:
  mission_timeout:
    duration_s: 3
    succeed: true
    child:
      guided_slide: {twist: [0, 0.01, 0, 0, 0, 0]}
"""
    root = load_tree(FILE, text=text).root
    assert isinstance(root, MissionTimeout)
    assert root.duration_s == 3.0 and root.succeed is True
    assert isinstance(root.decorated, GuidedSlide)


@pytest.mark.parametrize("kind,memory", [("sequence", False), ("sequence", True), ("selector", False), ("selector", True)])
def test_memory_flag_is_honoured(kind, memory):
    text = f"""\
root:
  {kind}:
    memory: {str(memory).lower()}
    children:
      - contact_lost: {{}}
      - force_hold: {{}}
"""
    root = load_tree(FILE, text=text).root
    assert root.memory is memory


def test_sequence_memory_changes_which_child_is_ticked():
    """With memory the sequence resumes at the running child; without it re-ticks from the first."""
    text = """\
root:
  sequence:
    memory: {memory}
    children:
      - approach: {{pressure_pa: 800}}
      - force_hold: {{}}
"""
    features = [make_features(pressure=1000.0), make_features(pressure=500.0)]
    twists = {}
    for memory in ("true", "false"):
        py_trees.blackboard.Blackboard.clear()
        h = LeafHarness(load_tree(FILE, text=text.format(memory=memory)).root)
        for f in features:
            h.tick(f)
        twists[memory] = h.twist.copy()
    # with memory: approach is done, force_hold runs (pressure too low → +vz from the servo)
    assert twists["true"][2] > 0 and twists["true"][2] != 0.01
    # without memory: approach is re-ticked first and runs again at its speed (0.01 m/s)
    assert twists["false"][2] == pytest.approx(0.01)


def test_parallel_policy_and_default():
    text = """\
root:
  parallel:
    {policy}
    children:
      - force_hold: {{}}
      - contact_lost: {{}}
"""
    root = load_tree(FILE, text=text.format(policy="policy: success_on_all")).root
    assert isinstance(root.policy, py_trees.common.ParallelPolicy.SuccessOnAll)
    root = load_tree(FILE, text=text.format(policy="synchronise: true")).root
    assert isinstance(root.policy, py_trees.common.ParallelPolicy.SuccessOnAll)


# --------------------------------------------------------------------------------- errors


def test_unknown_node_type_names_file_line_and_suggests():
    err = load_error("""\
root:
  sequence:
    children:
      - force_hodl: {target_pa: 2000}
""")
    msg = str(err)
    assert msg.startswith(f"{FILE}:4:")
    assert (err.file, err.line) == (FILE, 4)
    assert "force_hodl" in msg and "did you mean 'force_hold'" in msg


def test_misspelt_parameter_names_file_line_and_suggests():
    err = load_error("""\
root:
  sequence:
    children:
      - approach: {}
      - force_hold:
          kp: 1.0e-6
          target_pas: 2000
""")
    msg = str(err)
    assert f"{FILE}:7:" in msg
    assert "target_pas" in msg and "did you mean 'target_pa'" in msg


def test_wrong_type_names_file_line_and_field():
    err = load_error("""\
root:
  sequence:
    children:
      - force_hold:
          target_pa: "high"
""")
    msg = str(err)
    assert f"{FILE}:5:" in msg
    assert "target_pa" in msg and "high" in msg and "number" in msg


@pytest.mark.parametrize(
    "node,field,line",
    [
        ("force_hold: {target_pa: true}", "target_pa", 2),
        ("guided_slide:\n    twist: [0, a, 0, 0, 0, 0]", "twist", 3),
        ("force_hold: {converge: 1}", "converge", 2),
        ("centre: {target_m: 0.0}", "target_m", 2),
    ],
)
def test_more_wrong_types(node, field, line):
    err = load_error(f"root:\n  {node}\n")
    assert (err.file, err.line) == (FILE, line)
    assert field in str(err)


def test_record_contacts_point_kind_is_checked_with_its_line():
    err = load_error("root:\n  parallel:\n    children:\n      - record_contacts: {point: centre}\n")
    assert err.line == 4 and "point" in str(err)


def test_bad_value_rejected_by_the_class_names_the_line():
    err = load_error("""\
root:
  sequence:
    children:
      - approach: {speed_mps: -0.01}
""")
    assert err.line == 4 and "speed_mps" in str(err)


def test_missing_root():
    err = load_error("name: nothing\ndescription: a tree without a root\n")
    assert str(err).startswith(f"{FILE}:1")
    assert "root" in str(err)


def test_misspelt_top_level_key_suggests_root():
    err = load_error("roots:\n  force_hold: {}\n")
    assert err.line == 1 and "did you mean 'root'" in str(err)


def test_bad_parallel_policy():
    err = load_error("""\
root:
  parallel:
    policy: success_on_al
    children:
      - force_hold: {}
""")
    msg = str(err)
    assert f"{FILE}:3:" in msg
    assert "success_on_al" in msg and "did you mean 'success_on_all'" in msg


def test_decorator_without_child():
    err = load_error("""\
root:
  sequence:
    children:
      - mission_timeout:
          duration_s: 2.0
""")
    assert err.line == 5
    assert "child" in str(err)


def test_decorator_with_nothing():
    err = load_error("root:\n  mission_timeout:\n")
    assert err.line == 2 and "child" in str(err)


def test_composite_without_children():
    err = load_error("root:\n  sequence:\n    name: empty\n    children: []\n")
    assert err.line == 4 and "children" in str(err)


def test_unknown_composite_parameter_suggests():
    err = load_error("root:\n  sequence:\n    memmory: false\n    children:\n      - force_hold: {}\n")
    assert err.line == 3 and "did you mean 'memory'" in str(err)


def test_duplicate_key():
    err = load_error("""\
root:
  sequence:
    children:
      - force_hold:
          target_pa: 2000
          target_pa: 2500
""")
    assert err.line == 6
    assert "duplicate" in str(err) and "target_pa" in str(err)


def test_yaml_syntax_error_names_the_line():
    err = load_error("""\
root:
  sequence:
    children:
      - force_hold: {}
     - centre: {}
""")
    assert err.file == FILE and err.line == 5
    assert str(err).startswith(f"{FILE}:5")


def test_a_node_must_be_a_single_key_mapping():
    err = load_error("root:\n  force_hold: {}\n  centre: {}\n")
    assert err.line == 2 and "exactly one key" in str(err)


def test_empty_file_and_missing_file(tmp_path):
    with pytest.raises(TreeError, match="empty"):
        load_tree(FILE, text="")
    missing = tmp_path / "nope.yaml"
    with pytest.raises(TreeError) as info:
        load_tree(missing)
    assert str(missing) in str(info.value)


def test_error_names_a_real_file_path(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("root:\n  sequence:\n    children:\n      - force_hold: {target_pas: 1}\n")
    with pytest.raises(TreeError) as info:
        load_tree(path)
    assert str(info.value).startswith(f"{path}:4:")
