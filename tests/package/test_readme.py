"""The user test shown in README.md, verbatim: it must keep passing."""

from tactile_bt.tree.behaviours import ForceHold
from tactile_bt.testing import LeafHarness, make_features


def test_force_hold_presses_when_too_light():
    h = LeafHarness(ForceHold(target_pa=2000))
    assert h.tick(make_features(pressure=1500)).name == "RUNNING"
    assert h.twist[2] > 0          # +z of the sensor frame, towards the object
    assert h.errors["pressure_pa"] == -500
