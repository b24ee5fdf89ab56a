"""YAML trees: trees/cable_follow.yaml, and errors that name file, line and the closest name."""

from pathlib import Path

import numpy as np
import py_trees
import pytest
from numpy.testing import assert_allclose
from py_trees.common import Status

from tactile_bt import load_tree
from tactile_bt.tree.behaviours import (
    AlignEdge,
    Approach,
    Centre,
    ContactLost,
    ForceHold,
    GuidedSlide,
    MissionTimeout,
    RecordContacts,
)
from tactile_bt.tree.registry import NODE_TYPES
from tactile_bt.errors import TreeError
from tactile_bt.testing import LeafHarness, make_features

REPO = Path(__file__).resolve().parents[2]
CABLE_TREE = REPO / "trees" / "cable_follow.yaml"
FILE = "my_tree.yaml"



def load_error(text: str) -> TreeError:
    with pytest.raises(TreeError) as info:
        load_tree(FILE, text=text)
    return info.value


def shape(node):
    """(type, name, children) of a tree, for structural comparison."""
    return (type(node).__name__, node.name, [shape(c) for c in node.children])


# --------------------------------------------------------------------------------- cable_follow

#: The cable-following tree of the paper (Sec. V-D) as the loader tests know it; the tuned
#: version in trees/cable_follow.yaml may differ in its gains and extra rows.
CABLE_TEXT = """\
# Cable following (paper Sec. V-D)
name: cable_follow
description: follow an unknown cable lying on a table and record its path
root:
  sequence:
    name: cable_follow
    children:
      - approach:
          speed_mps: 0.01
          pressure_pa: 800
          timeout_s: 5.0
      - parallel:
          name: follow
          policy: success_on_one
          children:
            - force_hold: {target_pa: 2000}
            - centre: {target_m: [0.0, 0.0]}
            - align_edge: {target_rad: 1.5707963}   # cable along the sensor y axis
            - guided_slide: {twist: [0.0, 0.02, 0.0, 0.0, 0.0, 0.0]}
            - record_contacts: {point: local}   # where the cable crosses the pad centre
            - contact_lost: {grace_s: 0.3}
"""


def cable_tree():
    return load_tree("cable.yaml", text=CABLE_TEXT)


def test_cable_follow_loads_with_the_expected_nodes():
    tree = cable_tree()
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


def test_the_project_cable_tree_keeps_its_shape():
    """trees/cable_follow.yaml: beside the stiffness estimate, approach, then a bounded number of
    attempts, each backing up after a loss, settling on the cable and a parallel that slides,
    records and ends at the end of the cable (or fails when the line is lost)."""
    from tactile_bt.tree.behaviours import AdaptForceTarget, Backtrack, CableEnd, MissionTimeout, Retry

    adapt, task = load_tree(CABLE_TREE).root.children
    assert isinstance(adapt, AdaptForceTarget)
    approach, attempts = task.children
    assert isinstance(approach, Approach) and isinstance(attempts, Retry) and attempts.num_failures >= 2
    back_up, settle, follow = attempts.decorated.children
    assert any(isinstance(c, Backtrack) for c in back_up.children)
    assert isinstance(settle, MissionTimeout)
    kinds = {type(c) for c in follow.children}
    assert {ForceHold, Centre, AlignEdge, GuidedSlide, RecordContacts, CableEnd} <= kinds
    recorder = next(c for c in follow.children if isinstance(c, RecordContacts))
    assert recorder.only_when == "/cable/on_line"
    hold = next(c for c in follow.children if isinstance(c, ForceHold))
    assert hold.target_key == adapt.key == recorder.target_key


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
    yaml_tree = cable_tree()
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
    assert err.line == 3 and "P" in str(err)  # the value, not the node


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


# --------------------------------------------------------------------------------- decorators


def harness(text: str, dt: float = 1.0 / 128.0) -> LeafHarness:
    return LeafHarness(load_tree(FILE, text=text).root, dt=dt)


NO_CONTACT = make_features(in_contact=False)


def test_every_decorator_is_a_node_type_and_none_reads_wall_time():
    import inspect as _inspect

    for name in ("mission_timeout", "retry", "repeat", "inverter", "oneshot"):
        assert name in NODE_TYPES
    from tactile_bt.tree.behaviours import DECORATORS

    for cls in DECORATORS.values():
        for klass in cls.__mro__:
            if klass.__module__.startswith(("py_trees", "tactile_bt")) and klass is not object:
                source = _inspect.getsource(klass)
                assert "time.monotonic" not in source and "time.time" not in source, klass


def test_retry_restarts_a_failing_child_until_num_failures():
    """approach fails after 0.1 s without contact; retry runs it three times, then fails."""
    h = harness("""\
root:
  retry:
    num_failures: 3
    child:
      approach: {timeout_s: 0.1}
""")
    approach = h.behaviour.decorated
    n = h.tick_until(Status.FAILURE, max_ticks=1000, features=iter(lambda: NO_CONTACT, None))
    # each attempt: 0.1 s of mission time plus the failing tick; the next attempt starts a tick later
    assert 3 * 0.1 < n * h.dt < 3 * (0.1 + 3 * h.dt)
    assert approach.status == Status.FAILURE
    # a retry that meets the object succeeds
    py_trees.blackboard.Blackboard.clear()
    h = harness("root:\n  retry:\n    num_failures: 3\n    child:\n      approach: {timeout_s: 0.1}\n")
    h.tick_until(lambda s: h.behaviour.failures == 1, max_ticks=1000, features=iter(lambda: NO_CONTACT, None))
    assert h.behaviour.status == Status.RUNNING
    assert h.tick(make_features(pressure=1500.0)) == Status.SUCCESS


def test_repeat_runs_a_succeeding_child_num_success_times():
    h = harness("""\
root:
  repeat:
    num_success: 3
    child:
      guided_slide: {duration_s: 0.125}
""")
    slide = h.behaviour.decorated
    starts = []
    original = slide.initialise

    def counting():
        starts.append(h.time)
        original()

    slide.initialise = counting
    n = h.tick_until(Status.SUCCESS, max_ticks=1000)
    assert len(starts) == 3
    assert n == 3 * 17  # 16 ticks of 1/128 s sliding + the succeeding tick, three times
    assert h.twist.tolist() == [0.0] * 6  # the succeeding tick adds no twist


def test_repeat_forever_and_failure_ends_it():
    h = harness("root:\n  repeat:\n    num_success: -1\n    child:\n      guided_slide: {duration_s: 0.05}\n")
    assert h.tick_for(2.0) == Status.RUNNING
    py_trees.blackboard.Blackboard.clear()
    h = harness("root:\n  repeat:\n    child:\n      contact_lost: {grace_s: 0.0}\n")
    assert h.tick(NO_CONTACT) == Status.FAILURE


def test_inverter_swaps_success_and_failure():
    h = harness("root:\n  inverter:\n    child:\n      contact_lost: {grace_s: 0.0}\n")
    assert h.tick(make_features()) == Status.RUNNING
    assert h.tick(NO_CONTACT) == Status.SUCCESS
    py_trees.blackboard.Blackboard.clear()
    h = harness("root:\n  inverter:\n    child:\n      approach: {pressure_pa: 800}\n")
    assert h.tick(make_features(pressure=900.0)) == Status.FAILURE


@pytest.mark.parametrize("policy,second", [("on_completion", Status.FAILURE), ("on_successful_completion", Status.RUNNING)])
def test_oneshot_policies(policy, second):
    """A failing child: on_completion keeps the failure for good; on_successful_completion lets
    it run again (and then stays SUCCESS)."""
    h = harness(f"""\
root:
  oneshot:
    policy: {policy}
    child:
      approach: {{timeout_s: 0.02}}
""")
    approach = h.behaviour.decorated
    h.tick_until(Status.FAILURE, max_ticks=100, features=iter(lambda: NO_CONTACT, None))
    ticks_before = h.time
    assert h.tick(NO_CONTACT) == second
    if policy == "on_completion":
        for _ in range(5):
            assert h.tick(make_features(pressure=1500.0)) == Status.FAILURE
        assert approach.status == Status.FAILURE  # never ticked again
    else:
        assert approach.status == Status.RUNNING and approach._start == pytest.approx(ticks_before)
        assert h.tick(make_features(pressure=1500.0)) == Status.SUCCESS
        for _ in range(5):
            assert h.tick(NO_CONTACT) == Status.SUCCESS  # bounced, the child is not run again


def test_oneshot_default_policy_and_bad_policy():
    root = load_tree(FILE, text="root:\n  oneshot:\n    child: {force_hold: }\n").root
    assert root.policy == py_trees.common.OneShotPolicy.ON_SUCCESSFUL_COMPLETION
    err = load_error("root:\n  oneshot:\n    policy: once\n    child: {force_hold: }\n")
    assert (err.line, err.column) == (3, 13)
    assert "oneshot.policy" in str(err) and "on_completion" in str(err)


def test_mission_timeout_from_yaml_uses_the_mission_clock():
    h = harness("""\
root:
  mission_timeout:
    duration_s: 250 ms
    child:
      force_hold: {}
""")
    assert h.behaviour.duration_s == 0.25
    h.time = 1000.0  # the mission clock, not the wall clock, counts
    n = h.tick_until(Status.FAILURE, max_ticks=1000)
    assert (n - 1) * h.dt == pytest.approx(0.25)


@pytest.mark.parametrize(
    "text,line,field,hint",
    [
        ("root:\n  retry:\n    num_failures: 1.5\n    child: {force_hold: }\n", 3, "retry.num_failures", "integer"),
        ("root:\n  retry:\n    num_failures: 0\n    child: {force_hold: }\n", 3, "num_failures", "must be >= 1 (got 0)"),
        ("root:\n  repeat:\n    num_sucess: 2\n    child: {force_hold: }\n", 3, "num_sucess", "num_success"),
        ("root:\n  inverter:\n    children: [{force_hold: }]\n", 3, "children", "exactly one child"),
        ("root:\n  retryy:\n    child: {force_hold: }\n", 2, "retryy", "did you mean 'retry'"),
        ("root:\n  parallel:\n    policy: success_on_one\n    synchronise: true\n    children: [{force_hold: }]\n",
         4, "synchronise", "success_on_all"),
    ],
)
def test_decorator_and_policy_errors(text, line, field, hint):
    err = load_error(text)
    assert (err.file, err.line) == (FILE, line)
    assert field in str(err) and hint in str(err)


# --------------------------------------------------------------------------------- subtrees

SUBTREES = """\
subtrees:
  touch:
    description: approach with a chosen threshold
    params: {pressure: 800, speed: 0.01}
    root:
      approach: {speed_mps: $speed, pressure_pa: $pressure}
  hold:
    params: {target: null}
    root:
      parallel:
        policy: success_on_one
        children:
          - force_hold: {target_pa: $target}
          - contact_lost: {grace_s: 0.3}
  lost: {contact_lost: {grace_s: 1.0}}
root:
  sequence:
    children:
{children}
"""


def subtree_tree(*children: str):
    return load_tree(FILE, text=SUBTREES.replace("{children}", "\n".join("      - " + c for c in children)))


def test_subtree_with_defaults_and_overrides_both_call_forms():
    root = subtree_tree("touch: {}", "touch: {pressure: 1.5 kPa}", "subtree: {name: touch, params: {speed: 0.02}}",
                        "touch:", "hold: {target: 1800}", "lost: {}").root
    a, b, c, d, hold, lost = root.children
    assert [type(x) for x in (a, b, c, d)] == [Approach] * 4
    assert (a.pressure_pa, a.speed_mps) == (800.0, 0.01)
    assert (b.pressure_pa, b.speed_mps) == (1500.0, 0.01)
    assert (c.pressure_pa, c.speed_mps) == (800.0, 0.02)
    assert d.pressure_pa == 800.0
    assert a.name == "touch"  # an instance is named after its subtree
    assert isinstance(hold, py_trees.composites.Parallel) and hold.name == "hold"
    assert hold.children[0].target_pa == 1800.0
    assert isinstance(lost, ContactLost) and lost.grace_s == 1.0
    assert a is not b  # every use builds its own nodes


def test_subtree_built_tree_equals_the_expanded_one():
    expanded = load_tree(FILE, text="""\
root:
  sequence:
    children:
      - approach: {name: touch, speed_mps: 0.01, pressure_pa: 900}
      - parallel:
          name: hold
          policy: success_on_one
          children:
            - force_hold: {target_pa: 2100}
            - contact_lost: {grace_s: 0.3}
""")
    py_trees.blackboard.Blackboard.clear()
    with_subtrees = subtree_tree("touch: {pressure: 900}", "hold: {target: 2100}")
    assert shape(expanded.root) == shape(with_subtrees.root)


@pytest.mark.parametrize(
    "child,line,needle",
    [
        ("tuch: {}", 19, "did you mean 'touch'"),
        ("subtree: {name: hodl}", 19, "unknown subtree 'hodl' (did you mean 'hold'?)"),
        ("touch: {pressur: 900}", 19, "unknown parameter 'pressur' (did you mean 'pressure'?)"),
        ("hold: {}", 19, "missing parameter(s) target"),
        ("subtree: {name: hold, parms: {}}", 19, "did you mean 'params'"),
    ],
)
def test_subtree_call_errors(child, line, needle):
    with pytest.raises(TreeError) as info:
        subtree_tree(child)
    err = info.value
    assert (err.file, err.line) == (FILE, line)
    assert needle in str(err)


def test_subtree_parameter_of_the_wrong_type_names_the_call_and_the_field():
    with pytest.raises(TreeError) as info:
        subtree_tree("touch: {pressure: lots}")
    err = info.value
    assert (err.line, err.column) == (19, 27)  # the value the caller wrote
    assert "approach.pressure_pa" in str(err) and "lots" in str(err)
    assert "in subtree 'touch'" in str(err)


@pytest.mark.parametrize(
    "definition,line,needle",
    [
        ("  t:\n    params: {x: 1}\n    root: {force_hold: {target_pa: $y}}\n", 3, "unknown parameter $y"),
        ("  t:\n    params: {x: 1, y: 2}\n    root: {force_hold: {target_pa: $x}}\n", 2, "'y' is never used"),
        ("  t:\n    parms: {x: 1}\n    root: {force_hold: {target_pa: $x}}\n", 2, "did you mean 'params'"),
        ("  centre:\n    root: {force_hold: }\n", 1, "built-in node type"),
        ("  t:\n    params: {x: 1}\n", 2, "'root'"),
        ("  t:\n    params: {x: 1}\n    root: {force_hold: {target_pa: $x, kp: -1}}\n", 3, "kp must not be negative"),
    ],
)
def test_subtree_definition_errors(definition, line, needle):
    text = "subtrees:\n" + definition + "root:\n  force_hold: {}\n"
    err = load_error(text)
    assert err.line == line + 1 and needle in str(err)


def test_subtree_recursion_is_an_error():
    err = load_error("""\
subtrees:
  a:
    sequence:
      children: [{b: {}}]
  b:
    sequence:
      children: [{force_hold: }, {a: {}}]
root:
  a: {}
""")
    assert "recursion" in str(err) and "a → b → a" in str(err)
    assert err.line == 7
    err = load_error("subtrees:\n  a: {inverter: {child: {a: {}}}}\nroot:\n  force_hold: {}\n")
    assert "recursion" in str(err) and err.line == 2


def test_parameter_reference_outside_a_subtree_is_explained():
    err = load_error("root:\n  force_hold: {target_pa: $target}\n")
    assert err.line == 2 and "subtree parameter" in str(err)


def test_include_takes_the_subtrees_of_another_file(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "common.yaml").write_text(
        "subtrees:\n  touch:\n    params: {p: 800}\n    root: {approach: {pressure_pa: $p}}\n")
    tree = tmp_path / "t.yaml"
    tree.write_text("include: [lib/common.yaml]\nroot:\n  touch: {p: 700}\n")
    assert load_tree(tree).root.pressure_pa == 700.0
    # errors inside the included file name that file
    (tmp_path / "lib" / "common.yaml").write_text(
        "subtrees:\n  touch:\n    params: {p: 800}\n    root: {approach: {pressure_pas: $p}}\n")
    with pytest.raises(TreeError) as info:
        load_tree(tree)
    assert info.value.file == str((tmp_path / "lib" / "common.yaml").resolve()) and info.value.line == 4
    assert "did you mean 'pressure_pa'" in str(info.value)
    # a missing file and a clash of names
    tree.write_text("include: [lib/nope.yaml]\nroot:\n  force_hold: {}\n")
    with pytest.raises(TreeError, match="no such file"):
        load_tree(tree)
    (tmp_path / "lib" / "common.yaml").write_text("subtrees:\n  touch: {approach: {}}\n")
    tree.write_text("include: [lib/common.yaml]\nsubtrees:\n  touch: {centre: {}}\nroot:\n  touch: {}\n")
    with pytest.raises(TreeError, match="defined twice"):
        load_tree(tree)


def test_unused_subtrees_are_validated_too():
    err = load_error("subtrees:\n  spare:\n    force_hold: {target_pas: 1}\nroot:\n  centre: {}\n")
    assert err.line == 3 and "did you mean 'target_pa'" in str(err)


# --------------------------------------------------------------------------------- units


@pytest.mark.parametrize(
    "node,attribute,expected",
    [
        ("force_hold: {target_pa: 2 kPa}", "target_pa", 2000.0),
        ("align_edge: {target_rad: 90 deg}", "target_rad", np.pi / 2),
        ("centre: {target_m: [1 px, -2.5 mm]}", "target_m", (0.005, -0.0025)),
        ("approach: {speed_mps: 5 mm/s, timeout_s: 1.5 min}", "speed_mps", 0.005),
        ("force_limit: {limit_n: 500 mN}", "limit_n", 0.5),
    ],
)
def test_numbers_with_units(node, attribute, expected):
    leaf = load_tree(FILE, text=f"root:\n  {node}\n").root
    assert getattr(leaf, attribute) == pytest.approx(expected)


@pytest.mark.parametrize(
    "node,column,needle",
    [
        ("force_hold: {target_pa: 2 mm}", 27, "unit 'mm' does not fit a value in Pa"),
        ("align_edge: {target_rad: 90 dg}", 28, "did you mean 'deg'"),
        ("centre: {target_m: [1 px, 2 kPa]}", 29, "unit 'kPa'"),  # the element
        ("force_hold: {kp: 2 1/s}", 20, "takes no unit"),
    ],
)
def test_wrong_units_name_the_value(node, column, needle):
    err = load_error(f"root:\n  {node}\n")
    assert (err.line, err.column) == (2, column)
    assert needle in str(err)


# --------------------------------------------------------------------------------- blackboard references

BB_TREE = """\
root:
  sequence:
    memory: false
    children:
      - force_hold:
          target_pa: "@/goal/pressure"
          kp: {blackboard: goal/kp}
"""


def test_blackboard_references_are_read_when_the_leaf_starts():
    from tactile_bt.tree.parameters import blackboard_references

    leaf = load_tree(FILE, text=BB_TREE).root.children[0]
    assert blackboard_references(leaf) == {"target_pa": ("/goal/pressure", f"{FILE}:6:22"),
                                           "kp": ("/goal/kp", f"{FILE}:7:15")}
    h = LeafHarness(leaf, dt=1.0 / 128.0)
    h.set("/goal/pressure", 1500)
    h.set("/goal/kp", 1e-6)
    h.tick(make_features(pressure=1000.0))
    assert leaf.target_pa == 1500.0 and leaf.pid.kp == [1e-6]
    assert h.errors == {"pressure_pa": -500.0}
    # a new value is not read while the leaf runs (no per-tick cost) ...
    h.set("/goal/pressure", 2500)
    h.tick(make_features(pressure=1000.0))
    assert leaf.target_pa == 1500.0
    # ... but when it starts again
    leaf.stop(Status.INVALID)
    h.tick(make_features(pressure=1000.0))
    assert leaf.target_pa == 2500.0 and h.errors == {"pressure_pa": -1500.0}


def test_a_missing_blackboard_key_is_a_clear_error_at_initialise():
    from tactile_bt.errors import BlackboardReferenceError

    tree = load_tree(FILE, text=BB_TREE)  # loading does not need the key
    h = LeafHarness(tree.root)
    h.set("/goal/kp", 1e-6)
    with pytest.raises(BlackboardReferenceError) as info:
        h.tick()
    msg = str(info.value)
    assert msg.startswith(f"{FILE}:6:22: force_hold.target_pa:")
    assert "'/goal/pressure' is not set" in msg


def test_a_blackboard_value_of_the_wrong_type_is_an_error_at_initialise():
    from tactile_bt.errors import BlackboardReferenceError

    h = LeafHarness(load_tree(FILE, text=BB_TREE).root)
    h.set("/goal/pressure", "high")
    h.set("/goal/kp", -1.0)
    with pytest.raises(BlackboardReferenceError, match=r"force_hold.target_pa: bad value .*'/goal/pressure'.*number"):
        h.tick()
    h.set("/goal/pressure", 1800.0)
    with pytest.raises(BlackboardReferenceError, match=r"my_tree.yaml:7:15: force_hold.kp: .*must not be negative"):
        h.tick()


def test_blackboard_references_for_lists_decorators_and_subtree_parameters():
    text = """\
subtrees:
  hold_for:
    params: {seconds: 1.0}
    root:
      mission_timeout:
        duration_s: $seconds
        child:
          centre: {target_m: "@/goal/cop"}
root:
  hold_for: {seconds: "@/goal/seconds"}
"""
    root = load_tree(FILE, text=text).root
    h = LeafHarness(root, dt=1.0 / 128.0)
    h.set("/goal/seconds", 0.25)
    h.set("/goal/cop", np.array([0.005, 0.0]))
    n = h.tick_until(Status.FAILURE, max_ticks=1000)
    assert root.duration_s == 0.25 and root.decorated.target_m == (0.005, 0.0)
    assert (n - 1) * h.dt == pytest.approx(0.25)


@pytest.mark.parametrize(
    "node,needle",
    [
        ("record_contacts: {point: '@/x'}", "fixed when the tree is built"),
        ("tactile_servo: {P: '@/p'}", "fixed when the tree is built"),
        ("force_hold: {name: {blackboard: /n}}", "fixed when the tree is built"),
        ("force_hold: {target_pa: '@'}", "malformed blackboard key"),
        ("force_hold: {target_pa: {blackboard: 'a b'}}", "malformed blackboard key"),
        ("sequence: {memory: '@/m', children: [{force_hold: }]}", "cannot come from the blackboard"),
    ],
)
def test_bad_blackboard_references(node, needle):
    err = load_error(f"root:\n  {node}\n")
    assert err.line == 2 and needle in str(err)


def test_leaves_without_references_keep_their_plain_initialise():
    leaf = load_tree(FILE, text="root:\n  force_hold: {target_pa: 1900}\n").root
    assert "initialise" not in vars(leaf)


# --------------------------------------------------------------------------------- reference


def test_describe_nodes_covers_every_type_with_units_and_defaults():
    from tactile_bt.tree.reference import describe_nodes

    docs = describe_nodes()
    assert set(docs) == set(NODE_TYPES) - {"subtree"}
    for doc in docs.values():
        assert doc.summary, doc.type
        for p in doc.parameters:
            assert p.doc, f"{doc.type}.{p.name} has no description"
    params = {p.name: p for p in docs["force_hold"].parameters}
    assert params["target_pa"].unit == "Pa" and params["target_pa"].default == 2000.0
    assert params["target_pa"].type_name == "float"
    assert {p.name: p.unit for p in docs["approach"].parameters}["speed_mps"] == "m/s"
    assert docs["oneshot"].parameters[1].type_name == "on_completion | on_successful_completion"


def test_docs_reference_is_generated_from_the_registry():
    """docs/trees.md holds the output of reference_markdown() between its markers; regenerate
    with `python -m tactile_bt.tree.reference docs/trees.md`."""
    from tactile_bt.tree.reference import reference_markdown

    text = (REPO / "docs" / "trees.md").read_text(encoding="utf-8")
    begin, end = "<!-- BEGIN describe_nodes -->\n", "<!-- END describe_nodes -->"
    generated = text.split(begin, 1)[1].split(end, 1)[0]
    assert generated.strip() == reference_markdown().strip()


def test_a_bad_default_is_found_even_when_every_use_overrides_it():
    err = load_error("""\
subtrees:
  hold:
    params: {target: lots}
    root: {force_hold: {target_pa: $target}}
root:
  hold: {target: 1800}
""")
    assert (err.line, err.column) == (3, 22) and "force_hold.target_pa" in str(err)


def test_guided_slide_twist_key_from_yaml_follows_the_planner_every_tick():
    h = harness("root:\n  guided_slide: {twist_key: /planner/twist}\n")
    h.set("/planner/twist", [0.0, 0.01, 0.0, 0.0, 0.0, 0.0])
    h.tick()
    assert h.twist.tolist() == [0.0, 0.01, 0.0, 0.0, 0.0, 0.0]
    h.set("/planner/twist", np.array([0.02, 0.0, 0.0, 0.0, 0.0, 0.1]))
    h.tick()
    assert h.twist.tolist() == [0.02, 0.0, 0.0, 0.0, 0.0, 0.1]


def test_register_a_leaf_of_your_own(node_registry):
    from typing import Literal

    from tactile_bt.tree.behaviours import TactileBehaviour
    from tactile_bt.tree.declaration import Parameter
    from tactile_bt.tree.reference import describe_nodes
    from tactile_bt.tree.registry import register_node

    class Tap(TactileBehaviour):
        """Succeed on a tap."""

        force_n = Parameter(1.0, doc="Force that counts as a tap.")
        mode = Parameter("any", type=Literal["any", "all"], doc="How to count.")

        def update(self):
            return Status.SUCCESS if self.features_raw.force > self.force_n else Status.RUNNING

    register_node("tap", Tap)
    leaf = load_tree(FILE, text="root:\n  tap: {force_n: 500 mN, mode: all}\n").root
    assert isinstance(leaf, Tap) and leaf.force_n == 0.5 and leaf.mode == "all"
    err = load_error("root:\n  tap: {mode: sum}\n")
    assert err.line == 2 and "did you mean" not in str(err) and "valid: any, all" in str(err)
    assert "did you mean 'tap'" in str(load_error("root:\n  tapp: {}\n"))
    assert describe_nodes()["tap"].parameters[1].unit == "N"
    register_node("tap", Tap)  # the same class again (a module imported twice) is no clash

    class OtherTap(Tap):
        pass

    with pytest.raises(ValueError, match=r"'tap' of .*OtherTap clashes with 'tap' of .*Tap"):
        register_node("tap", OtherTap)
    with pytest.raises(ValueError, match=r"clashes with 'approach' of the built-in tactile_bt\.tree\.behaviours"):
        register_node("approach", OtherTap)


def test_guided_slide_twist_takes_units_per_element():
    """The linear part of a twist takes speeds (``30 mm/s``), the angular part angular rates."""
    h = harness("root:\n  guided_slide: {twist: [0, 30 mm/s, 0, 0, 0, 10 deg/s]}\n")
    h.tick()
    assert_allclose(h.twist, [0.0, 0.03, 0.0, 0.0, 0.0, np.deg2rad(10.0)])
    err = load_error("root:\n  guided_slide: {twist: [0, 0, 0, 30 mm/s, 0, 0]}\n")
    assert err.line == 2 and "unit 'mm/s' does not fit a value in rad/s" in str(err)
