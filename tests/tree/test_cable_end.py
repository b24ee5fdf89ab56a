"""The end of a cable, found by touch, and a lost line told apart from it: `cable_end` on scripted
tactile frames, and the cable tree ending by itself on a short simulated cable whatever its
budget."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from py_trees.common import Status

from tactile_bt import run_mission
from tactile_bt.testing import LeafHarness, contact_frame
from tactile_bt.tree.behaviours import CableEnd
from tactile_bt.tree.blackboard import read

ROOT = Path(__file__).resolve().parents[2]
DT = 1.0 / 250.0
CENTRE = (7.5, 7.5)


def cable_frame(length_px=20.0, cop_px=CENTRE, angle=math.pi / 2, force_n=2.0):
    """A line through ``cop_px`` along ``angle``, as long as ``length_px`` (clipped by the pad)."""
    return contact_frame(cop_px=cop_px, force_n=force_n, orientation_rad=angle, length_px=length_px, width_px=2.5)


def run(h, frame, seconds):
    status = Status.RUNNING
    for _ in range(int(round(seconds / DT))):
        status = h.tick(frame=frame)
        if status != Status.RUNNING:
            break
    return status


def test_a_line_across_the_pad_is_followed_and_recorded():
    h = LeafHarness(CableEnd(), dt=DT)
    assert run(h, cable_frame(), 1.0) == Status.RUNNING
    assert read("/cable/on_line") is True
    assert h.behaviour.reach_px >= 7.5


def test_a_line_that_ends_inside_the_pad_is_the_end():
    h = LeafHarness(CableEnd(), dt=DT)
    run(h, cable_frame(), 0.2)
    assert run(h, cable_frame(length_px=8.0, cop_px=(7.5, 3.5)), 0.5) == Status.SUCCESS
    assert "the line ends inside the pad" in h.behaviour.feedback_message
    assert read("/cable/on_line") is False


@pytest.mark.parametrize("after", [contact_frame(force_n=6.0, length_px=0.0, width_px=6.0), np.zeros((16, 16))])
def test_the_table_or_no_contact_right_after_the_end_was_in_view_is_the_end(after):
    """Past the end the pad tips onto the table (a patch) or leaves the cable: the end, since the
    line's end was seen inside the pad just before."""
    h = LeafHarness(CableEnd(), dt=DT)
    run(h, cable_frame(), 0.2)
    run(h, cable_frame(length_px=12.0, cop_px=(7.5, 5.5)), 0.05)  # the end 6 px ahead: in view
    assert run(h, after, 0.5) == Status.SUCCESS
    assert "end of cable" in h.behaviour.feedback_message


@pytest.mark.parametrize("frame, reason", [
    # a broad patch where a line was: flattened, or the pad on the table without an end in view
    (contact_frame(force_n=6.0, length_px=0.0, width_px=6.0), "flattened into a patch"),
    # a line along the pad's side border, far from the centre
    (cable_frame(cop_px=(14.0, 7.5)), "another line"),
    # a line across the travel: the cable turned away
    (cable_frame(angle=0.0), "turned away"),
    # no contact any more
    (np.zeros((16, 16)), "contact ended"),
])
def test_leaving_the_line_without_its_end_in_view_is_a_loss(frame, reason):
    h = LeafHarness(CableEnd(), dt=DT)
    run(h, cable_frame(), 0.2)
    assert run(h, frame, 0.5) == Status.FAILURE
    message = h.behaviour.feedback_message
    assert message.startswith("cable lost: ") and reason in message, message
    assert "mm along the path" in message
    assert read("/cable/lost").what in message


def test_a_line_that_slides_out_sideways_is_lost_never_the_end():
    """The line drifts across the pad to its border and out: FAILURE, never SUCCESS."""
    h = LeafHarness(CableEnd(), dt=DT)
    run(h, cable_frame(), 0.2)
    status = Status.RUNNING
    for k in range(250):  # 1 s, 8 px sideways
        status = h.tick(frame=cable_frame(cop_px=(7.5 + 8.0 * k / 250, 7.5)))
        assert status != Status.SUCCESS
        if status != Status.RUNNING:
            break
    if status == Status.RUNNING:
        status = run(h, np.zeros((16, 16)), 0.5)
    assert status == Status.FAILURE
    assert "the line left the pad sideways" in h.behaviour.feedback_message


def test_the_end_is_seen_with_a_real_sensors_jittered_frame_times():
    """Frames of a live sensor come 4 ms apart give or take a millisecond: the verdict still
    needs dwell_s of judging, not a window whose oldest frame is exactly dwell_s old."""
    rng = np.random.default_rng(3)
    h = LeafHarness(CableEnd(dwell_s=0.1), dt=DT)
    short = cable_frame(length_px=8.0, cop_px=(7.5, 3.5))
    status, elapsed = Status.RUNNING, 0.0
    for k in range(200):
        h.dt = DT * rng.uniform(0.75, 1.25)
        status = h.tick(frame=cable_frame() if k < 50 else short)
        elapsed += h.dt if k >= 50 else 0.0
        if status != Status.RUNNING:
            break
    assert status == Status.SUCCESS and "ends inside the pad" in h.behaviour.feedback_message
    assert elapsed < 0.2  # dwell_s of short-line frames and a few more, not never


def test_one_odd_frame_decides_nothing():
    h = LeafHarness(CableEnd(dwell_s=0.1), dt=DT)
    run(h, cable_frame(), 0.2)
    odd = cable_frame(angle=0.0)
    for _ in range(5):  # 20 ms of a crossing line in 100 ms of cable
        assert h.tick(frame=odd) == Status.RUNNING
        for _ in range(4):
            assert h.tick(frame=cable_frame()) == Status.RUNNING


def test_contact_lost_for_a_moment_decides_nothing():
    h = LeafHarness(CableEnd(lost_s=0.3), dt=DT)
    run(h, cable_frame(), 0.2)
    assert run(h, np.zeros((16, 16)), 0.25) == Status.RUNNING
    assert run(h, cable_frame(), 0.2) == Status.RUNNING


def test_travel_along_another_direction():
    """With travel along +x, a line along y is the wrong one and a line along x is followed."""
    h = LeafHarness(CableEnd(direction_rad=0.0), dt=DT)
    assert run(h, cable_frame(angle=0.0), 0.5) == Status.RUNNING
    assert run(h, cable_frame(angle=math.pi / 2), 0.5) == Status.FAILURE


def test_the_followed_line_is_the_region_extraction_keeps():
    """With another, larger line beside the followed one, the region hint keeps the followed one;
    the pressure is then the pad's whole load."""
    from tactile_bt import defaults
    from tactile_bt.perception.features import extract

    h = LeafHarness(CableEnd(), dt=DT)
    run(h, cable_frame(), 0.2)
    near, window = h.behaviour.region_hint()
    image = cable_frame() + contact_frame(cop_px=(13.5, 7.5), force_n=4.0, orientation_rad=math.pi / 2,
                                          length_px=20.0, width_px=3.0)
    assert extract(image).cop_px[0] > 10.0  # the paper's rule: the largest region
    kept = extract(image, near_px=near, window_px=window)
    assert abs(kept.cop_px[0] - 7.5) < 0.5
    loaded = image > defaults.CONTACT_THRESHOLD_N
    assert kept.pressure == pytest.approx(image[loaded].sum() / (loaded.sum() * kept.pad.pitch ** 2), rel=1e-9)


def test_a_larger_line_beside_the_followed_one_is_no_loss():
    """Through the harness's perception (as in a mission): a larger line comes in beside the
    followed one; the leaf keeps the followed one and stays on it."""
    h = LeafHarness(CableEnd(), dt=DT)
    run(h, cable_frame(), 0.2)
    both = cable_frame() + contact_frame(cop_px=(13.5, 7.5), force_n=4.0, orientation_rad=math.pi / 2,
                                         length_px=20.0, width_px=3.0)
    assert run(h, both, 0.5) == Status.RUNNING
    assert read("/cable/on_line") is True
    assert abs(h.features_raw.cop_px[0] - 7.5) < 0.5


def test_the_cable_tree_ends_at_the_end_of_a_short_cable_whatever_the_budget(tmp_path):
    """A 200 mm cable: the mission ends by touch, with the same figures for a budget of 30 s
    and of 60 s, and records nothing off the cable."""
    text = (ROOT / "sim" / "cable.yaml").read_text()
    text = text.replace("""      - straight: 0.07
      - arc: {radius: 0.10, angle_deg: -90}
      - straight: 0.05
      - arc: {radius: 0.08, angle_deg: 120}
      - straight: 0.025""", """      - straight: 0.10
      - arc: {radius: 0.12, angle_deg: -40}
      - straight: 0.02""")
    scene = tmp_path / "short_cable.yaml"
    scene.write_text(text)
    reports = [run_mission(ROOT / "trees" / "cable_follow.yaml", str(scene), duration=d).summary for d in (30.0, 60.0)]
    for r in reports:
        assert r.status == "success" and "end of cable" in r.reason, r.reason
        assert r.sim_time_s < 20.0
        assert r.path_error_m["max"] < 3e-3 and r.path_error_m["mean"] < 1e-3
        assert r.path_error_m["followed_m"] > 0.7 * r.path_error_m["cable_length_m"]
    assert reports[0].sim_time_s == reports[1].sim_time_s
    assert reports[0].path_error_m == reports[1].path_error_m


def test_line_shape_is_the_second_moments_of_the_tactel_positions():
    """``_shape`` (one product with a basis of moments) against the moments written out."""
    from numpy.testing import assert_allclose

    from tactile_bt.tree.behaviours.line_shape import line_shape as _shape

    rng = np.random.default_rng(5)
    for _ in range(200):
        mask = rng.random((16, 16)) < rng.uniform(0.005, 0.5)
        rows, cols = np.nonzero(mask)
        if rows.size < 3:
            assert _shape(mask)[0] == math.inf and math.isnan(_shape(mask)[1])
            continue
        sxx, syy = cols.var(), rows.var()
        sxy = float(np.mean(cols * rows) - cols.mean() * rows.mean())
        width, axis, mx, my, n = _shape(mask)
        assert n == rows.size
        spread = math.hypot(sxx - syy, 2 * sxy)
        assert_allclose((mx, my), (cols.mean(), rows.mean()), rtol=1e-9)
        if spread > 1e-6:
            assert_allclose(width, math.sqrt(12 * max(0.5 * (sxx + syy - spread), 0.0)), rtol=1e-6, atol=1e-6)
            assert_allclose(axis, 0.5 * math.atan2(2 * sxy, sxx - syy), rtol=1e-9, atol=1e-9)
