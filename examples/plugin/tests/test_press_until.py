"""Tests of the press_until leaf, ticked alone on tactile_bt's testing kit."""

import numpy as np
from py_trees.common import Status

from tactile_bt.testing import LeafHarness, make_features
from tactile_bt_press import PressUntil


def test_it_presses_along_the_normal_until_the_target_pressure():
    harness = LeafHarness(PressUntil(target_pa=3000.0, speed_mps=0.002))
    assert harness.tick(make_features(pressure=1000.0)) == Status.RUNNING
    np.testing.assert_allclose(harness.twist, [0, 0, 0.002, 0, 0, 0])
    assert harness.tick(make_features(pressure=3100.0)) == Status.SUCCESS
    np.testing.assert_allclose(harness.twist, np.zeros(6))


def test_it_fails_when_the_target_is_not_reached_in_time():
    harness = LeafHarness(PressUntil(target_pa=3000.0, timeout_s=0.1))
    status = harness.tick_for(1.0, features=make_features(pressure=1000.0))
    assert status == Status.FAILURE
    assert "not reached within 0.1 s" in harness.behaviour.feedback_message


def test_it_fails_when_contact_is_lost_after_it_was_made():
    harness = LeafHarness(PressUntil())
    harness.tick(make_features(pressure=1000.0))
    assert harness.tick(make_features(in_contact=False)) == Status.FAILURE
