"""The lean ticks (``tactile_bt.tree.composites``, ``TactileBehaviour.tick``, the decorators'
ticks, ``tactile_bt.mission.loop.tick`` and the direct ticks of ``tactile_bt.tree.ticking``)
behave exactly as py_trees' own: random trees of scripted leaves are built twice, once from
py_trees' classes and once from ours, ticked side by side, and every call on every node, every
status, every ``current_child`` and every feedback message must agree, as must the nodes a
visitor sees."""

from __future__ import annotations

import itertools

import py_trees
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import ParallelPolicy, Status

from tactile_bt.mission.loop import tick
from tactile_bt.tree.behaviours.base import TactileBehaviour
from tactile_bt.tree.behaviours.decorators import ONESHOT_POLICIES, Inverter, OneShot, Repeat, Retry
from tactile_bt.tree.behaviours.guards import MissionTimeout
from tactile_bt.tree.blackboard import TIME, write
from tactile_bt.tree.composites import Parallel, Selector, Sequence

TICKS = 10
STATUSES = [Status.RUNNING, Status.SUCCESS, Status.FAILURE]


class Scripted(TactileBehaviour):
    """A leaf that returns the statuses of its script in turn and logs every call."""

    def __init__(self, name, script, log):
        super().__init__(name)
        self.script, self.log = itertools.cycle(script), log

    def initialise(self):
        self.log.append((self.name, "initialise"))

    def update(self):
        self.log.append((self.name, "update"))
        self.feedback_message = f"update {len(self.log)}"  # for the decorators that pass it on
        return next(self.script)

    def terminate(self, new_status):
        self.log.append((self.name, "terminate", new_status))


class ScriptedReference(Scripted):
    tick = py_trees.behaviour.Behaviour.tick


class TimeoutReference(MissionTimeout):
    tick = py_trees.decorators.Decorator.tick


def leaves():
    return st.lists(st.sampled_from(STATUSES + ["bogus"]), min_size=1, max_size=4).map(lambda s: ("leaf", s))


def nodes():
    def extend(children):
        lists = st.lists(children, min_size=1, max_size=4)
        return st.one_of(
            st.tuples(st.just("parallel"), st.sampled_from(["all", "all_sync", "one", "selected"]),
                      st.integers(0, 3), lists),
            st.tuples(st.sampled_from(["sequence", "selector"]), st.booleans(), lists),
            st.tuples(st.just("timeout"), st.floats(0.01, 0.05), st.booleans(), children),
            st.tuples(st.sampled_from(["repeat", "retry"]), st.integers(1, 3), children),
            st.tuples(st.just("inverter"), children),
            st.tuples(st.just("oneshot"), st.sampled_from(["on_completion", "on_successful_completion"]), children),
        )
    return st.recursive(leaves(), extend, max_leaves=10)


def build(spec, ours: bool, log: list, counter=None):
    counter = counter if counter is not None else itertools.count()
    kind = spec[0]
    name = f"{kind}{next(counter)}"
    if kind == "leaf":
        return (Scripted if ours else ScriptedReference)(name, spec[1], log)
    if kind == "timeout":
        _, duration, succeed, child = spec
        cls = MissionTimeout if ours else TimeoutReference
        return cls(build(child, ours, log, counter), name=name, duration_s=duration, succeed=succeed)
    if kind in ("repeat", "retry"):
        _, count, child = spec
        built = build(child, ours, log, counter)
        if ours:
            return Repeat(built, name, count) if kind == "repeat" else Retry(built, name, count)
        cls = py_trees.decorators.Repeat if kind == "repeat" else py_trees.decorators.Retry
        return cls(name, built, count)
    if kind == "inverter":
        built = build(spec[1], ours, log, counter)
        return Inverter(built, name) if ours else py_trees.decorators.Inverter(name, built)
    if kind == "oneshot":
        _, policy, child = spec
        built = build(child, ours, log, counter)
        if ours:
            return OneShot(built, name, policy)
        return py_trees.decorators.OneShot(name, built, ONESHOT_POLICIES[policy])
    if kind in ("sequence", "selector"):
        _, memory, children = spec
        if ours:
            cls = Sequence if kind == "sequence" else Selector
        else:
            cls = py_trees.composites.Sequence if kind == "sequence" else py_trees.composites.Selector
        return cls(name, memory, [build(c, ours, log, counter) for c in children])
    _, policy, pick, children = spec
    kids = [build(c, ours, log, counter) for c in children]
    if policy == "all":
        chosen = ParallelPolicy.SuccessOnAll(synchronise=False)
    elif policy == "all_sync":
        chosen = ParallelPolicy.SuccessOnAll(synchronise=True)
    elif policy == "one":
        chosen = ParallelPolicy.SuccessOnOne()
    else:
        chosen = ParallelPolicy.SuccessOnSelected(children=kids[: 1 + pick % len(kids)], synchronise=pick % 2 == 0)
    cls = Parallel if ours else py_trees.composites.Parallel
    return cls(name, chosen, kids)


def snapshot(root):
    return [(n.name, n.status, getattr(getattr(n, "current_child", None), "name", None), n.feedback_message)
            for n in root.iterate()]


class Seen(py_trees.visitors.VisitorBase):
    """Every node a visitor is shown, in order, with its status at that moment."""

    def __init__(self):
        super().__init__(full=True)
        self.seen = []

    def run(self, behaviour):
        self.seen.append((behaviour.name, behaviour.status))


@settings(max_examples=300, deadline=None)
@given(nodes(), st.booleans())
def test_lean_ticks_match_py_trees(spec, with_visitor):
    log_ref, log_ours = [], []
    ref = py_trees.trees.BehaviourTree(build(spec, False, log_ref))
    ours = py_trees.trees.BehaviourTree(build(spec, True, log_ours))
    if with_visitor:  # the generators: every node shown to the visitor right after its tick
        ref.visitors.append(Seen())
        ours.visitors.append(Seen())
    for k in range(TICKS):
        write(TIME, 0.01 * k)
        ref.tick()
        tick(ours)
        assert log_ours == log_ref
        assert snapshot(ours.root) == snapshot(ref.root)
    assert ours.count == ref.count == TICKS
    if with_visitor:
        assert ours.visitors[0].seen == ref.visitors[0].seen


def test_debug_log_runs_py_trees_own_tick(monkeypatch):
    """With py_trees' debug log on, the lean ticks hand over to py_trees' (which logs)."""
    monkeypatch.setattr(py_trees.logging, "level", py_trees.logging.Level.DEBUG)
    lines = []
    monkeypatch.setattr(py_trees.console, "logdebug", lines.append)
    log = []
    write(TIME, 0.0)
    root = Parallel("p", ParallelPolicy.SuccessOnAll(), [Scripted("a", [Status.SUCCESS], log)])
    timeout = MissionTimeout(root, name="t", duration_s=1.0)
    for _ in timeout.tick():
        pass
    assert timeout.status == Status.SUCCESS
    assert any("Parallel.tick()" in line for line in lines)
    assert any("Scripted.tick()" in line for line in lines)
    assert any("MissionTimeout.tick()" in line for line in lines)


def test_tick_with_visitors_is_the_trees_own():
    """A tree with visitors or handlers is ticked by py_trees' BehaviourTree.tick."""
    log = []
    tree = py_trees.trees.BehaviourTree(Scripted("a", [Status.RUNNING], log))
    visitor = py_trees.visitors.SnapshotVisitor()
    tree.visitors.append(visitor)
    seen = []
    tree.add_post_tick_handler(lambda t: seen.append(t.count))
    tick(tree)
    tick(tree)
    assert seen == [0, 1] and tree.count == 2
    assert tree.root.id in visitor.visited


@pytest.mark.parametrize("bad", ["bogus", None])
def test_invalid_status_becomes_invalid(bad):
    log = []
    leaf = Scripted("a", [bad], log)
    ref = ScriptedReference("b", [bad], [])
    for node in (leaf, ref):
        for _ in node.tick():
            pass
    assert leaf.status == ref.status == Status.INVALID
