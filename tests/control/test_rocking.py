"""RockingDetector: a pad whose largest contact region changes sides again and again, another
region under it, rocks; one change, a jump without another region, or small moves do not."""

import numpy as np

from tactile_bt import defaults
from tactile_bt.control.chatter import RockingDetector

DT = 1.0 / defaults.RATE_HZ
WIDTH = 0.08
LEFT, RIGHT = (-0.035, -0.035), (0.035, 0.035)  # two opposite corners of an 80 mm pad (m)


def detector(hold_s=0.3):
    return RockingDetector(defaults.ROCKING_JUMP_SHARE, defaults.ROCKING_CHANGES, defaults.ROCKING_WINDOW_S, hold_s)


def feed(det, cops, t0=0.0, others=True, in_contact=True):
    """Whether it rocks after each cycle of ``cops`` (m, one a cycle from ``t0``)."""
    return [det.update(t0 + k * DT, in_contact, cop, others, WIDTH) for k, cop in enumerate(cops)]


def test_a_contact_changing_sides_twice_within_the_window_rocks_until_the_hold_is_over():
    det = detector()
    cops = [LEFT] * 15 + [RIGHT] * 15 + [LEFT] * 15   # sides changed at cycles 15 and 30
    rocks = feed(det, cops)
    assert not any(rocks[:30]) and all(rocks[30:])
    # then one region only, steady: rocking while both changes lie within 0.5 s, and 0.3 s after
    t0 = len(cops) * DT
    later = feed(det, [LEFT] * 250, t0=t0, others=False)
    quiet = t0 + DT * np.flatnonzero(~np.array(later))[0]
    assert abs(quiet - (15 * DT + defaults.ROCKING_WINDOW_S + 0.3)) <= 2 * DT


def test_one_change_of_sides_is_no_rocking():
    assert not any(feed(detector(), [LEFT] * 20 + [RIGHT] * 200))


def test_changes_too_far_apart_are_no_rocking():
    gap = int(1.2 * defaults.ROCKING_WINDOW_S / DT)
    assert not any(feed(detector(), [LEFT] * gap + [RIGHT] * gap + [LEFT] * gap + [RIGHT] * gap))


def test_without_another_region_under_the_pad_a_jumping_contact_is_no_rocking():
    """A contact that jumps onto another object (the table) does not rock the pad."""
    assert not any(feed(detector(), [LEFT, RIGHT] * 50, others=False))


def test_a_contact_moving_less_than_half_the_pad_s_width_is_no_rocking():
    near = (LEFT[0] + 0.035, LEFT[1])  # 35 mm away: less than 40 mm
    assert not any(feed(detector(), [LEFT, near] * 50))


def test_a_lost_contact_is_no_change_of_sides():
    det = detector()
    rocks = [det.update(k * DT, k % 2 == 0, LEFT if k % 4 == 0 else RIGHT, True, WIDTH) for k in range(100)]
    assert not any(rocks)
