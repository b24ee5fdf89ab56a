"""The twin's shared state: what the physics writes, the devices read, whole, never waiting."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal

from tactile_bt.mission.twin_devices import SharedTwinState


def test_values_cross_whole_between_two_views_of_the_state():
    rng = np.random.default_rng(0)
    writer = SharedTwinState(16, 16, 7)
    reader = SharedTwinState(16, 16, 7, name=writer.name)
    try:
        for _ in range(5):
            T, q = rng.normal(size=(4, 4)), rng.normal(size=7)
            raw = rng.integers(0, 4096, size=(16, 16), dtype=np.uint16)
            writer.put_pose(T, q)
            writer.put_frame(raw)
            got_T, got_q = reader.get_pose()
            assert_array_equal(got_T, T)
            assert_array_equal(got_q, q)
            assert_array_equal(reader.get_frame(), raw)
        assert reader.get_twist()[2] == 0  # no twist yet
        writer.put_twist(np.arange(6.0), 12.5)
        writer.put_twist(np.ones(6), 13.0)
        twist, when, count = reader.get_twist()
        assert_array_equal(twist, np.ones(6)) and when == 13.0 and count == 2
    finally:
        reader.close()
        writer.close(unlink=True)


def test_a_reader_is_never_held_by_a_write_in_progress():
    """The writer fills the other buffer: what a reader sees is the last whole value."""
    state = SharedTwinState(4, 4, 0)
    try:
        state.put_frame(np.full((4, 4), 7, dtype=np.uint16))
        spare = 1 - int(state._views["headers"][2, 0])
        state._views["frame"][spare][:2] = 9  # a write stopped halfway, as if preempted
        assert_array_equal(state.get_frame(), np.full((4, 4), 7))
    finally:
        state.close(unlink=True)
