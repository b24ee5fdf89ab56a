"""record_contacts records only a settled contact: one region, the pressure near its (adapted)
target, the pad not pressing in; of an imprint only the points pressed within the limit."""

import numpy as np
import pytest

from tactile_bt import defaults
from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, fresh_blackboard, make_features
from tactile_bt.tree.behaviours import RecordContacts
from tactile_bt.tree.behaviours.stiffness import FORCE_TARGET_KEY

DT = 1.0 / defaults.RATE_HZ
DOWN = np.diag([1.0, -1.0, -1.0])  # sensor z = world -z: into an object below


@pytest.fixture(autouse=True)
def _blackboard():
    with fresh_blackboard():
        yield


def blob(image: np.ndarray, row: int, col: int, force_n: float) -> None:
    """A 3x3 contact of ``force_n`` newtons centred on tactel (row, col)."""
    image[row - 1:row + 2, col - 1:col + 2] += force_n / 9.0


def test_a_contact_pressed_far_above_its_target_is_not_recorded_and_the_adapted_target_counts():
    h = LeafHarness(RecordContacts(), dt=DT)
    h.tick(make_features(pressure=3900.0))
    assert len(h.contacts) == 1  # within twice the 2 kPa default
    h.tick(make_features(pressure=4100.0))
    assert len(h.contacts) == 1
    assert "not recording (pressure 4100 Pa above 2 x 2000 Pa)" in h.behaviour.feedback_message
    h.set(FORCE_TARGET_KEY, 500.0)  # a soft object: the target was lowered
    h.tick(make_features(pressure=1500.0))
    assert len(h.contacts) == 1 and h.behaviour.skipped == 2
    h.tick(make_features(pressure=600.0))
    assert len(h.contacts) == 2


def test_a_pad_bridging_a_hollow_records_nothing():
    h = LeafHarness(RecordContacts(), dt=DT)
    image = np.zeros((16, 16))
    blob(image, 7, 2, 0.5)  # 2.2 kPa
    h.tick(frame=image)
    assert len(h.contacts) == 1  # one region
    blob(image, 7, 13, 0.4)  # a second contact at the other border
    h.tick(frame=image)
    assert len(h.contacts) == 1
    assert "second region" in h.behaviour.feedback_message


def test_a_pad_still_moving_into_the_object_records_nothing():
    h = LeafHarness(RecordContacts(max_approach_mps=0.01), dt=DT)
    z = 0.05

    def run(speed_mps: float, cycles: int) -> int:
        """Cycles recorded while the pad moves along its normal (world -z) at ``speed_mps``."""
        nonlocal z
        before = len(h.contacts)
        for _ in range(cycles):
            z -= speed_mps * DT
            h.set_pose(make_pose(DOWN, (0.0, 0.0, z)))
            h.tick(make_features())
        return len(h.contacts) - before

    assert run(0.005, 50) == 50  # slower than the limit: every cycle
    pressing = run(0.03, 50)
    assert pressing < 10  # 30 mm/s into the object: nothing once the averaged speed passes 10 mm/s
    assert "pressing in at" in h.behaviour.feedback_message
    assert run(-0.03, 50) > 40  # backing off records again
