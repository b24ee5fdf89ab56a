"""The end-of-surface condition leaves: each sign of the end of the surface under a sliding pad,
alone, in a stripe's composite and for a planner (``end_key``)."""

import math

import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, make_features
from tactile_bt.perception.synthetic import line_contact
from tactile_bt.tree.behaviours import (ContactBridged, ContactJumped, ContactShrank, ContactStalled, PadTurned,
                                        RollingOverEdge, TiltLimit)
from scan_helpers import ticks_until_done

DT = 1.0 / 250.0
DOWN = Rotation.from_euler("x", 180, degrees=True)  # pad facing down: x_s = x_g, y_s = -y_g


def pose(rotation: Rotation, position) -> np.ndarray:
    return make_pose(rotation, np.asarray(position, dtype=float))


def test_contact_stalled():
    h = LeafHarness(ContactStalled(window_s=0.5, min_travel_m=0.004), dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    statuses = [h.tick(make_features()) for _ in range(int(0.5 / DT) + 1)]
    assert statuses[:-1] == [Status.RUNNING] * int(0.5 / DT)  # not before the window is full
    assert statuses[-1] == Status.SUCCESS
    assert "stalled" in h.behaviour.feedback_message


def test_contact_stalled_keeps_running_while_the_contact_moves():
    leaf = ContactStalled(window_s=0.5, min_travel_m=0.004, result="failure")
    h = LeafHarness(leaf, dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    for k in range(300):  # 20 mm/s for 1.2 s
        h.set_pose(make_pose(DOWN, (0.02 * k * DT, 0, 0)))
        assert h.tick(make_features()) == Status.RUNNING
    assert leaf.travelled == pytest.approx(0.02 * 299 * DT)
    # now it stops: FAILURE (as asked) once the last 0.5 s hold less than 4 mm, i.e. 0.3 s later
    k, status = ticks_until_done(h, 200)
    assert status == Status.FAILURE and k * DT == pytest.approx(0.3, abs=0.01)


def _rims(left_share: float) -> np.ndarray:
    """A flat pad on the two rims of a hollow: line contacts along its two borders (x = 1 and
    14 tactels, 65 mm apart), ``left_share`` of 3 N on the left one."""
    return (line_contact((1.0, 7.5), math.pi / 2, 12.0, 0.8, 3.0 * left_share)
            + line_contact((14.0, 7.5), math.pi / 2, 12.0, 0.8, 3.0 * (1.0 - left_share)))


def test_contact_bridged_after_the_window_of_two_contacts_though_the_largest_changes_sides():
    h = LeafHarness(ContactBridged(window_s=0.5), dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    statuses = []
    for k in range(int(0.5 / DT) + 1):
        # the load rocks from one rim to the other, and one frame in 25 sees the right rim alone
        frame = _rims(1e-6) if k % 25 == 24 else _rims(0.45 if (k // 10) % 2 else 0.55)
        statuses.append(h.tick(frame=frame))
    assert set(statuses[:int(0.5 / DT)]) == {Status.RUNNING}
    assert statuses[-1] == Status.SUCCESS
    assert "bridging two contacts 65 mm apart" in h.behaviour.feedback_message
    # the largest region's centre jumped 65 mm at each change of sides: it "travelled" far
    assert h.behaviour.travelled > 0.5


@pytest.mark.parametrize("left_share", [0.0, 0.1])
def test_contact_bridged_not_on_one_contact_or_a_light_second_one(left_share):
    h = LeafHarness(ContactBridged(window_s=0.5, min_share=0.2), dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    frame = _rims(left_share) if left_share else line_contact((14.0, 7.5), math.pi / 2, 12.0, 0.8, 3.0)
    assert {h.tick(frame=frame) for _ in range(int(1.0 / DT))} == {Status.RUNNING}


def test_tilt_limit_on_tilt_but_not_for_a_stripe_that_starts_tilted_and_rolls_back():
    def tilted(deg):
        return make_pose(Rotation.from_euler("y", deg, degrees=True) * DOWN, (0, 0, 0))

    h = LeafHarness(TiltLimit(window_s=0.0, max_tilt_rad=math.radians(60)), dt=DT, pose=tilted(0))
    for deg in (0, 30, 59):
        h.set_pose(tilted(deg))
        assert h.tick(make_features()) == Status.RUNNING
    h.set_pose(tilted(61))
    assert h.tick(make_features()) == Status.SUCCESS
    # starts at 65° (after the previous stripe), rolls back over the top and down the other side
    py_trees.blackboard.Blackboard.clear()
    h = LeafHarness(TiltLimit(window_s=0.0, max_tilt_rad=math.radians(60)), dt=DT, pose=tilted(65))
    for deg in (65, 66, 40, 0, -30, -59):
        h.set_pose(tilted(deg))
        assert h.tick(make_features()) == Status.RUNNING
    h.set_pose(tilted(-61))
    assert h.tick(make_features()) == Status.SUCCESS


def test_the_end_of_a_stripe_that_starts_tilted_and_stays_so_or_turns_over_an_edge():
    def tilted(deg):
        return make_pose(Rotation.from_euler("y", deg, degrees=True) * DOWN, (0, 0, 0))

    # on a vertical face beyond the 60° limit, not coming back: ends after window_s
    h = LeafHarness(TiltLimit(window_s=0.5, max_tilt_rad=math.radians(60)), dt=DT, pose=tilted(85))
    k, status = ticks_until_done(h, 500)
    assert status == Status.SUCCESS and k == pytest.approx(0.5 / DT, abs=1)
    assert "stayed beyond" in h.behaviour.feedback_message
    # a step that rolls the pad over an edge: the normal turns 45° from where it started
    py_trees.blackboard.Blackboard.clear()
    h = LeafHarness(PadTurned(max_turn_rad=math.radians(45), result="failure"), dt=DT, pose=tilted(70))
    for deg in (70, 80, 100, 114):
        h.set_pose(tilted(deg))
        assert h.tick(make_features()) == Status.RUNNING
    h.set_pose(tilted(116))
    assert h.tick(make_features()) == Status.FAILURE
    assert "turned 46°" in h.behaviour.feedback_message


def test_the_end_when_the_contact_shrinks_or_jumps():
    h = LeafHarness(ContactShrank(window_s=0.5, min_area_ratio=0.5), dt=DT,
                    pose=make_pose(DOWN, (0, 0, 0)))
    for _ in range(10):
        assert h.tick(make_features(area=200)) == Status.RUNNING
    k, status = ticks_until_done(h, 100, area=90)  # below half of 200 for window_s / 5 = 0.1 s
    assert status == Status.SUCCESS and k == pytest.approx(0.1 / DT, abs=1)
    py_trees.blackboard.Blackboard.clear()
    h = LeafHarness(ContactJumped(max_jump_m=0.01), dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    assert h.tick(make_features(cop_px=(7.5, 7.5))) == Status.RUNNING
    assert h.tick(make_features(cop_px=(8.5, 7.5))) == Status.RUNNING   # 5 mm
    assert h.tick(make_features(cop_px=(14.5, 7.5))) == Status.SUCCESS  # 30 mm: another object
    assert "jumped" in h.behaviour.feedback_message


def rolled(deg: float, axis_point, about="y") -> np.ndarray:
    """The pad facing down, rolled ``deg`` about a world line through ``axis_point``."""
    R = Rotation.from_euler(about, deg, degrees=True)
    centre = R.apply(-np.asarray(axis_point)) + axis_point
    return pose(R * DOWN, centre)


def test_rolling_over_edge_knows_rolling_over_an_edge_from_rolling_round_a_curve():
    # over an edge: the pad turns about the edge line at x = 20 mm on its surface, the contact
    # (the edge) stays put in the world
    leaf = RollingOverEdge(window_s=1.0, edge_turn_rad=math.radians(10), edge_radius_m=0.01)
    h = LeafHarness(leaf)
    status = Status.RUNNING
    for k in range(250):
        deg = 20.0 * k / 250
        h.set_pose(rolled(deg, (0.02, 0.0, 0.0)))
        # the contact sits on the edge: at x = 20 mm on the pad
        status = h.tick(make_features(cop_px=(11.5, 7.5)))
        if status != Status.RUNNING:
            break
    assert status == Status.SUCCESS and leaf.cause == "edge"
    assert 10 <= deg < 12
    # round a cylinder of radius 50 mm: the contact moves R·θ as the pad turns
    leaf = RollingOverEdge(window_s=1.0, edge_turn_rad=math.radians(10), edge_radius_m=0.01)
    h = LeafHarness(leaf)
    for k in range(250):
        theta = math.radians(30.0 * k / 250)
        R = Rotation.from_euler("y", theta)
        h.set_pose(pose(R * DOWN, (0.05 * math.sin(theta), 0.0, 0.05 * math.cos(theta))))
        assert h.tick(make_features()) == Status.RUNNING
    # rolling back from an edge onto the face (the tilt shrinks) is no end either
    leaf = RollingOverEdge(window_s=1.0, edge_turn_rad=math.radians(10), edge_radius_m=0.01)
    h = LeafHarness(leaf)
    for k in range(250):
        h.set_pose(rolled(30.0 - 25.0 * k / 250, (0.02, 0.0, 0.0)))
        assert h.tick(make_features(cop_px=(11.5, 7.5))) == Status.RUNNING




def test_with_the_table_known_only_a_jump_onto_it_ends():
    h = LeafHarness(ContactJumped(max_jump_m=0.01, table_key="/setup/table_z_m"), dt=DT,
                    pose=make_pose(DOWN, (0, 0, 0.05)))
    h.set("/setup/table_z_m", 0.0)
    assert h.tick(make_features(cop_px=(7.5, 7.5))) == Status.RUNNING
    assert h.tick(make_features(cop_px=(14.5, 7.5))) == Status.RUNNING  # 35 mm, but 50 mm above the table
    h.set_pose(make_pose(DOWN, (0.035, 0, 0.001)))
    assert h.tick(make_features(cop_px=(7.5, 7.5))) == Status.SUCCESS  # 49 mm down, onto the table
    assert "jumped" in h.behaviour.feedback_message


def test_for_a_planner_the_end_is_written_once_per_attempt_and_the_leaf_starts_over_with_the_next():
    leaf = ContactStalled(window_s=0.2, min_travel_m=0.004, end_key="/scan/attempt_end")
    h = LeafHarness(leaf, dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    h.set("/scan/attempt", 1)
    for _ in range(int(0.2 / DT) + 5):
        assert h.tick(make_features()) == Status.RUNNING  # never ends: the planner decides
    end = py_trees.blackboard.Blackboard.storage["/scan/attempt_end"]
    assert end["attempt"] == 1 and end["cause"] == "stall" and end["message"].startswith("stalled")
    h.set("/scan/attempt", 2)  # a new attempt: the window starts again
    for _ in range(int(0.2 / DT) - 2):
        h.tick(make_features())
    assert py_trees.blackboard.Blackboard.storage["/scan/attempt_end"]["attempt"] == 1
    for _ in range(5):
        h.tick(make_features())
    assert py_trees.blackboard.Blackboard.storage["/scan/attempt_end"]["attempt"] == 2


def test_no_stall_while_the_pad_rolls_over_an_edge_towards_the_tilt_limit():
    # the contact stays on the edge line (x = 20 mm) while the pad rolls 10°/s about it
    def rolled(deg):
        R = Rotation.from_euler("y", deg, degrees=True)
        axis = np.array([0.02, 0.0, 0.0])
        return make_pose(R * DOWN, R.apply(-axis) + axis)

    rolling = ContactStalled(window_s=0.5, min_travel_m=0.004, rolling_turn_rad=math.radians(3))
    plain = ContactStalled(window_s=0.5, min_travel_m=0.004)
    for leaf, expected in ((rolling, Status.RUNNING), (plain, Status.SUCCESS)):
        py_trees.blackboard.Blackboard.clear()
        h = LeafHarness(leaf, dt=DT, pose=rolled(0))
        status = Status.RUNNING
        for k in range(250):
            h.set_pose(rolled(10.0 * k * DT))
            status = h.tick(make_features(cop_px=(11.5, 7.5)))
            if status != Status.RUNNING:
                break
        assert status == expected
