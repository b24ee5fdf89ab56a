"""Forces the object can carry: the contact stiffness estimated from pressure against the pad's
travel, the pressure target lowered where the object cannot carry it, and force_hold following
the adapted target every cycle."""

import math

import numpy as np
import pytest
from py_trees.common import Status

from tactile_bt import defaults
from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, fresh_blackboard, make_features
from tactile_bt.tree.behaviours import AdaptForceTarget, ForceHold
from tactile_bt.tree.behaviours.stiffness import FORCE_TARGET_KEY, STIFFNESS_KEY, ContactStiffness, carried_target
from tactile_bt.tree.blackboard import read_or

DT = 1.0 / defaults.RATE_HZ
#: The pad facing down (sensor z = world -z), as in the scenes' ``rpy_deg: [180, 0, 0]``.
DOWN = np.diag([1.0, -1.0, -1.0])


@pytest.fixture(autouse=True)
def _blackboard():
    with fresh_blackboard():
        yield


def pad_at(height_m: float) -> np.ndarray:
    return make_pose(DOWN, (0.0, 0.0, height_m))


def press(harness, surface_m: float, stiffness_pa_per_m: float, onset_pa: float = 350.0, speed_mps: float = 0.01,
          seconds: float = 0.5, start_m: float = 0.001) -> None:
    """Drive the pad down at ``speed_mps`` from ``start_m`` above a surface at ``surface_m``
    (world z) whose contact shows ``onset_pa + k·indentation``."""
    for k in range(int(round(seconds / DT))):
        z = surface_m + start_m - speed_mps * k * DT
        depth = surface_m - z
        harness.set_pose(pad_at(z))
        if depth <= 0.0:
            status = harness.tick(make_features(in_contact=False))
        else:
            status = harness.tick(make_features(pressure=onset_pa + stiffness_pa_per_m * depth))
        if status == Status.FAILURE:
            return


def test_a_contact_lost_before_it_was_loaded_leaves_the_estimate_of_the_last_loaded_one():
    est = ContactStiffness(min_travel_m=0.2e-3, min_rise_pa=100.0)
    for i in range(20):  # a stiff contact, loaded
        est.update(True, 300.0 + 2e6 * 1e-4 * i, pad_at(0.01 - 1e-4 * i), loaded_pa=1800.0)
    assert not est.loading and est.stiffness_pa_per_m == pytest.approx(2e6)
    est.update(False, 0.0, pad_at(0.02), loaded_pa=1800.0)
    for i in range(20):  # a contact fading at an edge while the pad moves on: looks soft
        est.update(True, 330.0 + 1e4 * 1e-4 * i + (150.0 if i > 5 else 0.0), pad_at(0.02 - 1e-4 * i), loaded_pa=1800.0)
    assert est.loading and est.stiffness_pa_per_m < 1e6
    est.update(False, 0.0, pad_at(0.03), loaded_pa=1800.0)  # lost before it was loaded
    assert est.stiffness_pa_per_m == pytest.approx(2e6)


def test_the_secant_of_a_loaded_contact_is_its_stiffness_and_is_held_once_loaded():
    est = ContactStiffness(min_travel_m=0.2e-3)
    k = 4e5
    for i in range(60):  # 0.1 mm a cycle along the pad normal (world -z)
        d = 1e-4 * i
        est.update(True, 300.0 + k * d, pad_at(0.01 - d), loaded_pa=math.inf)
    assert est.stiffness_pa_per_m == pytest.approx(k, rel=1e-6)
    assert est.indentation_m == pytest.approx(59e-4)
    est.update(True, 300.0 + k * 6e-3, pad_at(0.01 - 6e-3), loaded_pa=1000.0)  # loaded: held from now on
    est.update(True, 5000.0, pad_at(0.0), loaded_pa=1000.0)
    assert est.stiffness_pa_per_m == pytest.approx(k, rel=1e-6)
    est.update(False, 0.0, pad_at(0.02), loaded_pa=1000.0)  # a new contact estimates afresh
    assert est.update(True, 400.0, pad_at(0.02), loaded_pa=1000.0) and est.loading


def test_turning_about_a_contact_at_the_pad_s_corner_is_no_indentation():
    # the pad lands on its corner (35, 35) mm and rolls about it: its centre travels along the
    # normal by millimetres, the pad's point at the contact not at all
    from scipy.spatial.transform import Rotation

    corner = np.array([0.035, 0.035, 0.0])
    est = ContactStiffness(min_travel_m=0.2e-3, min_rise_pa=100.0)
    contact_world = np.array([0.0, 0.0, 0.02])
    for i in range(40):
        R = DOWN @ Rotation.from_rotvec([0.004 * i, -0.004 * i, 0.0]).as_matrix()
        pose = make_pose(R, contact_world - R @ corner)  # the corner stays where it touches
        est.update(True, 400.0, pose, loaded_pa=1800.0, cop_xy=(corner[0], corner[1]))
    centre_travel = abs(float(DOWN[:, 2] @ ((contact_world - R @ corner) - (contact_world - DOWN @ corner))))
    assert centre_travel > 1e-3
    assert abs(est.indentation_m) < 1e-9


def test_the_target_is_lowered_only_where_the_object_cannot_carry_it():
    # 1 mm of give at half share: a soft object carries 300 + 4e5 * 0.5e-3 = 500 Pa
    assert carried_target(2000.0, 400.0, 4e5, 300.0, 1e-3, 0.5) == pytest.approx(500.0)
    assert carried_target(2000.0, 600.0, 4e5, 300.0, 1e-3, 0.5) == 600.0  # never below the floor
    assert carried_target(2000.0, 400.0, 1e8, 300.0, 1e-3, 0.5) == 2000.0  # a stiff object: unchanged
    assert carried_target(2000.0, 400.0, math.nan, 300.0, 1e-3, 0.5) == 2000.0  # unknown: unchanged


def test_on_a_soft_thin_object_on_the_table_the_leaf_lowers_the_target_within_its_bounds():
    harness = LeafHarness(AdaptForceTarget(target_pa=2000.0, floor_pa=500.0, give_share=0.5))
    harness.set("/setup/table_z_m", 0.0)
    press(harness, surface_m=0.002, stiffness_pa_per_m=3e5)  # a 2 mm cable of 3e5 Pa/m
    target = read_or(FORCE_TARGET_KEY)
    assert read_or(STIFFNESS_KEY) == pytest.approx(3e5, rel=0.05)
    # half of the 2 mm the cable gives above the table: 350 + 3e5 * 1 mm = 650 Pa
    assert target == pytest.approx(650.0, rel=0.05)
    assert 500.0 <= target < 2000.0
    assert "target 6" in harness.behaviour.feedback_message


def test_on_a_stiff_object_the_target_stays():
    harness = LeafHarness(AdaptForceTarget(target_pa=2000.0))
    harness.set("/setup/table_z_m", 0.0)
    press(harness, surface_m=0.05, stiffness_pa_per_m=2e7)
    assert read_or(FORCE_TARGET_KEY) == 2000.0


def test_force_hold_follows_the_target_key_every_cycle():
    hold = ForceHold(target_pa=2000.0, target_key=FORCE_TARGET_KEY)
    harness = LeafHarness(hold)
    harness.set(FORCE_TARGET_KEY, 2000.0)
    harness.tick(make_features(pressure=1000.0))
    assert harness.command.twist()[2] > 0  # below the target: press
    harness.set(FORCE_TARGET_KEY, 600.0)  # lowered while the leaf runs
    harness.tick(make_features(pressure=1000.0))
    assert harness.command.twist()[2] < 0  # now above it: back off
    assert harness.command.errors["pressure_pa"] == pytest.approx(400.0)
    harness.set(FORCE_TARGET_KEY, None)  # no number: its own target_pa
    assert hold.current_target() == 2000.0


def test_an_object_that_cannot_carry_the_floor_fails_the_leaf_and_says_so():
    harness = LeafHarness(AdaptForceTarget(target_pa=2000.0, floor_pa=500.0, give_share=0.5))
    harness.set("/setup/table_z_m", 0.0)
    press(harness, surface_m=0.002, stiffness_pa_per_m=5e4, seconds=0.25)  # 1 mm in: 400 Pa
    assert harness.behaviour.status == Status.FAILURE
    message = harness.behaviour.feedback_message
    assert message.startswith("too soft to carry 500 Pa: 40") and "Pa after 1.00 mm" in message
    assert "50% of the 1.9" in message  # the 2 mm cable, touched a little in
    relaxed = LeafHarness(AdaptForceTarget(target_pa=2000.0, floor_pa=500.0, fail_below_floor=False))
    relaxed.set("/setup/table_z_m", 0.0)
    press(relaxed, surface_m=0.002, stiffness_pa_per_m=5e4, seconds=0.25)
    assert relaxed.behaviour.status != Status.FAILURE and read_or(FORCE_TARGET_KEY) == 500.0
