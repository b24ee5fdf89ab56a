"""Tactile leaves, each alone: fake features and a fake mission clock (tactile_bt.testing).

Sign conventions checked here come from tactile_bt/control/servo.py: Δf = target − measured,
v_x = −u_x, v_y = −u_y, v_z = +u_p, ω_x = +u_y / r, ω_y = −u_x / r, ω_z = −u_α. Errors the
leaves report are measured − target in metric units (Pa, px, rad).
"""

import time

import numpy as np
import py_trees
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.contacts.cloud import ContactCloud
from tactile_bt.tree.behaviours import (
    AlignEdge,
    Approach,
    Centre,
    ContactLost,
    ForceHold,
    ForceLimit,
    GuidedSlide,
    MissionTimeout,
    RecordContacts,
    Roll,
    TactileServo,
)
from tactile_bt.perception.features import extract
from tactile_bt.sim.objects import Cable, polyline_from_segments
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, make_features

PITCH = defaults.PITCH_M
#: A control period that is exact in binary, so tick counts × dt are exact mission times.
DT = 1.0 / 128.0
ROWS = {"vx": 0, "vy": 1, "vz": 2, "wx": 3, "wy": 4, "wz": 5}



def nonzero_rows(twist):
    return {name for name, i in ROWS.items() if twist[i] != 0.0}


# --------------------------------------------------------------------------------- force_hold


def test_force_hold_too_light_presses_along_plus_z_only():
    h = LeafHarness(ForceHold(target_pa=2000.0), dt=DT)
    assert h.tick(make_features(pressure=1500.0, cop_px=(11.0, 3.0), orientation=0.3)) == Status.RUNNING
    assert h.twist[2] > 0.0
    assert nonzero_rows(h.twist) == {"vz"}


def test_force_hold_too_hard_backs_off_along_minus_z_only():
    h = LeafHarness(ForceHold(target_pa=2000.0), dt=DT)
    assert h.tick(make_features(pressure=2600.0, cop_px=(2.0, 12.0))) == Status.RUNNING
    assert h.twist[2] < 0.0
    assert nonzero_rows(h.twist) == {"vz"}


def test_force_hold_integral_makes_vz_grow_under_constant_error():
    kp, ki, e = 1.0e-6, 4.0e-6, 500.0  # pressure 500 Pa below target
    h = LeafHarness(ForceHold(target_pa=2000.0, kp=kp, ki=ki, kd=0.0), dt=DT)
    vz = []
    for _ in range(40):
        h.tick(make_features(pressure=2000.0 - e))
        vz.append(h.twist[2])
    vz = np.array(vz)
    assert np.all(np.diff(vz) > 0.0)
    n = np.arange(1, 41)
    assert_allclose(vz, kp * e + ki * e * n * DT, rtol=1e-12)


def test_force_hold_reports_pressure_error_in_pa_measured_minus_target():
    h = LeafHarness(ForceHold(target_pa=2000.0), dt=DT)
    h.tick(make_features(pressure=1500.0))
    assert h.errors == pytest.approx({"pressure_pa": -500.0})
    h.tick(make_features(pressure=2300.0))
    assert h.errors == pytest.approx({"pressure_pa": 300.0})


@pytest.mark.parametrize("dt,expected_ticks", [(1.0 / 128.0, 33), (1.0 / 64.0, 17)])
def test_force_hold_converges_after_dwell_on_the_mission_clock(dt, expected_ticks):
    """Inside the band from the first tick: SUCCESS on the first tick at least dwell_s of
    mission time after entering it — the tick count depends on dt, the mission time does not."""
    dwell = 0.25
    h = LeafHarness(ForceHold(target_pa=2000.0, converge=True, band=50.0, dwell_s=dwell), dt=dt)
    statuses = [h.tick(make_features(pressure=2020.0)) for _ in range(expected_ticks)]
    assert statuses[:-1] == [Status.RUNNING] * (expected_ticks - 1)
    assert statuses[-1] == Status.SUCCESS
    # The successful tick happened at mission time dwell (ticks start at t = 0).
    assert (expected_ticks - 1) * dt == pytest.approx(dwell)


def test_force_hold_dwell_restarts_when_the_error_leaves_the_band():
    dwell = 0.25  # 32 ticks of DT
    h = LeafHarness(ForceHold(target_pa=2000.0, converge=True, band=50.0, dwell_s=dwell), dt=DT)
    inside, outside = make_features(pressure=1990.0), make_features(pressure=1800.0)
    for _ in range(30):  # inside for 29 DT: not yet converged
        assert h.tick(inside) == Status.RUNNING
    assert h.tick(outside) == Status.RUNNING  # leaves the band: dwell restarts
    t_reenter = h.time
    n = h.tick_until(Status.SUCCESS, max_ticks=200, features=iter(lambda: inside, None))
    t_success = t_reenter + (n - 1) * DT
    assert t_success - t_reenter == pytest.approx(dwell)
    assert n == 33


def test_force_hold_without_converge_runs_forever_at_zero_error():
    h = LeafHarness(ForceHold(target_pa=2000.0), dt=DT)
    for _ in range(500):
        assert h.tick(make_features(pressure=2000.0)) == Status.RUNNING


def test_servo_leaf_pid_state_is_reset_on_initialise():
    leaf = ForceHold(target_pa=2000.0, kp=1e-6, ki=4e-6)
    h = LeafHarness(leaf, dt=DT)
    low = make_features(pressure=1000.0)
    h.tick(low)
    first = h.twist.copy()
    for _ in range(50):
        h.tick(low)
    assert h.twist[2] > first[2]  # the integral has grown
    leaf.stop(Status.INVALID)  # the parent stops the leaf ...
    h.tick(low)  # ... and starts it again
    assert_allclose(h.twist, first, rtol=0, atol=1e-15)


# --------------------------------------------------------------------------------- centre


@pytest.mark.parametrize(
    "cop_px,sign_vx,sign_vy",
    [((10.0, 7.5), 1, 0), ((4.0, 7.5), -1, 0), ((7.5, 11.0), 0, 1), ((7.5, 2.0), 0, -1), ((12.0, 3.0), 1, -1)],
)
def test_centre_slides_so_the_cop_moves_back_to_the_target(cop_px, sign_vx, sign_vy):
    """COP at +x (right of centre): Δx = target − measured < 0, u_x < 0, v_x = −u_x > 0; the
    contact point then moves as ẋ = −v_x < 0, i.e. back to the centre."""
    h = LeafHarness(Centre(kp=3.0, ki=0.0, output_limit=np.inf), dt=DT)
    f = make_features(cop_px=cop_px, pressure=1234.0, orientation=0.2)
    assert h.tick(f) == Status.RUNNING
    tw = h.twist
    assert np.sign(tw[0]) == sign_vx and np.sign(tw[1]) == sign_vy
    assert nonzero_rows(tw) <= {"vx", "vy"}
    assert_allclose(tw[:2], 3.0 * f.cop)  # v = −kp·Δ = kp·(measured − target)
    # the COP moves as ẋ = −v: its distance to the target shrinks
    assert np.linalg.norm(f.cop - DT * tw[:2]) < np.linalg.norm(f.cop)


def test_centre_output_is_limited_per_component():
    h = LeafHarness(Centre(kp=3.0, ki=0.0, output_limit=0.01), dt=DT)
    h.tick(make_features(cop_px=(15.0, 0.0)))
    assert_allclose(h.twist[:2], [0.01, -0.01])


def test_centre_reports_cop_errors_in_tactels_measured_minus_target():
    h = LeafHarness(Centre(target_m=(PITCH, 0.0)), dt=DT)
    h.tick(make_features(cop_px=(10.0, 5.0)))
    assert h.errors == pytest.approx({"cop_x_px": 1.5, "cop_y_px": -2.5})


def test_centre_converges_with_band_in_metres():
    h = LeafHarness(Centre(converge=True, band=0.1 * PITCH, dwell_s=0.25), dt=DT)
    assert h.tick_until(Status.SUCCESS, max_ticks=100, features=iter(lambda: make_features(cop_px=(7.55, 7.45)), None)) == 33
    h2 = LeafHarness(Centre(converge=True, band=0.1 * PITCH, dwell_s=0.25), dt=DT)
    for _ in range(100):
        assert h2.tick(make_features(cop_px=(7.5 + 0.2, 7.5))) == Status.RUNNING  # 0.2 px > band


# --------------------------------------------------------------------------------- roll


@pytest.mark.parametrize("cop_px", [(10.0, 7.5), (4.0, 7.5), (7.5, 11.0), (7.5, 2.0), (12.0, 3.0)])
def test_roll_drives_only_the_rolling_rows_with_signs_and_radius(cop_px):
    r, kp = 0.04, 1.0
    h = LeafHarness(Roll(kp=kp, ki=0.0, output_limit=np.inf, roll_radius=r), dt=DT)
    f = make_features(cop_px=cop_px)
    assert h.tick(f) == Status.RUNNING
    tw = h.twist
    assert nonzero_rows(tw) <= {"wx", "wy"}
    dx, dy = -f.cop  # Δ = target (0) − measured
    # ω_x = +u_y / r, ω_y = −u_x / r
    assert_allclose(tw[3:5], [kp * dy / r, -kp * dx / r])


def test_roll_reports_cop_errors_in_tactels():
    h = LeafHarness(Roll(), dt=DT)
    h.tick(make_features(cop_px=(9.5, 6.5)))
    assert h.errors == pytest.approx({"cop_x_px": 2.0, "cop_y_px": -1.0})


# --------------------------------------------------------------------------------- align_edge


@pytest.mark.parametrize(
    "measured,target,expected_delta",
    [
        (1.4, np.pi / 2, np.pi / 2 - 1.4),  # turned a little below the target: ω_z < 0
        (0.3, 0.0, -0.3),  # above the target: ω_z > 0
        (-1.5, np.pi / 2, np.pi / 2 + 1.5 - np.pi),  # modulo π: −1.5 rad is just past +π/2
    ],
)
def test_align_edge_turns_about_z_only_modulo_pi(measured, target, expected_delta):
    kp = 4.0
    h = LeafHarness(AlignEdge(target_rad=target, kp=kp, ki=0.0, output_limit=np.inf), dt=DT)
    assert h.tick(make_features(orientation=measured, cop_px=(3.0, 12.0), pressure=900.0)) == Status.RUNNING
    tw = h.twist
    assert nonzero_rows(tw) == {"wz"}
    assert_allclose(tw[5], -kp * expected_delta)  # ω_z = −u_α
    assert h.errors["orientation_rad"] == pytest.approx(-expected_delta)
    assert set(h.errors) == {"orientation_rad"}


def test_align_edge_without_dominant_axis_adds_nothing():
    h = LeafHarness(AlignEdge(), dt=DT)
    assert h.tick(make_features(orientation=float("nan"))) == Status.RUNNING
    assert_array_equal(h.twist, np.zeros(6))
    assert h.command.parts == {}


# --------------------------------------------------------------------------------- tactile_servo


def _gains():
    return dict(kp=(3.0, 3.0, 2.0e-6, 4.0), ki=(0.5, 0.5, 4.0e-6, 0.5), kd=(0.0, 0.0, 1e-8, 0.0),
                output_limit=(0.03, 0.03, 0.02, 1.0))


def test_tactile_servo_force_projection_equals_force_hold():
    g = _gains()
    rng = np.random.default_rng(1)
    script = [
        make_features(pressure=p, cop_px=c, orientation=a)
        for p, c, a in zip(rng.uniform(800, 3200, 60), rng.uniform(1, 14, (60, 2)), rng.uniform(-1.5, 1.5, 60))
    ]
    hs = LeafHarness(TactileServo(P=(0, 0, 1, 0, 0, 0), target_pa=2000.0, **g), dt=DT)
    servo = []
    for f in script:
        hs.tick(f)
        servo.append(hs.twist.copy())
    py_trees.blackboard.Blackboard.clear()
    hf = LeafHarness(ForceHold(target_pa=2000.0, kp=g["kp"][2], ki=g["ki"][2], kd=g["kd"][2],
                               output_limit=g["output_limit"][2]), dt=DT)
    hold = []
    for f in script:
        hf.tick(f)
        hold.append(hf.twist.copy())
    assert_allclose(np.array(servo), np.array(hold), rtol=1e-12, atol=0)
    assert np.all(np.array(servo)[:, [0, 1, 3, 4, 5]] == 0.0)


def test_tactile_servo_force_projection_still_servos_force_on_a_contact_without_axis():
    """A flat contact (table, round blob) has no dominant axis: orientation is NaN. With
    P = diag(0,0,1,0,0,0) orientation is not controlled, so the force loop must still act."""
    h = LeafHarness(TactileServo(P=(0, 0, 1, 0, 0, 0), target_pa=2000.0), dt=DT)
    h.tick(make_features(pressure=1000.0, orientation=float("nan")))
    assert h.twist[2] > 0.0


def test_tactile_servo_reports_only_the_features_its_projection_controls():
    h = LeafHarness(TactileServo(P=(0, 0, 1, 0, 0, 0)), dt=DT)
    h.tick(make_features(pressure=1500.0, cop_px=(10.0, 7.5)))
    assert set(h.errors) == {"pressure_pa"}


def test_tactile_servo_cable_projection_drives_its_rows():
    h = LeafHarness(TactileServo(P=(1, 1, 1, 0, 0, 1)), dt=DT)
    h.tick(make_features(pressure=1500.0, cop_px=(10.0, 5.0), orientation=1.3))
    tw = h.twist
    assert nonzero_rows(tw) == {"vx", "vy", "vz", "wz"}
    assert tw[0] > 0 and tw[1] < 0 and tw[2] > 0 and tw[5] < 0


# --------------------------------------------------------------------------------- no contact


@pytest.mark.parametrize(
    "leaf,metrics",
    [
        (lambda: ForceHold(), {"pressure_pa"}),
        (lambda: Centre(), {"cop_x_px", "cop_y_px"}),
        (lambda: Roll(), {"cop_x_px", "cop_y_px"}),
        (lambda: AlignEdge(), {"orientation_rad"}),
        (lambda: TactileServo(P=(1, 1, 1, 1, 1, 1)), {"pressure_pa", "cop_x_px", "cop_y_px", "orientation_rad"}),
    ],
)
def test_servo_leaves_add_nothing_without_contact_and_keep_running(leaf, metrics):
    h = LeafHarness(leaf(), dt=DT)
    for _ in range(20):
        assert h.tick(make_features(in_contact=False)) == Status.RUNNING
        assert_array_equal(h.twist, np.zeros(6))
        assert h.command.parts == {}
    # errors are logged as NaN (not controlled), never as a fake 0
    assert set(h.errors) == metrics
    assert all(np.isnan(v) for v in h.errors.values())


def test_servo_leaf_resumes_after_contact_without_integral_windup_during_the_gap():
    h = LeafHarness(ForceHold(kp=1e-6, ki=4e-6), dt=DT)
    h.tick(make_features(pressure=1500.0))
    first = h.twist[2]
    for _ in range(100):
        h.tick(make_features(in_contact=False))
    h.tick(make_features(pressure=1500.0))
    # one more step of integral, nothing accumulated while out of contact
    assert h.twist[2] == pytest.approx(first + 4e-6 * 500.0 * DT)


def test_converged_dwell_restarts_after_a_contact_gap():
    h = LeafHarness(ForceHold(converge=True, band=50.0, dwell_s=0.25), dt=DT)
    for _ in range(20):
        assert h.tick(make_features(pressure=2000.0)) == Status.RUNNING
    assert h.tick(make_features(in_contact=False)) == Status.RUNNING
    assert h.tick_until(Status.SUCCESS, max_ticks=100, features=iter(lambda: make_features(pressure=2000.0), None)) == 33


# --------------------------------------------------------------------------------- approach


def test_approach_moves_along_plus_z_at_speed_until_pressure_reached():
    h = LeafHarness(Approach(speed_mps=0.01, pressure_pa=800.0), dt=DT)
    for _ in range(5):
        assert h.tick(make_features(in_contact=False)) == Status.RUNNING
        assert_array_equal(h.twist, [0, 0, 0.01, 0, 0, 0])
    assert h.tick(make_features(pressure=500.0)) == Status.RUNNING  # touching, not enough yet
    assert_array_equal(h.twist, [0, 0, 0.01, 0, 0, 0])
    assert h.tick(make_features(pressure=800.0)) == Status.SUCCESS
    assert_array_equal(h.twist, np.zeros(6))


def test_approach_fails_after_timeout_on_the_mission_clock():
    timeout = 0.5
    h = LeafHarness(Approach(speed_mps=0.001, timeout_s=timeout, max_travel_m=1.0), dt=DT)
    n = h.tick_until(lambda s: s != Status.RUNNING, max_ticks=1000, features=iter(lambda: make_features(in_contact=False), None))
    assert h.behaviour.status == Status.FAILURE
    t_fail = (n - 1) * DT
    assert t_fail > timeout and t_fail - DT <= timeout


def test_approach_timeout_counts_from_its_own_start():
    h = LeafHarness(Approach(timeout_s=0.5, max_travel_m=1.0), dt=DT)
    h.time = 100.0  # the mission has been running for a while
    n = h.tick_until(lambda s: s != Status.RUNNING, max_ticks=1000, features=iter(lambda: make_features(in_contact=False), None))
    assert h.behaviour.status == Status.FAILURE
    assert (n - 1) * DT == pytest.approx(0.5 + DT)


def test_approach_fails_after_max_travel():
    speed, max_travel = 0.01, 0.002
    h = LeafHarness(Approach(speed_mps=speed, timeout_s=100.0, max_travel_m=max_travel), dt=DT)
    running = 0
    while h.tick(make_features(in_contact=False)) == Status.RUNNING:
        running += 1
        assert running < 10_000
    assert h.behaviour.status == Status.FAILURE
    travelled = running * speed * DT  # distance commanded while RUNNING
    assert max_travel <= travelled + 1e-12 < max_travel + speed * DT


def test_approach_rejects_non_positive_speed():
    with pytest.raises(ValueError, match="speed_mps"):
        Approach(speed_mps=0.0)


# --------------------------------------------------------------------------------- guided_slide


def test_guided_slide_adds_its_twist_while_in_contact():
    twist = [0.0, 0.02, 0.0, 0.0, 0.0, 0.1]
    h = LeafHarness(GuidedSlide(twist=twist), dt=DT)
    assert h.tick(make_features()) == Status.RUNNING
    assert_array_equal(h.twist, twist)
    assert set(h.command.parts) == {"guided_slide"}


def test_guided_slide_waits_without_contact_when_required():
    h = LeafHarness(GuidedSlide(twist=[0.0, 0.02, 0, 0, 0, 0], distance_m=0.01), dt=DT)
    for _ in range(50):
        assert h.tick(make_features(in_contact=False)) == Status.RUNNING
        assert_array_equal(h.twist, np.zeros(6))
    assert h.behaviour.travelled == 0.0
    h2 = LeafHarness(GuidedSlide(twist=[0.0, 0.02, 0, 0, 0, 0], require_contact=False), dt=DT)
    h2.tick(make_features(in_contact=False))
    assert_array_equal(h2.twist, [0.0, 0.02, 0, 0, 0, 0])


def test_guided_slide_succeeds_after_distance():
    speed, distance = 0.02, 0.005
    h = LeafHarness(GuidedSlide(twist=[speed, 0, 0, 0, 0, 0], distance_m=distance), dt=DT)
    running = 0
    while h.tick(make_features()) == Status.RUNNING:
        running += 1
        assert running < 10_000
    assert h.behaviour.status == Status.SUCCESS
    assert distance <= running * speed * DT + 1e-12 < distance + speed * DT


def test_guided_slide_succeeds_after_duration_on_the_mission_clock():
    h = LeafHarness(GuidedSlide(duration_s=0.25), dt=DT)
    n = h.tick_until(lambda s: s != Status.RUNNING, max_ticks=1000)
    assert h.behaviour.status == Status.SUCCESS
    assert (n - 1) * DT == pytest.approx(0.25)


def test_guided_slide_reads_its_twist_from_a_blackboard_key():
    planner = py_trees.blackboard.Client(name="planner")
    planner.register_key(key="/planner/twist", access=py_trees.common.Access.WRITE)
    planner.set("/planner/twist", [0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    h = LeafHarness(GuidedSlide(twist_key="/planner/twist", distance_m=0.002), dt=DT)
    h.tick()
    assert_array_equal(h.twist, [0.01, 0, 0, 0, 0, 0])
    planner.set("/planner/twist", [0.0, -0.02, 0.0, 0.0, 0.0, 0.3])
    h.tick()
    assert_array_equal(h.twist, [0.0, -0.02, 0, 0, 0, 0.3])
    assert h.behaviour.travelled == pytest.approx((0.01 + 0.02) * DT)


def test_guided_slide_rejects_a_bad_twist():
    with pytest.raises(ValueError, match="twist"):
        GuidedSlide(twist=[0.0, 0.02, 0.0])
    with pytest.raises(ValueError, match="twist"):
        GuidedSlide(twist=[0.0, float("nan"), 0, 0, 0, 0])


# --------------------------------------------------------------------------------- guards


def test_contact_lost_fails_only_after_grace_without_contact():
    grace = 0.25
    h = LeafHarness(ContactLost(grace_s=grace), dt=DT)
    for _ in range(10):
        assert h.tick(make_features()) == Status.RUNNING
    # a short gap (less than grace) is tolerated, and contact resets the count
    for _ in range(20):
        assert h.tick(make_features(in_contact=False)) == Status.RUNNING
    assert h.tick(make_features()) == Status.RUNNING
    t_lost = h.time
    n = h.tick_until(lambda s: s != Status.RUNNING, max_ticks=1000, features=iter(lambda: make_features(in_contact=False), None))
    assert h.behaviour.status == Status.FAILURE
    assert (n - 1) * DT == pytest.approx(grace)
    assert h.time - DT - t_lost == pytest.approx(grace)
    assert_array_equal(h.twist, np.zeros(6))


def test_force_limit_fails_on_raw_force_above_the_limit():
    h = LeafHarness(ForceLimit(limit_n=3.0), dt=DT)
    light = make_features(pressure=2000.0, area=40)  # 2 N
    heavy = make_features(pressure=4000.0, area=40)  # 4 N
    assert h.tick(light) == Status.RUNNING
    # judged on the unsmoothed force: a spike the moving average hides still trips it
    h.set_features(light, raw=heavy)
    assert h.tick() == Status.FAILURE
    h2 = LeafHarness(ForceLimit(limit_n=3.0), dt=DT)
    h2.set_features(heavy, raw=light)
    assert h2.tick() == Status.RUNNING
    assert h2.tick(make_features(in_contact=False)) == Status.RUNNING


class _Counter(py_trees.behaviour.Behaviour):
    """A child that runs forever (or finishes with ``result`` after ``after`` ticks)."""

    def __init__(self, after=None, result=Status.SUCCESS):
        super().__init__(name="child")
        self.after, self.result, self.ticks, self.stops = after, result, 0, 0

    def update(self):
        self.ticks += 1
        if self.after is not None and self.ticks >= self.after:
            return self.result
        return Status.RUNNING

    def terminate(self, new_status):
        if new_status == Status.INVALID:
            self.stops += 1


@pytest.mark.parametrize("succeed,expected", [(False, Status.FAILURE), (True, Status.SUCCESS)])
def test_mission_timeout_ends_its_child_after_mission_time(succeed, expected):
    child = _Counter()
    h = LeafHarness(MissionTimeout(child, duration_s=0.5, succeed=succeed), dt=DT)
    n = h.tick_until(lambda s: s != Status.RUNNING, max_ticks=1000)
    assert h.behaviour.status == expected
    assert (n - 1) * DT == pytest.approx(0.5)
    assert child.status == Status.INVALID and child.stops == 1


def test_mission_timeout_ignores_wall_time(monkeypatch):
    """Ticking fast with a fast mission clock times out; a frozen mission clock never does, even
    when the wall clock jumps by an hour between ticks."""
    h = LeafHarness(MissionTimeout(_Counter(), duration_s=5.0), dt=1.0)
    statuses = [h.tick() for _ in range(6)]  # microseconds of wall time, 5 s of mission time
    assert statuses == [Status.RUNNING] * 5 + [Status.FAILURE]

    py_trees.blackboard.Blackboard.clear()
    fake = [time.monotonic()]

    def jump():
        fake[0] += 3600.0
        return fake[0]

    monkeypatch.setattr(time, "monotonic", jump)
    monkeypatch.setattr(time, "time", jump)
    h2 = LeafHarness(MissionTimeout(_Counter(), duration_s=5.0), dt=0.0)
    for _ in range(20):
        assert h2.tick() == Status.RUNNING


def test_mission_timeout_passes_through_a_child_that_finishes_in_time():
    h = LeafHarness(MissionTimeout(_Counter(after=3, result=Status.SUCCESS), duration_s=1.0), dt=DT)
    assert [h.tick() for _ in range(3)] == [Status.RUNNING, Status.RUNNING, Status.SUCCESS]
    h2 = LeafHarness(MissionTimeout(_Counter(after=2, result=Status.FAILURE), duration_s=1.0, succeed=True), dt=DT)
    assert [h2.tick() for _ in range(2)] == [Status.RUNNING, Status.FAILURE]


def test_mission_timeout_restarts_its_clock_when_reentered():
    timeout = MissionTimeout(_Counter(), duration_s=0.25)
    h = LeafHarness(timeout, dt=DT)
    h.tick_until(Status.FAILURE, max_ticks=100)
    h.time += 10.0
    n = h.tick_until(Status.FAILURE, max_ticks=100)
    assert (n - 1) * DT == pytest.approx(0.25)


def test_mission_timeout_rejects_non_positive_duration():
    with pytest.raises(ValueError, match="duration_s"):
        MissionTimeout(_Counter(), duration_s=0.0)


# --------------------------------------------------------------------------------- record_contacts


def test_record_contacts_stores_the_contact_point_and_outward_normal_in_the_world():
    R = Rotation.from_euler("x", 180, degrees=True)  # pad facing down (sensor z = −world z)
    T = make_pose(R, (0.1, 0.2, 0.3))
    h = LeafHarness(RecordContacts(), dt=DT, pose=T)
    f = make_features(cop_px=(10.0, 5.5), pressure=1800.0)  # cop = (+12.5 mm, −10 mm) in O_s
    assert h.tick(f) == Status.RUNNING
    assert len(h.contacts) == 1
    row = h.contacts.data[0]
    # rotation about x by 180°: (x, y, 0) → (x, −y, 0)
    assert_allclose(row[0:3], [0.1 + 0.0125, 0.2 + 0.010, 0.3], atol=1e-15)
    assert_allclose(row[3:6], [0.0, 0.0, 1.0], atol=1e-15)  # the table's outward normal: up
    assert row[6] == pytest.approx(1800.0)
    assert row[7] == 0.0
    assert_array_equal(h.twist, np.zeros(6))


def test_record_contacts_general_pose_matches_the_transform():
    rng = np.random.default_rng(3)
    R = Rotation.random(random_state=rng)
    T = make_pose(R, rng.uniform(-1, 1, 3))
    h = LeafHarness(RecordContacts(), dt=DT, pose=T)
    f = make_features(cop_px=(3.25, 12.0))
    h.tick(f)
    expected = T @ np.array([f.cop[0], f.cop[1], 0.0, 1.0])
    assert_allclose(h.contacts.points[0], expected[:3], atol=1e-14)
    assert_allclose(h.contacts.normals[0], -T[:3, 2], atol=1e-14)


def test_record_contacts_skips_frames_without_contact():
    h = LeafHarness(RecordContacts(), dt=DT)
    for k in range(10):
        assert h.tick(make_features(in_contact=(k % 2 == 0))) == Status.RUNNING
    assert len(h.contacts) == 5
    assert_allclose(h.contacts.data[:, 7], np.arange(0, 10, 2) * DT)


def test_record_contacts_thins_with_min_spacing():
    spacing = 0.002
    h = LeafHarness(RecordContacts(min_spacing_m=spacing), dt=DT)
    xs = 7.5 + np.arange(0, 40) * 0.25  # COP walks 1.25 mm per tick along x ... (off the pad is fine here)
    for x in xs:
        h.tick(make_features(cop_px=(x, 7.5)))
    pts = h.contacts.points
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert np.all(steps >= spacing)
    assert_allclose(steps, 0.0025)  # every second sample of a 1.25 mm walk is kept
    assert len(pts) == 20
    h0 = LeafHarness(RecordContacts(), dt=DT)
    for _ in range(7):
        h0.tick(make_features())  # the same point every cycle: kept without thinning
    assert len(h0.contacts) == 7


def test_record_contacts_local_point_sits_on_a_bent_cable_where_the_cop_does_not():
    """On a bent cable the COP lies on the chord, off the cable; point='local' takes the point
    where the line crosses the pad centre (simulated pad, cable arc of radius 100 mm)."""
    R = 0.1
    cable = Cable(path=polyline_from_segments((-R, -0.1), 90.0, [{"straight": 0.1}, {"arc": {"radius": R, "angle_deg": -120}}]))
    on_arc = R * np.array([np.cos(np.deg2rad(135)), np.sin(np.deg2rad(135))])  # arc centre at the origin
    pose = make_pose(Rotation.from_euler("z", 30, degrees=True) * Rotation.from_euler("x", 180, degrees=True),
                     (on_arc[0], on_arc[1], 2 * cable.radius - 1e-3))
    force, _ = SensorModel(SensorParams(), np.random.default_rng(0)).force_image(pose, [cable])
    f = extract(force)
    assert f.in_contact and np.isfinite(f.orientation)
    distance = {}
    for point in ("cop", "local"):
        py_trees.blackboard.Blackboard.clear()
        h = LeafHarness(RecordContacts(point=point), dt=DT, pose=pose)
        h.tick(f)
        distance[point] = cable.distance_to_centreline(h.contacts.points[:, :2])[0]
    assert distance["cop"] > 1.5e-3  # the chord bias, ~s²/(6R)
    assert distance["local"] < 0.5e-3


def test_record_contacts_local_point_records_nothing_without_orientation():
    """Without a line direction the local point is unknown (the COP of a curved line lies on
    its chord): the cycle records nothing rather than a point beside the line."""
    h = LeafHarness(RecordContacts(point="local"), dt=DT)
    h.tick(make_features(cop_px=(9.0, 6.0), orientation=float("nan")))
    assert len(h.contacts) == 0
    h.tick(make_features(cop_px=(9.0, 6.0), orientation=0.3))
    assert len(h.contacts) == 1


def test_record_contacts_local_point_records_nothing_where_the_line_ends_near_the_centre():
    """Past a cable's end the windowed local point slides onto the tip, beyond the end of the
    centreline: such a cycle records nothing; a line across the pad records its point."""
    from tactile_bt.perception.synthetic import line_contact

    for centre, recorded in (((7.5, 7.5), 1), ((7.5, 13.5), 0)):
        py_trees.blackboard.Blackboard.clear()
        h = LeafHarness(RecordContacts(point="local", max_pressure_ratio=np.inf), dt=DT)
        h.tick(frame=line_contact(centre, np.pi / 2, 10.0 if recorded == 0 else 20.0, 1.5, 3.0))
        assert len(h.contacts) == recorded


def test_record_contacts_only_when_a_blackboard_key_is_true():
    h = LeafHarness(RecordContacts(only_when="/cable/on_line"), dt=DT)
    h.tick(make_features())
    assert len(h.contacts) == 0  # the key was never written: not recording
    h.set("/cable/on_line", True)
    h.tick(make_features())
    h.set("/cable/on_line", False)
    h.tick(make_features())
    assert len(h.contacts) == 1


def test_record_contacts_rejects_an_unknown_point_kind():
    with pytest.raises(ValueError, match="point"):
        RecordContacts(point="centroid")


def test_contact_cloud_grows_beyond_its_capacity():
    cloud = ContactCloud(capacity=2)
    for k in range(5):
        cloud.append([k, 0, 0], [0, 0, 1], 100.0 * k, 0.1 * k)
    assert len(cloud) == 5
    assert_array_equal(cloud.points[:, 0], np.arange(5))
    assert cloud.data.shape == (5, len(ContactCloud.COLUMNS))


# --------------------------------------------------------------------------------- parameters, feedback


def test_tactile_servo_converges_on_the_components_its_projection_controls():
    """P = diag(0,0,1,0,0,0): COP far off and orientation undefined do not hold back convergence."""
    leaf = TactileServo(P=(0, 0, 1, 0, 0, 0), converge=True, band=(1e-4, 1e-4, 50.0, 0.01), dwell_s=0.25)
    h = LeafHarness(leaf, dt=DT)
    f = make_features(pressure=2010.0, cop_px=(14.0, 1.0), orientation=float("nan"))
    assert h.tick_until(Status.SUCCESS, max_ticks=100, features=iter(lambda: f, None)) == 33
    assert "(converged)" in leaf.feedback_message


def test_tactile_servo_uses_only_the_features_of_its_rows():
    """The mission computes the orientation only for running leaves that use it."""
    assert TactileServo(P=(0, 0, 1, 0, 0, 0)).uses == {"pressure"}
    assert TactileServo(P=(1, 1, 0, 1, 1, 0)).uses == {"cop"}
    assert TactileServo(P=(0, 0, 1, 0, 0, 1)).uses == {"pressure", "orientation"}


@pytest.mark.parametrize(
    "make,needle",
    [
        (lambda: ForceHold(kp=-1.0), "kp must not be negative"),
        (lambda: Centre(target_m=(0.0, 0.0, 0.0)), "target_m"),
        (lambda: TactileServo(kp=(1.0, 2.0)), "kp must be one number or 4 numbers"),
        (lambda: TactileServo(target_m=(0.0,)), "target_m"),
        (lambda: ForceHold(band=-1.0), "band must be > 0"),
        (lambda: ContactLost(grace_s=-0.1), "grace_s"),
        (lambda: ForceLimit(limit_n=0.0), "limit_n"),
        (lambda: Approach(timeout_s=0.0), "timeout_s"),
        (lambda: RecordContacts(min_spacing_m=-1.0), "min_spacing_m"),
    ],
)
def test_bad_parameter_values_name_the_parameter(make, needle):
    with pytest.raises(ValueError, match=needle):
        make()


def test_set_parameter_goes_through_the_same_checks_and_updates_derived_state():
    leaf = ForceHold(kp=1e-6, ki=0.0)
    leaf.set_parameter("kp", 2e-6)
    leaf.set_parameter("output_limit", 0.001)
    assert leaf.pid.kp == [2e-6] and leaf.pid.output_limit == [0.001]
    with pytest.raises(ValueError, match="kp"):
        leaf.set_parameter("kp", -1.0)
    with pytest.raises(ValueError, match="fixed"):
        leaf.set_parameter("name", "other")
    slide = GuidedSlide()
    slide.set_parameter("twist", (0.03, 0.04, 0.0, 0.0, 0.0, 0.0))
    assert slide._speed == pytest.approx(0.05)
    with pytest.raises(ValueError, match="twist"):
        slide.set_parameter("twist", (1.0, 2.0))
    roll = Roll()
    with pytest.raises(ValueError, match="fixed"):
        roll.set_parameter("roll_radius", 0.1)


def test_bind_blackboard_in_python():
    from tactile_bt.tree.behaviours import bind_blackboard

    leaf = Centre()
    bind_blackboard(leaf, "target_m", "/goal/cop")
    h = LeafHarness(leaf, dt=DT)
    h.set("/goal/cop", (PITCH, 0.0))
    h.tick(make_features(cop_px=(7.5, 7.5)))
    assert leaf.target_m == (PITCH, 0.0)
    assert h.errors["cop_x_px"] == pytest.approx(-1.0)
    with pytest.raises(ValueError, match="fixed"):
        bind_blackboard(RecordContacts(), "point", "/x")
    with pytest.raises(ValueError, match="no parameter"):
        bind_blackboard(Centre(), "target_pa", "/x")


@pytest.mark.parametrize(
    "leaf,features,expected",
    [
        (lambda: ForceHold(), make_features(pressure=1500.0), "pressure_pa=-500"),
        (lambda: Centre(), make_features(cop_px=(9.5, 7.5)), "cop_x_px=+2"),
        (lambda: AlignEdge(), make_features(orientation=1.5), "orientation_rad"),
        (lambda: ForceHold(), make_features(in_contact=False), "no contact"),
        (lambda: Approach(), make_features(in_contact=False), "approaching, 0.1 mm"),  # 10 mm/s for 1/128 s
        (lambda: GuidedSlide(), make_features(), "sliding, 0.2 mm"),
        (lambda: GuidedSlide(), make_features(in_contact=False), "waiting for contact"),
        (lambda: ContactLost(), make_features(in_contact=False), "no contact for 0.00 s"),
        (lambda: ForceLimit(), make_features(pressure=2000.0, area=40), "force 2.00 N"),
        (lambda: RecordContacts(), make_features(), "1 contacts"),
        (lambda: RecordContacts(), make_features(in_contact=False), "0 contacts, not in contact"),
        (lambda: MissionTimeout(GuidedSlide(), duration_s=2.0), make_features(), "0.00 / 2 s"),
    ],
)
def test_every_leaf_says_what_it_is_doing(leaf, features, expected):
    h = LeafHarness(leaf(), dt=DT)
    h.tick(features)
    assert expected in h.behaviour.feedback_message


def test_feedback_after_finishing():
    h = LeafHarness(Approach(pressure_pa=800.0), dt=DT)
    h.tick(make_features(in_contact=False))
    h.tick(make_features(pressure=900.0))
    assert h.behaviour.feedback_message == "contact at 900 Pa after 0.1 mm"
    h = LeafHarness(ForceLimit(limit_n=1.0), dt=DT)
    h.tick(make_features(pressure=2000.0, area=40))
    assert h.behaviour.feedback_message == "force 2.00 N above the limit 1 N"
