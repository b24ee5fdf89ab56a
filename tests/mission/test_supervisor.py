"""The supervisor between the controller and the mount: force and pressure limits (retreat along
the pad normal, then failure naming the limit), the live-mission checks (silent sensor, stale
pose, workspace), its limits, and closed-loop missions that press too hard."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from py_trees.common import Status

from tactile_bt import defaults, load_tree, run_mission
from tactile_bt.control.spatial import body_to_spatial, make_pose
from tactile_bt.errors import SceneError
from tactile_bt.mission.report import MissionReport
from tactile_bt.mission.supervisor import Supervisor, SupervisorLimits
from tactile_bt.sim.scene import load_scene
from tactile_bt.testing import LeafHarness, fresh_blackboard, make_features
from tactile_bt.tree.behaviours import SupervisorRetreat
from tactile_bt.tree.blackboard import read_or
from tactile_bt.tree.behaviours.supervision import REASON, RETREATING

ROOT = Path(__file__).resolve().parents[2]
DT = 1.0 / defaults.RATE_HZ
#: The pad pointing down at the table (the scenes' ``rpy_deg: [180, 0, 0]``).
PAD_DOWN = make_pose(np.diag([1.0, -1.0, -1.0]), (0.0, 0.0, 0.05))
TREE_TWIST = np.array([0.01, 0.02, 0.005, 0.0, 0.1, -0.2])


@pytest.fixture(autouse=True)
def _blackboard():
    with fresh_blackboard():
        yield


def press(pressure_pa: float, area: int = 40):
    """Fake smoothed features of a contact at ``pressure_pa`` over ``area`` tactels."""
    return make_features(pressure=pressure_pa, area=area)


def run_for(supervisor, features, seconds, t0=0.0, twist=TREE_TWIST, **kwargs):
    """Check ``seconds`` of cycles with the same input; the twists sent and the times."""
    times = t0 + DT * np.arange(int(round(seconds / DT)))
    return [supervisor.check(features, PAD_DOWN, twist, t, **kwargs) for t in times], times


# ------------------------------------------------------------------ force and pressure limits


def test_within_the_limits_the_tree_twist_passes_unchanged():
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0))
    sent, _ = run_for(sup, press(3900.0), 1.0)
    assert all(np.array_equal(s, TREE_TWIST) for s in sent)
    assert sup.outcome is None and not sup.interventions
    assert read_or(RETREATING) is False and read_or(REASON) == ""


def test_above_the_pressure_limit_it_retreats_along_the_pad_normal_away_from_the_object():
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, retreat_speed_mps=0.02))
    twist = sup.check(press(4500.0), PAD_DOWN, TREE_TWIST, 1.0)
    # Sensor frame: z points towards the object, so the retreat is -z, and nothing else moves.
    np.testing.assert_allclose(twist, [0.0, 0.0, -0.02, 0.0, 0.0, 0.0])
    # With the pad's normal pointing down at the table, that is straight up in the world.
    np.testing.assert_allclose(body_to_spatial(PAD_DOWN, twist), [0.0, 0.0, 0.02, 0.0, 0.0, 0.0], atol=1e-15)
    # The tree is told why.
    assert read_or(RETREATING) is True
    assert "pressure 4500 Pa above the limit 4000 Pa at 1.00 s" == read_or(REASON)


def test_a_contact_at_the_pad_s_border_is_left_sideways_as_well():
    # the pressure peaks at the pad's corner (+x, -y): an object beside the pad's border there;
    # the retreat backs off along the normal and slides the pad away from that corner
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, retreat_speed_mps=0.02))
    corner = make_features(cop_px=(15.0, 0.0), pressure=4500.0, area=3)
    twist = sup.check(corner, PAD_DOWN, TREE_TWIST, 1.0)
    x, y = corner.cop_xy
    assert twist[2] == pytest.approx(-0.02) and not twist[3:].any()
    assert twist[0] < 0.0 < twist[1]  # away from the contact, in the pad's plane
    np.testing.assert_allclose(twist[:2], -np.array([x, y]) / 0.04 * 0.02)
    # a centred contact: the normal alone, as before
    np.testing.assert_allclose(sup.check(press(4500.0), PAD_DOWN, TREE_TWIST, 1.004)[:3], [0.0, 0.0, -0.02], atol=1e-12)
    # a second region on the other side (a groove the pad bridges): sliding would press it, so
    # the normal alone; where it lies unknown, likewise
    across = dataclasses.replace(make_features(cop_px=(15.0, 7.5), pressure=4500.0, area=3), others_force=0.5,
                                 others_tactels=3, others_cop_px=(0.0, 7.5))
    np.testing.assert_allclose(sup.check(across, PAD_DOWN, TREE_TWIST, 1.008)[:3], [0.0, 0.0, -0.02], atol=1e-12)
    unknown = dataclasses.replace(corner, others_force=0.5, others_tactels=3)
    np.testing.assert_allclose(sup.check(unknown, PAD_DOWN, TREE_TWIST, 1.012)[:3], [0.0, 0.0, -0.02], atol=1e-12)


def test_a_corner_hit_beside_a_bridged_hollow_is_left_across_the_line_to_the_other_contact():
    # A pad bridging a ring's hole (a rim under its border row y = 0) slides on and its corner
    # (+x, +y) meets the far side, steep to the pad: backing off along the normal frees it
    # slowly. The slide away from the corner keeps only its part across the line to the rim
    # seen just before (pressing that rim would follow otherwise): here along -x, not -y.
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, retreat_speed_mps=0.02))
    rim = dataclasses.replace(make_features(cop_px=(15.0, 15.0), pressure=1500.0, area=6),
                              others_force=0.3, others_tactels=6, others_cop_px=(15.0, 0.0))
    assert np.array_equal(sup.check(rim, PAD_DOWN, TREE_TWIST, 1.0), TREE_TWIST)
    corner = make_features(cop_px=(15.0, 15.0), pressure=4500.0, area=6)
    twist = sup.check(corner, PAD_DOWN, TREE_TWIST, 1.05)
    x, _ = corner.cop_xy
    assert twist[2] == pytest.approx(-0.02) and not twist[3:].any()
    np.testing.assert_allclose(twist[:2], [-x / 0.04 * 0.02, 0.0], atol=1e-12)  # sensor y is the rim's direction


def test_a_pad_rocking_between_two_rims_is_not_slid_into_the_other_one():
    # A flat pad over a groove rocks from one rim to the other and bears them one at a time: a
    # frame with the far rim's region shortly before the push counts, and the retreat is along
    # the normal alone; once no second region has been seen for a while, the slide comes back.
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, retreat_speed_mps=0.02))
    near_rim = make_features(cop_px=(7.5, 0.0), pressure=4500.0, area=16)
    far_rim_too = dataclasses.replace(make_features(cop_px=(7.5, 0.0), pressure=1500.0, area=16),
                                      others_force=0.4, others_tactels=16, others_cop_px=(7.5, 15.0))
    assert np.array_equal(sup.check(far_rim_too, PAD_DOWN, TREE_TWIST, 1.0), TREE_TWIST)
    np.testing.assert_allclose(sup.check(near_rim, PAD_DOWN, TREE_TWIST, 1.1)[:3], [0.0, 0.0, -0.02], atol=1e-12)
    later = sup.check(near_rim, PAD_DOWN, TREE_TWIST, 1.5)
    assert later[1] > 0.0  # away from the rim under the border row y = 0, in the pad's plane


def test_above_the_force_cap_it_retreats_even_at_a_moderate_pressure():
    sup = Supervisor(SupervisorLimits())  # 20 N cap
    features = press(3000.0, area=256)  # 3 kPa over the whole pad: 19.2 N
    assert np.array_equal(sup.check(features, PAD_DOWN, TREE_TWIST, 0.0), TREE_TWIST)
    features = press(3500.0, area=256)  # 22.4 N
    assert sup.check(features, PAD_DOWN, TREE_TWIST, DT)[2] < 0
    assert sup.interventions[0].limit == "force"
    assert "force 22.4 N above the limit 20 N" in read_or(REASON)


def test_a_limit_that_persists_past_the_grace_time_ends_the_mission_naming_it():
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, grace_s=0.5))
    sent, times = run_for(sup, press(4800.0), 0.8, t0=2.0)
    ended = next(i for i, s in enumerate(sent) if not s.any())
    assert times[ended] == pytest.approx(2.5, abs=1.5 * DT)  # after the grace time, not before
    assert all(s[2] < 0 for s in sent[:ended])  # retreating until then
    assert all(not s.any() for s in sent[ended:])  # then a zero twist, whatever the tree asks
    status, reason = sup.outcome
    assert status == "failure"
    assert reason == ("supervisor: pressure limit: 4800 Pa above 4000 Pa at 2.50 s, above a limit for 0.50 s in all, "
                      "the pad pulled back, in the 0.50 s since the intervention began at 2.00 s"), reason
    summary = sup.summary()
    assert summary["interventions"] == 1 and summary["ended_mission"] == reason
    assert summary["longest_intervention_s"] == pytest.approx(0.5, abs=1.5 * DT)
    assert summary["peak_pressure_pa"] == pytest.approx(4800.0)


def test_a_tree_that_keeps_pushing_back_cannot_outlast_the_grace_time():
    """Above the limit for a cycle, below it for a few: one intervention, whose stretches above
    the limit add up until they make the grace time."""
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, grace_s=0.5, clear_s=0.2))
    ended_at = None
    for k in range(int(3.0 / DT)):
        sup.check(press(4100.0 if k % 4 == 0 else 3900.0), PAD_DOWN, TREE_TWIST, k * DT)
        if sup.outcome:
            ended_at = k * DT
            break
    assert sup.outcome is not None and "pressure limit" in sup.outcome[1]
    assert len(sup.interventions) == 1
    # one cycle in four above the limit: 0.5 s of them after 2 s
    assert ended_at == pytest.approx(2.0, abs=1.5 * DT)
    assert sup.interventions[0].retreat_s == pytest.approx(0.5, abs=1.5 * DT)
    assert ", above a limit for 0.50 s in all, the pad pulled back, in the 2.00 s since" in sup.outcome[1]


def test_short_stretches_above_a_limit_in_separate_interventions_do_not_end_the_mission():
    # a cycle above the limit, then clear for longer than clear_s, again and again
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, grace_s=0.5, clear_s=0.2))
    for k in range(int(5.0 / DT)):
        sup.check(press(4100.0 if k % 100 == 0 else 3900.0), PAD_DOWN, TREE_TWIST, k * DT)
    assert sup.outcome is None and len(sup.interventions) == 13


def test_an_intervention_ends_after_the_clear_time_and_hands_the_twist_back():
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, grace_s=0.5, clear_s=0.2))
    run_for(sup, press(4500.0), 0.1)
    sent, times = run_for(sup, press(2000.0), 0.4, t0=0.1)
    assert all(np.array_equal(s, TREE_TWIST) for s in sent)  # the tree's twist as soon as it is within
    assert sup.outcome is None
    assert read_or(RETREATING) is False and read_or(REASON) == ""
    run_for(sup, press(4500.0), 0.1, t0=1.0)  # a new intervention, with a fresh grace time
    summary = sup.summary()
    assert summary["interventions"] == 2
    assert summary["retreat_time_s"] == pytest.approx(0.2, abs=2.5 * DT)
    assert [r["start_s"] for r in summary["runs"]] == pytest.approx([0.0, 1.0])


def test_a_tree_can_back_off_on_the_guard():
    harness = LeafHarness(SupervisorRetreat())
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0))
    sup.check(press(2000.0), PAD_DOWN, TREE_TWIST, 0.0)
    assert harness.tick(press(2000.0)) == Status.RUNNING
    sup.check(press(4500.0), PAD_DOWN, TREE_TWIST, DT)
    assert harness.tick(press(4500.0)) == Status.FAILURE
    assert "pressure 4500 Pa above the limit 4000 Pa" in harness.behaviour.feedback_message


def test_stop_is_a_zero_twist():
    sup = Supervisor()
    sup.check(press(2000.0), PAD_DOWN, TREE_TWIST, 0.0)
    assert np.array_equal(sup.last_command, TREE_TWIST)
    assert not sup.stop().any() and not sup.last_command.any()


# ------------------------------------------------------------------ live-mission checks


@pytest.mark.parametrize(
    "kwargs,fragment",
    [
        ({"frame_time": 0.95}, "sensor silent: no frame for 50 ms (limit 40 ms) at 1.00 s"),
        ({"pose_time": 0.9}, "stale robot pose: 100 ms old (limit 40 ms) at 1.00 s"),
    ],
)
def test_a_silent_sensor_or_a_stale_pose_stops_the_mission(kwargs, fragment):
    sup = Supervisor(SupervisorLimits(sensor_silence_s=0.04, pose_stale_s=0.04))
    fresh = {k: 1.0 - 0.03 for k in kwargs}  # within the limit: the twist passes
    assert np.array_equal(sup.check(press(2000.0), PAD_DOWN, TREE_TWIST, 1.0, **fresh), TREE_TWIST)
    assert not sup.check(press(2000.0), PAD_DOWN, TREE_TWIST, 1.0, **kwargs).any()
    assert sup.outcome == ("failure", f"supervisor: {fragment}")


def test_a_pose_outside_the_workspace_stops_the_mission():
    limits = SupervisorLimits(workspace_min_m=(-0.3, -0.3, 0.0), workspace_max_m=(0.3, 0.3, 0.4))
    sup = Supervisor(limits)
    assert np.array_equal(sup.check(press(2000.0), PAD_DOWN, TREE_TWIST, 0.0), TREE_TWIST)
    outside = make_pose(np.diag([1.0, -1.0, -1.0]), (0.31, 0.0, 0.05))
    assert not sup.check(press(2000.0), outside, TREE_TWIST, DT).any()
    assert "pose outside the workspace: the pad at [310, 0, 50] mm, the box [-300, -300, 0] to [300, 300, 400] mm" \
        in sup.outcome[1]


# ------------------------------------------------------------------ the limits


def test_the_default_pressure_limit_is_twice_the_highest_target_of_the_tree(tmp_path):
    tree = tmp_path / "t.yaml"
    tree.write_text("""
root:
  sequence:
    children:
      - approach: {pressure_pa: 800}
      - force_hold: {target_pa: 2500}
      - tactile_servo: {P: [1, 1, 0, 0, 0, 0], target_pa: 9000}   # no normal row: holds no pressure
""")
    limits = SupervisorLimits.for_tree(load_tree(tree))
    assert limits.pressure_limit_pa == 5000.0
    assert limits.force_limit_n == defaults.SUPERVISOR_FORCE_CAP_N
    declared = SupervisorLimits.for_tree(load_tree(tree), {"pressure_limit_pa": 3000.0, "grace_s": 0.2})
    assert (declared.pressure_limit_pa, declared.grace_s) == (3000.0, 0.2)


@pytest.mark.parametrize(
    "field,value,fragment",
    [
        ("force_limit_n", 25.0, "positive number up to 20 N"),
        ("pressure_limit_pa", 0.0, "positive number up to 20000 Pa"),
        ("grace_s", float("inf"), "positive number up to 2 s"),
    ],
)
def test_limits_outside_their_bounds_are_refused(field, value, fragment):
    with pytest.raises(ValueError, match=f"supervisor.{field}: expected a {fragment}"):
        SupervisorLimits(**{field: value})


def test_a_scene_declares_limits_within_bounds_with_file_and_line(tmp_path):
    scene = tmp_path / "s.yaml"
    text = (ROOT / "sim" / "pen.yaml").read_text()
    scene.write_text(text + "supervisor:\n  pressure_limit_pa: 3000\n  force_limit_n: 30\n")
    with pytest.raises(SceneError) as info:
        load_scene(scene)
    line = len(text.splitlines()) + 3
    assert str(info.value).startswith(f"{scene}:{line}:")
    assert "supervisor.force_limit_n: expected a positive number up to 20 N, got 30" in str(info.value)
    scene.write_text(text + "supervisor:\n  pressure_limit_pa: 3000\n  workspace_min_m: [0, 0, 0]\n"
                            "  workspace_max_m: [0.5, -0.1, 0.5]\n")
    with pytest.raises(SceneError, match="workspace_max_m: expected every coordinate above"):
        load_scene(scene)
    overridden = load_scene(ROOT / "sim" / "pen.yaml", ["supervisor.grace_s=0.3"])
    assert overridden.supervisor == {"grace_s": 0.3}


# ------------------------------------------------------------------ closed loop

PRESS_HARD = """
name: press_hard
root:
  sequence:
    name: press_hard
    children:
      - approach: {pressure_pa: 800, timeout_s: 5}
      - force_hold: {target_pa: 12000}
"""

BACK_OFF = """
name: back_off
root:
  sequence:
    name: back_off
    children:
      - approach: {pressure_pa: 800, timeout_s: 5}
      - selector:
          name: hard_or_gentle
          children:
            - parallel:
                name: hard
                policy: success_on_one
                children:
                  - force_hold: {name: press_hard, target_pa: 12000}
                  - supervisor_retreat: {}
            - force_hold: {name: press_gently, target_pa: 2000}
"""


def _smoothed_pressure_after(result, t0):
    log = result.log
    return log["pressure_pa"][log["t"] >= t0]


def test_a_tree_pressing_into_a_rigid_pen_is_pulled_back_and_the_mission_fails_naming_the_limit(tmp_path):
    tree = tmp_path / "press_hard.yaml"
    tree.write_text(PRESS_HARD)
    result = run_mission(tree, ROOT / "sim" / "pen.yaml", duration=3.0, out=tmp_path / "out",
                         overrides=["supervisor.pressure_limit_pa=4000"])
    r = result.report
    assert r["status"] == "failure"
    assert r["reason"].startswith("supervisor: pressure limit: "), r["reason"]
    assert "above 4000 Pa" in r["reason"] and "s in all, the pad pulled back" in r["reason"]
    sup = r["supervisor"]
    assert sup["interventions"] >= 1 and sup["retreat_time_s"] > 0.1
    start = sup["runs"][0]["start_s"]
    # once it has been above the limit for the default grace time in all, pressing again
    # each time the retreat brought it under
    run = sup["runs"][0]
    assert run["retreat_s"] == pytest.approx(0.5, abs=0.01) and r["sim_time_s"] >= start + 0.5
    # The supervisor retreated (-z) during the intervention, and the pressure stayed bounded
    # near its limit although the tree asked for three times as much.
    log = result.log
    during = (log["t"] >= start) & (log["t"] < r["sim_time_s"])
    assert np.any(log["twist_s"][during, 2] < 0)
    assert np.max(_smoothed_pressure_after(result, 0.0)) < 1.15 * 4000.0
    assert not log["twist_s"][-1].any()  # the last command: zero
    saved = MissionReport.load(tmp_path / "out")
    assert saved.supervisor == sup
    assert any(line.startswith("  supervisor       1 intervention, ") for line in saved.summary_lines())


def test_a_tree_that_backs_off_on_the_supervisor_carries_on_within_the_limits(tmp_path):
    tree = tmp_path / "back_off.yaml"
    tree.write_text(BACK_OFF)
    result = run_mission(tree, ROOT / "sim" / "pen.yaml", duration=2.5,
                         overrides=["supervisor.pressure_limit_pa=4000"])
    r = result.report
    assert r["status"] == "completed", r["reason"]
    assert r["supervisor"]["interventions"] == 1 and r["supervisor"]["ended_mission"] == ""
    late = _smoothed_pressure_after(result, 1.5)
    assert abs(np.mean(late) - 2000.0) < 200.0  # the gentle branch holds its target


def test_the_absolute_force_cap_holds_without_any_declared_limit(tmp_path):
    """A target of 15 kPa on the flat top of a box: the default pressure limit is 20 kPa, but
    the whole pad in contact reaches the 20 N cap first."""
    tree = tmp_path / "press_harder.yaml"
    tree.write_text(PRESS_HARD.replace("12000", "15000"))
    result = run_mission(tree, ROOT / "sim" / "toy_box.yaml", duration=4.0)
    r = result.report
    assert r["supervisor"]["limits"]["pressure_limit_pa"] == 20000.0
    assert r["status"] == "failure" and r["reason"].startswith("supervisor: force limit: "), r["reason"]
    assert "above 20 N" in r["reason"]
    assert np.max(result.log["force_n"]) < 1.1 * defaults.SUPERVISOR_FORCE_CAP_N


def test_the_retreat_never_slows_a_tree_that_already_backs_off_faster():
    sup = Supervisor(SupervisorLimits(pressure_limit_pa=4000.0, retreat_speed_mps=0.02))
    backing_off = np.array([0.01, 0.0, -0.05, 0.2, 0.0, 0.0])
    twist = sup.check(press(4500.0), PAD_DOWN, backing_off, 0.0)
    np.testing.assert_allclose(twist, [0.0, 0.0, -0.05, 0.0, 0.0, 0.0])  # its speed, nothing else
    twist = sup.check(press(4500.0), PAD_DOWN, TREE_TWIST, DT)  # pressing on: the retreat
    np.testing.assert_allclose(twist, [0.0, 0.0, -0.02, 0.0, 0.0, 0.0])


PUSH_THEN_HOLD = """
name: push_then_hold
root:
  sequence:
    name: push_then_hold
    children:
      - approach: {pressure_pa: 800, timeout_s: 5}
      - mission_timeout:                 # a blind push into the pen: 20 mm in 0.5 s
          duration_s: 0.5
          succeed: true
          child:
            guided_slide: {name: push, twist: [0, 0, 0.04, 0, 0, 0]}
      - mission_timeout:
          duration_s: 1.5
          succeed: true
          child:
            force_hold: {target_pa: 2000}
"""


def test_a_blind_push_into_a_rigid_object_is_pulled_back_and_the_mission_goes_on(tmp_path):
    """No leaf of this tree listens to the supervisor: it retreats for the tree, hands the twist
    back once the pressure has stayed within the limit, and the mission ends as the tree does."""
    tree = tmp_path / "push.yaml"
    tree.write_text(PUSH_THEN_HOLD)
    result = run_mission(tree, ROOT / "sim" / "pen.yaml", duration=4.0)
    r = result.report
    assert r["status"] == "success", r["reason"]
    sup = r["supervisor"]
    assert sup["interventions"] >= 1 and sup["ended_mission"] == ""
    assert sup["runs"][0]["limit"] == "pressure" and sup["retreat_time_s"] > 0.0
    log = result.log
    start = sup["runs"][0]["start_s"]
    assert np.all(log["twist_s"][(log["t"] > start) & (log["t"] < start + 0.02), 2] < 0)  # retreating
    # ... within twice the limit at worst, and then the force hold holds its target
    assert np.max(log["pressure_pa"]) < 2 * sup["limits"]["pressure_limit_pa"]
    late = log["pressure_pa"][log["t"] > r["sim_time_s"] - 0.5]
    assert abs(np.mean(late) - 2000.0) < 200.0
    force = r["force"]
    assert force["peak_force_n"] <= defaults.SUPERVISOR_FORCE_CAP_N
