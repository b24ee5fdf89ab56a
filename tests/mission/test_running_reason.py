"""A mission whose time runs out says why, when its tree ends its task by itself."""

import py_trees
from py_trees.common import Status

from tactile_bt.mission.loop import running_reason, tick


class _Searching(py_trees.behaviour.Behaviour):
    reports_success = True  # a task that ends by itself, as frontier_guidance's scan

    def update(self):
        self.feedback_message = "sliding to the frontier"
        return Status.RUNNING


class _Holding(py_trees.behaviour.Behaviour):
    def update(self):
        self.feedback_message = "error pressure_pa=+64.3"
        return Status.RUNNING


def _ticked(*children):
    root = py_trees.composites.Parallel("root", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                        children=list(children))
    tree = py_trees.trees.BehaviourTree(root)
    tick(tree)
    return root


def test_a_task_still_running_when_the_time_runs_out_names_the_time_and_what_it_was_doing():
    root = _ticked(_Searching("frontier_guidance"), _Holding("force_hold"))
    assert running_reason(root, 600.0) == (
        "600 s of mission time ran out while frontier_guidance was running: sliding to the frontier")


def test_a_tree_that_runs_for_the_mission_s_time_ends_without_a_reason():
    assert running_reason(_ticked(_Holding("force_hold")), 1.5) == ""


def test_the_step_the_task_is_on_is_named_not_a_guard_running_beside_it():
    task = py_trees.composites.Sequence("task", memory=True, children=[_Searching("frontier_guidance")])
    step = py_trees.composites.Sequence("retry", memory=True, children=[_Holding("border_sweep")])
    root = _ticked(_Holding("adapt_force_target"), py_trees.composites.Parallel(
        "scan", policy=py_trees.common.ParallelPolicy.SuccessOnOne(), children=[task, step]))
    assert running_reason(root, 60.0).startswith("60 s of mission time ran out while frontier_guidance was running")


class _Scanning(_Searching):
    def standing(self):
        return "the scan so far: about 19 % of the surface untouched (38.2 cm² in valleys narrower than the pad)"


def test_what_the_task_had_achieved_follows_what_was_running_when_the_time_ran_out():
    # the scan had asked for a sweep: the sweep ran, and the scan's estimate says what is left
    task = py_trees.composites.Sequence("task", memory=True, children=[_Scanning("frontier_guidance")])
    step = py_trees.composites.Sequence("retry", memory=True, children=[_Holding("border_sweep")])
    root = _ticked(py_trees.composites.Parallel("scan", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                                children=[task, step]))
    reason = running_reason(root, 600.0)
    assert reason.startswith("600 s of mission time ran out while frontier_guidance was running")
    assert reason.endswith("; the scan so far: about 19 % of the surface untouched (38.2 cm² in valleys narrower "
                           "than the pad)")
