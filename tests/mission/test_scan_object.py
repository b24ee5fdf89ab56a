"""Exploration by touch of an unknown object on a table: the table guards (the pad's lowest corner
through the forward kinematics, table contacts left out of the cloud), the contact placement
that keeps the pad's border off the table, the frontier planner and the mission's set-up keys,
on scripted poses and frames (tactile_bt.testing)."""

import math
from pathlib import Path

import numpy as np
import py_trees
import pytest
from numpy.testing import assert_allclose
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.control.spatial import exp_twist, make_pose
from tactile_bt.errors import BlackboardReferenceError
from tactile_bt.mission.loop import root_outcome, success_reason
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.testing import LeafHarness, contact_frame, make_features
from tactile_bt.tree.behaviours import (TactileBehaviour, Centre, CentreTo, CoverageStalled, FrontierGuidance, RecordContacts, Roll,
                                        RollTo, SquareToSlope, TableClearance, TableOffset)
from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, lowest_corner, pad_clearance
from tactile_bt.tree.behaviours.surface_end import ATTEMPT_END_KEY
from tactile_bt.tree.behaviours.supervision import REASON, RETREATING
from tactile_bt.contacts.frontier_map import EXPLAINING, WRIST
from tactile_bt.tree.blackboard import JOINTS_HELD, POSE, TURN_ROOM
from scan_helpers import disc, ticks_until_done

REPO = Path(__file__).resolve().parents[2]
DT = 1.0 / 250.0
DOWN = Rotation.from_euler("x", 180, degrees=True)  # pad facing down: x_s = x_g, y_s = -y_g
PAD = PadGeometry()  # 16 x 16 tactels at 5 mm: 80 mm square


def tilted(deg: float, about: str = "y", yaw_deg: float = 0.0) -> Rotation:
    """The pad facing down, turned ``yaw_deg`` about its normal, then tilted ``deg`` about the
    world axis ``about``."""
    return Rotation.from_euler(about, deg, degrees=True) * DOWN * Rotation.from_euler("z", yaw_deg, degrees=True)


def pose(rotation: Rotation, position) -> np.ndarray:
    return make_pose(rotation, position)


# ------------------------------------------------------------------------- the pad's corners


def test_lowest_corner_of_a_level_and_a_tilted_pad():
    level = pose(DOWN, (0.1, 0.2, 0.05))
    assert pad_clearance(level, PAD, 0.0) == pytest.approx(0.05)
    assert pad_clearance(level, PAD, 0.01) == pytest.approx(0.04)
    assert pad_clearance(level, PAD, math.nan) == math.inf  # no table known
    # tilted 30° about world y: the edge at x = +40 mm goes down by 40 mm * sin 30°
    t = pose(tilted(30), (0.0, 0.0, 0.05))
    assert pad_clearance(t, PAD, 0.0) == pytest.approx(0.05 - 0.040 * 0.5)
    assert lowest_corner(t, PAD)[0] == pytest.approx(0.040 * math.cos(math.radians(30)))
    # a frame 2 mm wide around the sensing area lowers it by 2 mm * sin 30°
    assert pad_clearance(t, PAD, 0.0, margin_m=0.002) == pytest.approx(0.05 - 0.042 * 0.5)
    # turned 45° about its normal a corner points downhill: half the diagonal
    c = pose(tilted(30, yaw_deg=45), (0.0, 0.0, 0.05))
    assert pad_clearance(c, PAD, 0.0) == pytest.approx(0.05 - 0.040 * math.sqrt(2) * 0.5)


@pytest.mark.parametrize("height, status", [(0.030, Status.RUNNING), (0.021, Status.RUNNING),
                                            (0.0195, Status.FAILURE), (0.010, Status.FAILURE)])
def test_table_clearance_guard_on_the_lowest_corner(height, status):
    # tilted 30°: the lowest corner lies 20 mm below the pad centre; the limit is 1 mm
    h = LeafHarness(TableClearance(min_clearance_m=0.001), pose=pose(tilted(30), (0.0, 0.0, height)))
    h.set(TABLE_Z_KEY, 0.0)
    assert h.tick(frame=contact_frame()) == status
    if status == Status.FAILURE:
        assert "above the table" in h.behaviour.feedback_message
        assert h.behaviour.clearance_m == pytest.approx(height - 0.020)


def test_table_clearance_follows_the_pad_as_it_tilts_and_needs_no_contact():
    h = LeafHarness(TableClearance(min_clearance_m=0.002), pose=pose(DOWN, (0.0, 0.0, 0.03)))
    h.set(TABLE_Z_KEY, 0.005)
    ticks = 0
    for deg in np.arange(0.0, 60.0, 1.0):
        h.set_pose(pose(tilted(deg, about="x"), (0.0, 0.0, 0.03)))
        ticks += 1
        if h.tick(make_features(in_contact=False)) == Status.FAILURE:
            break
    # fails at the first tilt whose edge (40 mm) comes within 2 mm of the table 5 mm up
    expected = math.degrees(math.asin((0.03 - 0.005 - 0.002) / 0.040))
    assert ticks - 1 == math.ceil(expected)


@pytest.mark.parametrize("value", [None, math.nan])
def test_table_clearance_without_a_known_table_never_fails(value):
    h = LeafHarness(TableClearance(), pose=pose(tilted(80), (0.0, 0.0, 0.0)))
    if value is not None:
        h.set(TABLE_Z_KEY, value)
    assert h.tick(frame=contact_frame()) == Status.RUNNING
    assert h.behaviour.feedback_message == "no table in the set-up"


def test_a_table_height_that_is_not_a_number_is_an_error():
    h = LeafHarness(TableClearance(), pose=pose(DOWN, (0.0, 0.0, 0.05)))
    h.set(TABLE_Z_KEY, "high")
    with pytest.raises(BlackboardReferenceError, match="table's height"):
        h.tick()


class _Twist(TactileBehaviour):
    """Adds a fixed sensor-frame twist every tick: what the servo leaves of a scan add."""

    def __init__(self, twist, name: str | None = None) -> None:
        super().__init__(name)
        self._twist = tuple(float(v) for v in twist)

    def update(self) -> Status:
        self.command.add(self.name, self._twist)
        return Status.RUNNING


def _braked_run(twist, start, seconds=2.0, limits=(np.inf, np.inf), sink_mps=0.0, sink_s=np.inf, may_fail=False,
                **guard):
    """A leaf adding ``twist`` and, after it, a braking guard; the pad moved by the cycle's twist
    (within the twist ``limits``, m/s and rad/s) each tick, and lowered by ``sink_mps`` (world z)
    beyond it for the first ``sink_s``. Returns the guard, the corner heights and the twists
    applied; the run ends where the guard fails if ``may_fail`` (a failure is an assertion error
    otherwise)."""
    guard = TableClearance(min_clearance_m=0.0005, recover_s=1.0, brake_s=0.2, **guard)
    root = py_trees.composites.Parallel("scan", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                        children=[_Twist(twist), guard])
    h = LeafHarness(root, pose=start)
    h.command.linear_limit, h.command.angular_limit = limits
    h.set(TABLE_Z_KEY, 0.0)
    heights, applied = [], []
    T = start
    for i in range(int(seconds / DT)):
        status = h.tick(frame=contact_frame())
        if may_fail and status == Status.FAILURE:
            break
        assert status == Status.RUNNING, guard.feedback_message
        V = h.command.twist()
        applied.append(V)
        T = T @ exp_twist(V, DT)
        if i * DT < sink_s:
            T[2, 3] -= sink_mps * DT
        h.set_pose(T)
        heights.append(pad_clearance(T, PAD, 0.0))
    return guard, np.array(heights), np.array(applied)


def test_the_brake_slows_a_roll_towards_the_table_and_the_corner_stays_above_the_limit():
    # the pad tilted 20°, its lowest corner 10 mm up, rolling on at 1 rad/s towards the table:
    # unbraked, the corner would reach the table within 0.2 s
    guard, heights, applied = _braked_run((0.0, 0.0, 0.0, 0.0, -1.0, 0.0), pose(tilted(20), (0.0, 0.0, 0.0237)))
    assert heights[0] > 0.009
    assert heights.min() >= 0.0005 + 0.001 - 1e-4  # above the limit and its margin
    assert guard.trips == 0 and guard.braked
    assert abs(applied[0][4]) > 0.5 and abs(applied[-1][4]) < 0.01  # full speed, then almost stopped


def test_the_brake_keeps_the_slide_and_lifts_what_the_translation_alone_would_lower():
    # a slide along the pad (sensor x) while pressing in (sensor z, down the tilted normal)
    start = pose(tilted(20), (0.0, 0.0, 0.016))
    guard, heights, applied = _braked_run((0.01, 0.0, 0.01, 0.0, 0.0, 0.0), start, seconds=3.0)
    assert heights.min() >= 0.0005 + 0.001 - 1e-4
    assert heights[-1] < 0.002  # it came down to the brake's floor
    # the lift is along the world's z only: across the table the pad moves as commanded
    R = start[:3, :3]
    world = applied[:, :3] @ R.T
    assert_allclose(world[:, :2], np.tile((R @ [0.01, 0.0, 0.01])[:2], (len(world), 1)), atol=1e-9)
    assert guard.trips == 0


def test_the_brake_holds_while_the_slide_is_at_the_twist_limit():
    # the servo's parts add up to a slide six times the linear limit (50 mm/s), backing off a
    # little, while the pad rolls its corner down: the limits scale the whole translation, and
    # its lift, which the brake had counted on against the roll, shrank with it while the roll
    # did not (a narrow groove's scan put its corner onto the table so; here the guard failed,
    # the pad touching the table). The corner stays above the brake's floor, and the slide goes on.
    start = pose(tilted(20), (0.0, 0.0, 0.02))
    limits = (defaults.TWIST_LINEAR_LIMIT_MPS, defaults.TWIST_ANGULAR_LIMIT_RPS)
    guard, heights, applied = _braked_run((0.0, 0.3, -0.03, 0.0, -0.5, 0.0), start, seconds=1.0, limits=limits)
    assert heights.min() >= 0.0005 + 0.001 - 1e-4
    assert guard.trips == 0 and guard.braked
    assert np.linalg.norm(applied[:, :3], axis=1).max() <= limits[0] + 1e-12  # within the limit as sent
    assert np.linalg.norm(applied[-1, :3] @ start[:3, :3].T[:, :2]) > 0.02  # still sliding across


def test_the_brake_lifts_against_a_sinking_the_twist_does_not_explain():
    # a compliant arm pivoting the pad about an edge: the pad sinks at 10 mm/s (world z) while
    # the twist holds it still. The brake measures the sinking and lifts against it; the corner
    # settles above the limit. Reckoning with the twist alone, it never brakes and the pad lands.
    start = pose(tilted(20), (0.0, 0.0, 0.02))
    guard, heights, applied = _braked_run((0.0,) * 6, start, seconds=2.0, sink_mps=0.01, sink_tau_s=0.05)
    assert heights.min() >= 0.0005 and guard.trips == 0 and guard.braked
    assert_allclose(guard.sink_mps.min(), -0.01, rtol=0.05)
    assert abs(heights[-1] - heights[-50]) < 1e-4  # held: the lift balances the sinking
    blind, heights, _ = _braked_run((0.0,) * 6, start, seconds=2.0, sink_mps=0.01, may_fail=True)  # off by default
    assert blind.status == Status.FAILURE and "touches the table" in blind.feedback_message


def test_a_tripped_guard_lifts_the_pad_until_the_corner_is_back_at_the_brake_s_floor():
    # the compliant arm sinks the pad at 10 mm/s (world z) for 0.4 s while the twist holds it
    # still, and the brake, reckoning with the twist alone, does not see it: without the lift the
    # corner reaches the table and the guard fails
    start = pose(tilted(20), (0.0, 0.0, 0.0167))  # the lowest corner 3 mm up
    blind, _, _ = _braked_run((0.0,) * 6, start, seconds=1.0, sink_mps=0.01, sink_s=0.4, may_fail=True)
    assert blind.status == Status.FAILURE and "touches the table" in blind.feedback_message
    # with it, the pad rises at 20 mm/s from each trip until the corner is 1.5 mm up, and neither
    # turns nor slides meanwhile; the corner never reaches the table and the guard goes on
    guard, heights, applied = _braked_run((0.0,) * 6, start, seconds=1.0, sink_mps=0.01, sink_s=0.4,
                                          lift_mps=0.02)
    assert heights.min() > 0.0004 and guard.status == Status.RUNNING and guard.trips == 1
    lifting = np.isclose(applied[:, :3] @ start[2, :3], 0.02)  # the world's z, in the sensor frame
    assert_allclose(applied[lifting], np.tile(np.r_[0.02 * start[2, :3], 0.0, 0.0, 0.0], (lifting.sum(), 1)))
    # the lift from the tick the corner came below 0.5 mm to the tick it was 1.5 mm up again
    before = np.r_[0.0167 - 0.040 * math.sin(math.radians(20)), heights[:-1]]  # the corner when each twist was made
    first, last = np.flatnonzero(lifting)[[0, -1]]
    assert lifting[first:last + 1].all()
    assert before[first] < 0.0005 <= before[first - 1] and before[last] < 0.0015 <= before[last + 1]
    assert py_trees.blackboard.Blackboard.storage["/scan/table_alarm"] is None
    summary = guard.summary()  # what report.json shows under "table"
    assert summary["trips"] == 1 and summary["cycles"] == len(heights)
    assert summary["lifted_s"] == pytest.approx(lifting.sum() * DT)
    assert summary["lowest_clearance_m"] == pytest.approx(before.min())


@pytest.mark.slow
def test_the_report_says_how_near_the_table_the_pad_came(tmp_path):
    from tactile_bt import run_mission
    from tactile_bt.mission.report import MissionReport

    result = run_mission(REPO / "trees" / "scan_object.yaml", REPO / "sim" / "object.yaml", duration=4.0,
                         reconstruct="none", out=tmp_path)
    table = result.report["table"]
    assert table["node"] == "table_clearance" and 0 < table["cycles"] < result.report["ticks"]  # from the scan on
    assert table["trips"] == 0 and table["lifted_s"] == 0.0 and 0.0 <= table["braked_share"] <= 1.0
    # the lowest corner the guard saw is the lowest the log's poses put the pad's corners at
    log = result.log
    lowest = min(pad_clearance(make_pose(R, p), PAD, 0.0) for R, p in zip(log["rotation"], log["position_m"]))
    assert table["lowest_clearance_m"] == pytest.approx(lowest, abs=2e-3)
    saved = MissionReport.load(tmp_path)
    assert saved.table == table
    shown = f"  table guard      lowest corner {table['lowest_clearance_m'] * 1e3:.1f} mm above the table, 0 trips, braking"
    assert any(line.startswith(shown) for line in saved.summary_lines())
    saved.table = {**table, "trips": 1, "lifted_s": 0.12}
    assert any(", 1 trip, lifted 0.12 s, braking" in line for line in saved.summary_lines())


def test_a_lift_that_a_contact_holds_back_is_no_sinking():
    # the twist lifts the pad at 10 mm/s (world z) while a contact holds it back to 1 mm/s: the
    # corners rise less than asked, but they do not come down, and that is no sinking
    start = pose(tilted(20), (0.0, 0.0, 0.02))
    up = start[2, :3]  # the world's z in the sensor frame
    guard, heights, _ = _braked_run(tuple(0.01 * up) + (0.0, 0.0, 0.0), start, seconds=0.5, sink_mps=0.009,
                                    sink_tau_s=0.05)
    assert np.all(np.diff(heights) > 0.0)
    assert (guard.sink_mps == 0.0).all()


def test_the_brake_ignores_motion_that_lifts_the_pad_beyond_its_twist():
    start = pose(tilted(20), (0.0, 0.0, 0.02))
    guard, heights, applied = _braked_run((0.0,) * 6, start, seconds=0.5, sink_mps=-0.01, sink_tau_s=0.05)
    assert not guard.braked and (guard.sink_mps == 0.0).all()
    assert_allclose(applied, 0.0)


def test_without_a_brake_the_same_roll_trips_the_guard():
    guard = TableClearance(min_clearance_m=0.0005, recover_s=1.0)
    root = py_trees.composites.Parallel("scan", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                        children=[_Twist((0.0, 0.0, 0.0, 0.0, -1.0, 0.0)), guard])
    T = pose(tilted(20), (0.0, 0.0, 0.0237))
    h = LeafHarness(root, pose=T)
    h.set(TABLE_Z_KEY, 0.0)
    for _ in range(100):
        if h.tick(frame=contact_frame()) != Status.RUNNING:
            break
        T = T @ exp_twist(h.command.twist(), DT)
        h.set_pose(T)
    assert guard.trips >= 1


@pytest.mark.slow
@pytest.mark.parametrize("value", ["abc", "inf", "true", "[0, 1]"])
def test_a_bad_table_height_on_the_command_line_is_one_error_line_before_the_run(tmp_path, value):
    import subprocess
    import sys

    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "tactile_bt.cli", "run", "trees/scan_object.yaml", "--scene",
                          "sim/object.yaml", "--blackboard", f"/setup/table_z_m={value}", "--out", str(out)],
                         capture_output=True, text=True, timeout=120, cwd=REPO)
    assert run.returncode != 0
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "/setup/table_z_m" in lines[0]
    assert "Traceback" not in run.stderr
    assert not (out / "report.json").exists()  # nothing ran


# ------------------------------------------------------------------ no table contacts recorded


@pytest.mark.parametrize("point", ["cop", "region"])
@pytest.mark.parametrize("z, kept", [(0.0010, False), (0.0014, False), (0.0016, True), (0.03, True)])
def test_record_contacts_leaves_out_contacts_at_the_table(point, z, kept):
    """The pad facing down touches something at height z (scripted frames); with the table at
    0 and a margin of 1.5 mm, contacts below 1.5 mm are the table's."""
    h = LeafHarness(RecordContacts(point=point, table_margin_m=0.0015), pose=pose(DOWN, (0.01, 0.02, z)))
    h.set(TABLE_Z_KEY, 0.0)
    h.tick(frame=contact_frame(force_n=2.0))
    assert (len(h.contacts) > 0) == kept
    if kept:
        assert np.all(h.contacts.points[:, 2] > 0.0015)


def test_record_contacts_keeps_everything_without_a_table_or_a_margin():
    for margin, table in ((0.0015, None), (0.0, 0.0)):
        h = LeafHarness(RecordContacts(point="cop", table_margin_m=margin), pose=pose(DOWN, (0.0, 0.0, 0.0005)))
        if table is not None:
            h.set(TABLE_Z_KEY, table)
        h.tick(frame=contact_frame())
        assert len(h.contacts) == 1
        py_trees.blackboard.Blackboard.clear()


def test_record_region_drops_the_part_of_an_imprint_at_the_table():
    # tilted 30° about world y: the imprint's samples run from 20 mm below to 20 mm above the
    # pad centre, which lies 15 mm above the table
    h = LeafHarness(RecordContacts(point="region", table_margin_m=0.0015), pose=pose(tilted(30), (0.0, 0.0, 0.015)))
    h.set(TABLE_Z_KEY, 0.0)
    full = np.full((16, 16), 0.05)  # the whole pad pressed evenly
    h.tick(frame=full)
    z = h.contacts.points[:, 2]
    assert len(z) > 100 and z.min() > 0.0015
    assert z.max() > 0.03


# ----------------------------------------------------------------------- placing the contact


def offset_harness(height: float, tilt_deg: float, **kw) -> LeafHarness:
    h = LeafHarness(TableOffset(**kw), pose=pose(tilted(tilt_deg), (0.0, 0.0, height)))
    h.set(TABLE_Z_KEY, 0.0)
    return h


def test_table_offset_moves_the_contact_downhill_just_enough():
    # tilted 40° about world y: downhill is world +x, sensor +x (x_s = x_g when facing down)
    h = offset_harness(0.025, 40.0, clearance_m=0.006, max_offset_m=0.035, rate_mps=0.04, smoothing_s=0.1)
    for _ in range(1000):  # 4 s: 40 time constants of the low-pass filter
        h.tick(frame=contact_frame())
    target = np.asarray(py_trees.blackboard.Blackboard.storage["/scan/cop_target"])
    reach = (0.025 - 0.006) / math.sin(math.radians(40))  # of the border downhill of the contact
    assert_allclose(target, [0.040 - reach, 0.0], atol=1e-9)
    # with the contact there, the lowest corner is clearance_m above the table
    sin = math.sin(math.radians(40))
    assert 0.025 - (0.040 - target[0]) * sin == pytest.approx(0.006)


def test_table_offset_is_bounded_rate_limited_and_slides_the_pad_the_other_way():
    h = offset_harness(0.010, 60.0, clearance_m=0.006, max_offset_m=0.03, rate_mps=0.02)
    h.tick(frame=contact_frame())
    target = np.asarray(py_trees.blackboard.Blackboard.storage["/scan/cop_target"])
    assert_allclose(target, [0.02 * DT, 0.0], atol=1e-12)  # one cycle at 20 mm/s
    # the pad slides the opposite way at the same speed, so the contact keeps its place
    assert_allclose(h.twist_of(h.behaviour)[:2], [-0.02, 0.0], atol=1e-9)
    for _ in range(2000):
        h.tick(frame=contact_frame())
    target = np.asarray(py_trees.blackboard.Blackboard.storage["/scan/cop_target"])
    assert_allclose(target, [0.03, 0.0], atol=1e-9)  # at most max_offset_m
    assert_allclose(h.twist_of(h.behaviour), 0.0, atol=1e-12)  # settled: no more sliding


@pytest.mark.parametrize("height, tilt_deg, table", [(0.05, 40.0, 0.0), (0.02, 0.0, 0.0), (0.02, 40.0, None)])
def test_table_offset_stays_centred_when_the_table_is_far_level_or_unknown(height, tilt_deg, table):
    h = LeafHarness(TableOffset(), pose=pose(tilted(tilt_deg), (0.0, 0.0, height)))
    if table is not None:
        h.set(TABLE_Z_KEY, table)
    for _ in range(50):
        h.tick(frame=contact_frame())
    assert_allclose(py_trees.blackboard.Blackboard.storage["/scan/cop_target"], [0.0, 0.0])


@pytest.mark.parametrize("cls, reference", [(CentreTo, Centre), (RollTo, Roll)])
def test_centre_to_and_roll_to_follow_their_key_every_cycle(cls, reference):
    leaf = cls(target_key="/test/cop", kp=2.0)
    h = LeafHarness(leaf)
    h.set("/test/cop", (0.0, 0.0))
    h.tick(make_features(cop_px=(9.5, 7.5)))  # the contact 10 mm off the centre along x
    first = h.twist_of(leaf)
    h.set("/test/cop", (0.01, 0.0))  # now the target is where the contact is
    h.tick(make_features(cop_px=(9.5, 7.5)))
    assert_allclose(h.twist_of(leaf), 0.0, atol=1e-12)
    h.set("/test/cop", (-0.005, 0.002))
    h.tick(make_features(cop_px=(9.5, 7.5)))
    ref = LeafHarness(reference(target_m=(-0.005, 0.002), kp=2.0))
    ref.tick(make_features(cop_px=(9.5, 7.5)))
    rows = [0, 1] if cls is CentreTo else [3, 4]  # roll_to also keeps the contact's height: row vz
    assert_allclose(h.twist[rows], ref.twist[rows], atol=1e-12)
    assert np.any(first != 0)


@pytest.mark.parametrize("cls, rows", [(CentreTo, [0, 1]), (RollTo, [3, 4])])
def test_with_all_regions_a_pad_bridging_two_contacts_servos_their_common_centre(cls, rows):
    # a flat pad on two rims of a hollow, the right one carrying a little more: the largest
    # region changes sides with the load, and the leaf that servos the largest region's centre
    # would swing from one border to the other; with all_regions it sees one centre between them
    from tactile_bt.perception.synthetic import line_contact

    def frame(left_share: float) -> np.ndarray:
        left = line_contact((1.0, 7.5), math.pi / 2, 12.0, 0.8, 3.0 * left_share)
        right = line_contact((14.0, 7.5), math.pi / 2, 12.0, 0.8, 3.0 * (1 - left_share))
        return left + right

    twists = {}
    for all_regions in (False, True):
        leaf = cls(target_key="/test/cop", kp=2.0, all_regions=all_regions)
        h = LeafHarness(leaf)
        h.set("/test/cop", (0.0, 0.0))
        twists[all_regions] = []
        for share in (0.52, 0.48):  # the larger load on the left, then on the right
            for _ in range(25):
                h.tick(frame=frame(share))
            twists[all_regions].append(h.twist_of(leaf)[rows].copy())
    swing = [float(np.linalg.norm(t[1] - t[0])) for t in (twists[False], twists[True])]
    assert swing[1] < 0.2 * swing[0]
    assert np.linalg.norm(twists[True][0]) < 0.2 * np.linalg.norm(twists[False][0])


@pytest.mark.parametrize("hold_s, pulled_back", [(0.3, True), (0.0, True), (0.3, False)])
def test_roll_to_holds_the_tilt_while_the_pad_rocks_between_two_rims(hold_s, pulled_back):
    """A flat pad resting on two opposite corners, the load passing from one to the other every
    60 ms: rolled towards the larger contact, the pad would press the other, which then bears
    more. Once the supervisor has pulled the pad back, the leaf stops adding a roll when the
    contact has changed sides twice, and rolls again once one contact stays. With
    ``rocking_hold_s: 0``, or without the supervisor's pull-back, it never stops."""
    from tactile_bt.perception.synthetic import blob_contact
    from tactile_bt.tree.behaviours.supervision import publish_supervision

    def frame(first_share: float) -> np.ndarray:
        return blob_contact((1.0, 1.0), 0.8, 2.0 * first_share) + blob_contact((14.0, 14.0), 0.8, 2.0 * (1 - first_share))

    leaf = RollTo(target_key="/test/cop", kp=6.0, output_limit=0.06, rocking_hold_s=hold_s)
    h = LeafHarness(leaf)
    h.set("/test/cop", (0.0, 0.0))
    publish_supervision(pulled_back, "pressure 4100 Pa above the limit 4000 Pa" if pulled_back else "")
    rolls = []
    for k in range(6):  # three changes of side each way
        for _ in range(15):
            h.tick(frame=frame(0.6 if k % 2 == 0 else 0.4))
            rolls.append(h.twist_of(leaf)[2:5].copy())
    rolls = np.array(rolls)
    publish_supervision(False, "")
    if hold_s and pulled_back:
        assert np.abs(rolls[:15]).max() > 0  # rolling towards the first corner
        assert_allclose(rolls[31:], 0.0)      # from the second change on: the tilt held
        assert "rocks between two contacts" in leaf.feedback_message
    else:
        assert np.sign(rolls[14, 1]) == -np.sign(rolls[29, 1]) == np.sign(rolls[44, 1])  # rocking
    for _ in range(int((0.5 + hold_s) / h.dt) + 5):  # one contact stays: rolling again
        h.tick(frame=blob_contact((1.0, 1.0), 0.8, 1.2))
    assert np.abs(h.twist_of(leaf)[3:5]).max() > 0


def test_square_to_slope_turns_an_edge_downhill():
    leaf = SquareToSlope(kp=2.0, output_limit=10.0)
    yaw = 30.0
    h = LeafHarness(leaf, pose=pose(tilted(35, yaw_deg=yaw), (0.0, 0.0, 0.05)))
    errors = []
    for _ in range(800):
        h.tick()
        w = h.twist_of(leaf)[5]
        errors.append(abs(leaf.error_rad))
        yaw += math.degrees(w * DT)  # the pad turns about its own normal as commanded
        h.set_pose(pose(tilted(35, yaw_deg=yaw), (0.0, 0.0, 0.05)))
    assert errors[0] == pytest.approx(math.radians(30), abs=1e-6)
    assert errors[-1] < math.radians(0.5)
    assert yaw == pytest.approx(0.0, abs=0.5)  # back to an edge downhill, the nearer way
    # level: nothing to do
    h.set_pose(pose(DOWN, (0.0, 0.0, 0.05)))
    h.tick()
    assert_allclose(h.twist_of(leaf), 0.0)


def test_square_to_slope_does_not_wind_the_wrist_beyond_its_turn_limit():
    leaf = SquareToSlope(max_turn_rad=math.radians(100))
    h = LeafHarness(leaf, pose=pose(tilted(35, yaw_deg=40.0), (0.0, 0.0, 0.05)))
    h.tick()
    assert leaf.error_rad == pytest.approx(math.radians(-40))  # the nearest edge: turn back 40°
    leaf.turned_rad = math.radians(-80)  # as if it had already turned 80° that way
    leaf.error_rad = math.nan
    h.tick()
    # not the other edge, 50° on: that turn would swing a corner downhill, towards the table;
    # it turns to the limit and holds there
    assert leaf.error_rad == pytest.approx(math.radians(-20))
    leaf.turned_rad = math.radians(-100)
    h.tick()
    assert leaf.error_rad == pytest.approx(0.0, abs=1e-9)
    # the downhill direction drifts on, past the pad's diagonal: the edge on the other side
    # is now the nearest, and within the limit
    h.set_pose(pose(tilted(35, yaw_deg=50.0), (0.0, 0.0, 0.05)))
    h.tick()
    assert leaf.error_rad == pytest.approx(math.radians(40))


def test_square_to_slope_never_swings_a_corner_downhill():
    """Whatever it turned before, the turn it asks for is at most 45° plus the hysteresis: the
    pad's lowest point passes no corner on its way to an edge."""
    leaf = SquareToSlope(max_turn_rad=math.radians(120))
    h = LeafHarness(leaf)
    for yaw in np.arange(-180.0, 180.0, 7.0):
        for turned in (-115.0, -60.0, 0.0, 60.0, 115.0):
            leaf.turned_rad = math.radians(turned)
            h.set_pose(pose(tilted(40, yaw_deg=yaw), (0.0, 0.0, 0.05)))
            h.tick()
            assert abs(leaf.error_rad) <= math.radians(55.0) + 1e-9
            assert abs(leaf.turned_rad) <= math.radians(120.0) + 0.01


# ----------------------------------------------------------------------------- the planner


def planner_harness(patch, contact_xy, height=0.05, rotation=DOWN, table=None, **kw):
    leaf = FrontierGuidance(key="/scan/guidance", replan_s=0.04, **kw)
    h = LeafHarness(leaf, pose=pose(rotation, (contact_xy[0], contact_xy[1], height)))
    h.contacts.extend(patch[0], patch[1], 2000.0, 0.0)
    if table is not None:
        h.set(TABLE_Z_KEY, table)
    return leaf, h


def guidance() -> np.ndarray:
    return np.asarray(py_trees.blackboard.Blackboard.storage["/scan/guidance"])


def test_planner_slides_towards_the_nearest_open_boundary():
    # a touched disc of 20 mm around the origin; the pad touches at x = 15 mm: the nearest
    # frontier is the rim at x = +20 mm, i.e. world +x = sensor +x
    leaf, h = planner_harness(disc(0.02), (0.015, 0.0), speed_mps=0.02)
    h.tick(make_features())
    v = guidance()
    assert np.linalg.norm(v[:2]) == pytest.approx(0.02)
    assert v[0] > 0.019 and v[2:].tolist() == [0, 0, 0, 0]
    assert leaf.target is not None


def test_planner_slows_near_the_pad_s_border_but_not_while_the_pad_bridges_a_hollow():
    # the largest region at the border: the slide would drag it off the pad, so the guidance
    # slows to a tenth; with the other rim of a hollow under the opposite border carrying a
    # third of the load, the pad rests on both and slides at full speed
    from tactile_bt.perception.synthetic import line_contact

    rim = line_contact((0.0, 7.5), math.pi / 2, 12.0, 0.8, 2.0)
    other = line_contact((15.0, 7.5), math.pi / 2, 12.0, 0.8, 1.0)
    speeds = []
    for frame in (rim, rim + other):
        leaf, h = planner_harness(disc(0.06), (0.0, 0.0), speed_mps=0.02)
        for _ in range(3):
            h.tick(frame=frame)
        speeds.append(float(np.linalg.norm(guidance()[:3])))
    assert speeds[0] == pytest.approx(0.002, rel=0.05)
    assert speeds[1] == pytest.approx(0.02, rel=1e-6)


def test_planner_marks_the_strip_a_pad_resting_on_two_rims_bridges_as_a_hollow():
    # with bridge_watch_s: two rims under opposite borders, the lesser carrying a third of the
    # load, for 2 s: the map marks the strip between them as a hollow, so that an untouched channel
    # there may count as a valley the flat pad bridges; one rim alone, or the watch off (the
    # default), marks nothing
    from tactile_bt.perception.synthetic import line_contact

    rim = line_contact((0.0, 7.5), math.pi / 2, 12.0, 0.8, 2.0)
    other = line_contact((15.0, 7.5), math.pi / 2, 12.0, 0.8, 1.0)
    marked = {}
    for case, frame, watch in (("two rims", rim + other, 1.5), ("one rim", rim, 1.5), ("watch off", rim + other, 0.0)):
        leaf, h = planner_harness(disc(0.06), (0.0, 0.0), speed_mps=0.02, bridge_watch_s=watch)
        for _ in range(round(2.0 / h.dt)):
            h.tick(frame=frame)
        marked[case] = leaf.map.hollow.copy()
        if case == "two rims":
            middle = leaf.map.cell_of(np.zeros((1, 2)))[0]  # the pad's centre, between the rims
            assert marked[case][middle[0], middle[1]]
            xy = leaf.map.centre_of(*np.nonzero(marked[case]))
            assert np.all(np.abs(xy) <= 0.04 + 1e-9)  # nothing beyond the rims
    assert not marked["one rim"].any() and not marked["watch off"].any()


def test_planner_succeeds_when_no_frontier_is_within_the_tilt_limit():
    tilt = math.radians(68)
    steep = (math.sin(tilt), 0.0, math.cos(tilt))  # every touched cell is tilted 68°
    leaf, h = planner_harness(disc(0.02, normal=steep), (0.0, 0.0), max_tilt_rad=math.radians(70),
                              tilt_margin_rad=math.radians(5))
    assert h.tick(make_features()) == Status.SUCCESS
    assert leaf.feedback_message.startswith("no reachable frontier left")
    assert_allclose(guidance(), 0.0)


def _closed_all_round(patch, cause):
    """A planner on a touched ``patch`` (30 mm above the table) whose whole rim is closed for
    ``cause``, after one replan; the status of the next."""
    leaf, h = planner_harness(patch, (0.0, 0.0), height=0.03, table=0.0, min_coverage=0.95)
    h.tick(make_features())
    leaf.map.close((0.0, 0.0), 0.05, cause)
    leaf.target, leaf._next_plan = None, -math.inf
    return leaf, h.tick(make_features())


def test_a_scan_stopped_all_round_by_the_arm_s_reach_fails_naming_the_surface_beyond_it():
    # a level disc of 20 mm the arm could go no further on: the surface beyond it goes on, so
    # the scan has not covered 0.95 of it, whatever explains why the pad stopped
    leaf, status = _closed_all_round(disc(0.02, z=0.03), "reach")
    assert status == Status.FAILURE
    assert "of frontier the arm could not reach" in leaf.feedback_message
    left = py_trees.blackboard.Blackboard.storage["/scan/frontier_left"]
    assert left["untouched_beyond_reach_m2"] > 0.1 * leaf.map.touched_area()
    assert left["estimated_coverage"] < 0.95
    # the same disc with its rim too steep to go on: nothing the scan is for lies beyond
    leaf, status = _closed_all_round(disc(0.02, z=0.03), "tilt")
    assert status == Status.SUCCESS


def test_planner_does_not_start_before_anything_is_touched_and_waits_without_contact():
    leaf, h = planner_harness((np.zeros((0, 3)), np.zeros((0, 3))), (0.0, 0.0))
    for _ in range(20):
        assert h.tick(make_features()) == Status.RUNNING
    assert h.tick(make_features(in_contact=False)) == Status.RUNNING
    assert leaf.feedback_message.startswith("waiting for contact")


def test_planner_leaves_out_frontier_at_the_table():
    # the touched patch lies 2 mm above the table: it is the table's edge, not the object's
    leaf, h = planner_harness(disc(0.02, z=0.002), (0.0, 0.0), height=0.002, table=0.0)
    assert h.tick(make_features()) == Status.SUCCESS


def test_planner_backs_off_uphill_when_the_pad_nears_the_table_and_blocks_that_way():
    # the touched disc (tilted 40° towards +x) lies 30 mm up; the pad, tilted as much, touches
    # it 5 mm from its rim at +x; its lowest edge is 40 mm * sin 40° = 25.7 mm below the contact
    tilt = math.radians(40)
    patch = disc(0.02, z=0.03, normal=(math.sin(tilt), 0.0, math.cos(tilt)))
    leaf, h = planner_harness(patch, (0.015, 0.0), height=0.03, rotation=tilted(40), table=0.0,
                              table_clearance_m=0.002)
    h.tick(make_features())
    assert leaf.target is not None and leaf.direction[0] > 0.9  # downhill, to the rim at +x
    # the pad sinks towards the table: its lowest corner passes 2 mm
    for z in np.arange(0.03, 0.025, -0.0005):
        h.set_pose(pose(tilted(40), (0.015, 0.0, z)))
        h.tick(make_features())
    assert leaf.blocks == 1 and "above the table" in leaf.last_end
    v = guidance()
    # backing off: uphill (the world's up is -x on this pad, sensor x = world x)
    assert v[0] < 0
    assert leaf.feedback_message.startswith("backing off")
    rows, cols, out = leaf.map.frontier()
    blocked = leaf.map.blocked[rows, cols].any(axis=1)
    assert np.all(out[blocked][:, 0] > 0)  # only the frontier facing +x was blocked


# ------------------------------------------------------- recovering from the table's guard


def sinking_scan(max_trips=0):
    """The touched disc of the test above, 30 mm up and tilted 40° towards +x; the pad touches
    it 5 mm from its rim at +x; in parallel, as in trees/scan_object.yaml, frontier_guidance
    (its own table test off, to leave it to the guard) and a recovering table_clearance guard
    (0.5 mm, 1 s)."""
    tilt = math.radians(40)
    leaf = FrontierGuidance(key="/scan/guidance", replan_s=0.04, table_clearance_m=0.0)
    guard = TableClearance(min_clearance_m=0.0005, recover_s=1.0, hit_m=0.0, max_trips=max_trips)
    root = py_trees.composites.Parallel("scan", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                        children=[leaf, guard])
    h = LeafHarness(root, pose=pose(tilted(40), (0.015, 0.0, 0.03)))
    h.contacts.extend(*disc(0.02, z=0.03, normal=(math.sin(tilt), 0.0, math.cos(tilt))), 2000.0, 0.0)
    h.set(TABLE_Z_KEY, 0.0)
    return leaf, guard, root, h


def sink(h, x: float, z_to: float, ticks: int = 20) -> Status:
    """Move the pad (tilted 40°; its lowest corner 25.7 mm below its centre) from where it is
    to ``x`` (m, world) and the height ``z_to``; the status of the last tick."""
    status = Status.RUNNING
    T = py_trees.blackboard.Blackboard.storage[POSE]
    for xi, zi in zip(np.linspace(T[0, 3], x, ticks), np.linspace(T[2, 3], z_to, ticks)):
        h.set_pose(pose(tilted(40), (xi, 0.0, zi)))
        status = h.tick(make_features())
        if status != Status.RUNNING:
            break
    return status


DROP = 0.040 * math.sin(math.radians(40))  # the lowest corner below the pad's centre (m)


def test_a_pad_corner_near_the_table_backs_off_and_the_scan_goes_on():
    leaf, guard, root, h = sinking_scan()
    h.tick(make_features())
    assert leaf.target is not None and leaf.direction[0] > 0.9  # downhill, to the rim at +x
    # the corner sinks to 0.2 mm above the table: the guard trips, but the scan goes on
    assert sink(h, 0.015, DROP + 0.0002) == Status.RUNNING
    assert guard.trips == 1 and guard.status == Status.RUNNING
    assert py_trees.blackboard.Blackboard.storage["/scan/table_alarm"] is not None
    assert leaf.ends["table"] == 1 and leaf.target is None
    assert leaf.feedback_message.startswith("backing off")
    assert guidance()[0] < 0  # uphill, away from the corner (sensor x = world x)
    rows, cols, out = leaf.map.frontier()
    blocked = leaf.map.blocked[rows, cols].any(axis=1)
    assert blocked.any() and np.all(out[blocked][:, 0] > 0)  # the frontier towards the table only
    # the pad backs off, up and away: the alarm ends and another frontier is chosen
    assert sink(h, 0.005, 0.04, ticks=50) == Status.RUNNING
    assert py_trees.blackboard.Blackboard.storage["/scan/table_alarm"] is None
    for _ in range(20):
        assert h.tick(make_features()) == Status.RUNNING
    assert leaf.target is not None and leaf.direction[0] < 0.9 and leaf.attempts == 2
    assert "table" in leaf.explained()


def test_a_supervisor_intervention_ends_the_attempt_and_the_pad_backs_off():
    leaf, h = planner_harness(disc(0.02), (0.015, 0.0), speed_mps=0.02)
    h.tick(make_features())
    assert leaf.target is not None and guidance()[0] > 0.019  # towards the rim at +x
    h.set(RETREATING, True)
    h.set(REASON, "pressure 4500 Pa above the limit 4000 Pa at 1.00 s")
    assert h.tick(make_features()) == Status.RUNNING
    assert leaf.ends["pressure"] == 1 and leaf.target is None
    assert leaf.feedback_message.startswith("backing off (the supervisor pulled back (pressure 4500 Pa")
    assert guidance()[0] < 0  # away from where it pressed
    rows, cols, out = leaf.map.frontier()
    blocked = leaf.map.blocked[rows, cols].any(axis=1)
    assert blocked.any() and np.all(out[blocked][:, 0] > 0)  # that way only
    assert "pressure" not in EXPLAINING  # a limit passed explains no frontier
    for _ in range(5):  # one intervention, one end, however long it lasts
        h.tick(make_features())
    assert leaf.ends["pressure"] == 1


@pytest.mark.parametrize("case", ["stays", "hits", "again"])
def test_the_table_guard_still_fails_the_scan_when_it_must(case):
    leaf, guard, root, h = sinking_scan(max_trips=3)
    h.tick(make_features())
    if case == "stays":  # 0.2 mm above the table, and it does not get clear within 1 s
        assert sink(h, 0.015, DROP + 0.0002) == Status.RUNNING
        _, status = ticks_until_done(h, int(1.2 / h.dt))
        expected = "not clear after backing off 1.0 s"
    elif case == "hits":  # through the limit onto the table at once
        status = sink(h, 0.015, DROP - 0.0005, ticks=10)
        expected = "the pad touches the table"
    else:  # it comes back, the third time ends it
        for _ in range(3):
            status = sink(h, 0.015, DROP + 0.0002)
            if status != Status.RUNNING:
                break
            assert sink(h, 0.015, DROP + 0.01) == Status.RUNNING
        expected = "trip 3 of at most 3"
    assert status == Status.FAILURE
    outcome, reason = root_outcome(root)
    assert outcome == "failure"
    assert reason.startswith("table_clearance: the pad's corner is") and expected in reason
    assert py_trees.blackboard.Blackboard.storage["/scan/table_alarm"] is None


def test_a_scan_that_ends_by_touch_reports_why():
    leaf = FrontierGuidance(key="/scan/guidance")
    tilt = math.radians(80)
    root = py_trees.composites.Parallel(
        "scan", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[leaf, CoverageStalled(window_s=100)])
    h = LeafHarness(root, pose=pose(DOWN, (0.0, 0.0, 0.05)))
    h.contacts.extend(*disc(0.02, normal=(math.sin(tilt), 0.0, math.cos(tilt))), 2000.0, 0.0)
    assert h.tick(make_features()) == Status.SUCCESS
    status, reason = root_outcome(root)
    assert status == "success"
    assert reason.startswith("frontier_guidance: no reachable frontier left")
    assert success_reason(root) == reason
    # a tree that succeeds without such a leaf gives no reason
    plain = py_trees.behaviours.Success("done")
    plain.tick_once()
    assert root_outcome(plain) == ("success", "")


def test_no_frontier_left_is_a_failure_while_edges_leave_it_unexplained():
    # a flat touched disc whose rim every attempt ended at, at an edge: the surface beyond may go
    # on, so the scan has no evidence that it is done
    leaf, h = planner_harness(disc(0.02), (0.0, 0.0))
    assert h.tick(make_features()) == Status.RUNNING
    for angle in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
        leaf.map.block((0.0, 0.0), 0.03, (math.cos(angle), math.sin(angle)), cause="edge")
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE
    assert "unexplained" in leaf.feedback_message and "edge" in leaf.feedback_message
    left = leaf.frontier_left()
    assert left["unexplained"]["edge"] > 2 * math.pi * 0.02 * 0.6 and not left["explained"]


def test_an_unexplained_frontier_is_re_approached_once_and_what_it_found_is_applied():
    leaf, h = planner_harness(disc(0.02), (0.0, 0.0), reapproach_key="/scan/reapproach")
    assert h.tick(make_features()) == Status.RUNNING
    for angle in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
        leaf.map.block((0.0, 0.0), 0.03, (math.cos(angle), math.sin(angle)), cause="stall")
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and leaf.feedback_message.startswith("re-approaching the frontier")
    job = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    point, normal = job["probe"]
    assert np.linalg.norm(point[:2]) > 0.03  # beyond the rim (20 mm)
    # the re-approach found the table there: that part of the rim is explained
    job["result"] = "table"
    leaf.initialise()
    for _ in range(10):
        h.tick(make_features())
    assert leaf.frontier_left()["explained"].get("table", 0.0) > 0.01
    assert leaf.ends["re-approach: table"] == 1



def _rim_explained_but_an_arc(leaf, radius_m, half_angle_rad):
    """Close the rim of a touched disc as the table's, but for an arc at +x of ``half_angle_rad``
    either side, where slides stalled."""
    for angle in np.linspace(-math.pi, math.pi, 144, endpoint=False):
        d = np.array([math.cos(angle), math.sin(angle)])
        if abs(angle) > half_angle_rad + 0.1:
            leaf.map.close(radius_m * d, 0.006, cause="table")
        elif abs(angle) <= half_angle_rad:
            leaf.map.block(radius_m * d, 0.006, d, cause="stall")


def _re_approached_and_stalled_again():
    """A level disc 50 mm above the table, its rim explained by the table but for a 25 mm arc:
    it is re-approached, the surface found there, and a slide stalls on the same arc again.
    Returns the leaf, its harness, the re-approach and the status after it."""
    leaf, h = planner_harness(disc(0.02), (0.0, 0.0), table=0.0, reapproach_key="/scan/reapproach",
                              min_coverage=0.95)
    assert h.tick(make_features()) == Status.RUNNING
    _rim_explained_but_an_arc(leaf, 0.02, 0.6)
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and leaf.feedback_message.startswith("re-approaching the frontier")
    job = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    job["result"] = "surface"
    leaf.initialise()
    h.tick(make_features())
    _rim_explained_but_an_arc(leaf, 0.02, 0.6)
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    return leaf, h, job, status


def test_frontier_a_re_approach_reopened_and_a_slide_stalled_at_again_is_probed_far_beyond():
    leaf, h, job, status = _re_approached_and_stalled_again()
    # nothing else left, the arc within 20 mm of the re-approach: a level pad lowered beyond it
    assert status == Status.FAILURE and leaf.feedback_message.startswith("probing beyond the frontier"), \
        leaf.feedback_message
    far = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    assert far["far"] and np.linalg.norm(far["frontier_xy"] - job["frontier_xy"]) <= 0.02
    assert far["approach_m"] == pytest.approx(0.05, abs=0.003)
    # it came down to the table touching nothing: the arc is explained, and the scan is done
    far["result"] = "table"
    leaf.initialise()
    _, status = ticks_until_done(h, 10)
    assert status == Status.SUCCESS, leaf.feedback_message
    assert not leaf.frontier_left()["unexplained"]
    assert leaf.ends["far re-approach: table"] == 1


def test_what_a_far_probe_found_is_taken_in_after_a_return_to_the_surface_that_followed_it():
    # the far probe came down to the table; the touch after it found nothing, and a return to
    # the last contact took the key: the far probe's finding still explains the arc
    leaf, h, job, status = _re_approached_and_stalled_again()
    far = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    far["result"] = "table"
    back = {"probe": job["probe"], "home": job["probe"], "top_z": 0.05, "return": True, "pending": far,
            "result": "surface"}
    py_trees.blackboard.Blackboard.storage["/scan/reapproach"] = back
    leaf.initialise()
    _, status = ticks_until_done(h, 10)
    assert status == Status.SUCCESS, leaf.feedback_message
    assert leaf.ends["far re-approach: table"] == 1 and far["applied"]


def test_frontier_tried_before_is_not_far_probed_while_the_estimate_falls_short(monkeypatch):
    from tactile_bt.tree.behaviours import frontier_jobs, frontier_left

    for module in (frontier_left, frontier_jobs):  # 10 cm² taken to lie beyond
        monkeypatch.setattr(module, "untouched_beyond", lambda *a, **k: 1e-3)
    leaf, h, job, status = _re_approached_and_stalled_again()
    assert leaf.coverage < 0.95
    assert status == Status.FAILURE and leaf.feedback_message.startswith("no reachable frontier left, but"), \
        leaf.feedback_message
    assert "stall" in leaf.frontier_left()["unexplained"]


def test_more_unexplained_frontier_than_a_far_probe_closes_is_not_far_probed():
    # the same on a disc of 50 mm with 100 mm of its rim stalled, every part of it re-approached
    leaf, h = planner_harness(disc(0.05, step=0.002), (0.0, 0.0), table=0.0, reapproach_key="/scan/reapproach",
                              min_coverage=0.95)
    assert h.tick(make_features()) == Status.RUNNING
    _rim_explained_but_an_arc(leaf, 0.05, 1.0)
    leaf.plan.tried = [0.05 * np.array([math.cos(a), math.sin(a)]) for a in np.linspace(-1.0, 1.0, 8)]
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and leaf.feedback_message.startswith("no reachable frontier left, but"), \
        leaf.feedback_message
    assert sum(leaf.frontier_left()["unexplained"].values()) > 0.08
    assert py_trees.blackboard.Blackboard.storage["/scan/reapproach"] == {"verdict": leaf.feedback_message}


def test_runs_of_unexplained_frontier_each_narrower_than_the_pad_are_far_probed():
    # the same disc with two 50 mm arcs stalled on opposite sides (100 mm in all, more than the
    # pad's width), every part of them re-approached: each arc is one far probe's worth
    leaf, h = planner_harness(disc(0.05, step=0.002), (0.0, 0.0), table=0.0, reapproach_key="/scan/reapproach",
                              min_coverage=0.95)
    assert h.tick(make_features()) == Status.RUNNING
    for angle in np.linspace(-math.pi, math.pi, 144, endpoint=False):
        d = np.array([math.cos(angle), math.sin(angle)])
        off = min(abs(angle), math.pi - abs(angle))  # from the nearer of +x and -x
        if off > 0.6:
            leaf.map.close(0.05 * d, 0.006, cause="table")
        elif off <= 0.5:
            leaf.map.block(0.05 * d, 0.006, d, cause="stall")
    arcs = np.concatenate((np.linspace(-0.5, 0.5, 5), math.pi + np.linspace(-0.5, 0.5, 5)))
    leaf.plan.tried = [0.05 * np.array([math.cos(a), math.sin(a)]) for a in arcs]
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    assert sum(leaf.frontier_left()["unexplained"].values()) > 0.08
    assert status == Status.FAILURE and leaf.feedback_message.startswith("probing beyond the frontier"), \
        leaf.feedback_message
    assert py_trees.blackboard.Blackboard.storage["/scan/reapproach"]["far"]


def _stalled_ring(inner_m, outer_m=0.1, **kw):
    """A planner on a level ring 30 mm above the table, from ``inner_m`` to ``outer_m`` out,
    its outer rim too steep to go on and every attempt at its inner rim stalled."""
    pts, normals = disc(outer_m, z=0.03, step=0.0015)
    ring = np.linalg.norm(pts[:, :2], axis=1) >= inner_m
    leaf, h = planner_harness((pts[ring], normals[ring]), (0.08, 0.0), height=0.03, table=0.0,
                              reapproach_key="/scan/reapproach", min_coverage=0.95, **kw)
    assert h.tick(make_features()) == Status.RUNNING
    _close_ring(leaf, inner_m, outer_m)
    return leaf, h, pts, normals


def _close_ring(leaf, inner_m, outer_m):
    for angle in np.linspace(0.0, 2 * math.pi, 96, endpoint=False):
        d = np.array([math.cos(angle), math.sin(angle)])
        leaf.map.close(inner_m * d, 0.005, cause="stall")
        leaf.map.close(outer_m * d, 0.005, cause="tilt")
    leaf.target = None


def test_a_hole_wider_than_the_pad_stalled_round_its_rim_is_probed_and_found_open_explains_it():
    # the ring's hole 90 mm across (wider than the pad, which slides over no rim into it): the
    # planner asks to lower the pad's corner into the hole before it sweeps the hole's sides
    # (which a flat pad's border cannot reach under a ring's rim) or re-approaches
    leaf, h, _, _ = _stalled_ring(0.045, max_hole_probes=2, max_sweeps=1)
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and leaf.feedback_message.startswith("probing the hole at"), leaf.feedback_message
    job = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    assert np.linalg.norm(job["hole"]["centre"]) < 0.003
    probes = job["hole"]["probes"]
    assert len(probes) == 5 and all(corner_z <= 0.02 for _, _, corner_z in probes)
    # the corner went down touching nothing: the rim faces a hole, and the scan is done, the band
    # the probe left along the rim counted as untouched, no sweep made
    job["result"] = "open"
    leaf.initialise()
    _, status = ticks_until_done(h, 10)
    assert status == Status.SUCCESS, leaf.feedback_message
    left = leaf.frontier_left()
    assert left["explained"].get("hole", 0.0) > 0.2 and not left["unexplained"]
    band = left["untouched_at_hole_rims_m2"]
    assert 0.5 * 2 * math.pi * 0.043 * 0.004 < band < 2 * 2 * math.pi * 0.043 * 0.004
    assert left["estimated_coverage"] < 1.0
    assert leaf.ends["hole probe: open"] == 1
    assert leaf.sweeps is None or not leaf.sweeps.swept


@pytest.mark.parametrize("corner_mm, cleared", [(3.0, True), (18.0, False)])
def test_the_band_along_an_open_hole_s_rim_leaves_the_estimate_where_the_corner_came_below_a_wall_at_the_tilt_limit(
        corner_mm, cleared):
    # the same ring, 30 mm above the table, its hole found open: where the corner, 6 mm inside the
    # rim, came down to 3 mm above the table touching nothing, the rim falls away steeper than
    # the pad may tilt (more than 16.5 mm over those 6 mm), and the band along it holds nothing
    # the pad could lie on but for the row of cells next to the touched edge (a rounded rim may
    # still lie within the tilt there); a corner that stopped 18 mm up shows only that the hole
    # is open
    leaf, h, _, _ = _stalled_ring(0.045, max_hole_probes=2, max_sweeps=1)
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and leaf.feedback_message.startswith("probing the hole at"), leaf.feedback_message
    job = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    job.update(result="open", outcomes=["open"] * len(job["hole"]["probes"]),
               reached=[corner_mm * 1e-3] * len(job["hole"]["probes"]))
    leaf.initialise()
    _, status = ticks_until_done(h, 10)
    assert status == Status.SUCCESS, leaf.feedback_message
    band = leaf.frontier_left()["untouched_at_hole_rims_m2"]
    whole = 2 * math.pi * 0.043 * 0.004  # a 4 mm band round the rim
    assert (0.4 * whole < band < 0.75 * whole) if cleared else (band > 0.85 * whole), band / whole
    assert leaf.ends["hole probe: open"] == 1


@pytest.mark.parametrize("probes", [2, 0])
def test_a_valley_the_touched_area_encloses_is_probed_before_its_sides_are_swept(probes):
    # the ring's hole 60 mm across, narrower than the pad, which bridges it: the estimate counts
    # the whole hole as untouched and falls short; the planner lowers the pad's corner into it
    # before it sweeps its sides, and the hole found open leaves the estimate but for the band
    # along its rim, which ends the scan with no sweep made; without probes, it sweeps
    leaf, h, _, _ = _stalled_ring(0.03, max_hole_probes=probes, max_sweeps=4)
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and leaf.coverage < 0.95, leaf.feedback_message
    # had the time run out now, the mission would say what the scan had left, and where
    assert leaf.standing().startswith(f"the scan so far: about {100 * (1 - leaf.coverage):.0f} % of the surface untouched")
    assert "in valleys narrower than the pad" in leaf.standing()
    if not probes:
        assert leaf.feedback_message.startswith("sweeping the side of the valley"), leaf.feedback_message
        return
    assert leaf.feedback_message.startswith("probing the valley at"), leaf.feedback_message
    assert leaf.sweeps is None or not leaf.sweeps.swept
    job = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    assert np.linalg.norm(job["hole"]["centre"]) < 0.003
    job["result"] = "open"
    leaf.initialise()
    _, status = ticks_until_done(h, 10)
    assert status == Status.SUCCESS, leaf.feedback_message
    assert 0.95 <= leaf.frontier_left()["estimated_coverage"] < 1.0
    assert leaf.ends["hole probe: open"] == 1
    assert leaf.sweeps is None or not leaf.sweeps.swept


def test_a_hole_whose_probe_touched_is_probed_again_once_sliding_has_shrunk_it():
    # the hole 140 mm across in the map: the corner, lowered near its edge, touched a wall under
    # the rim the pad had not reached yet; once the pad has touched that wall (the hole in the
    # map now 120 mm across), the hole is probed again, and found open
    leaf, h, pts, normals = _stalled_ring(0.07, 0.16, max_hole_probes=2)

    def probe_found(result):
        _, status = ticks_until_done(h, 10)
        assert status == Status.FAILURE and leaf.feedback_message.startswith("probing the hole at"), \
            leaf.feedback_message
        py_trees.blackboard.Blackboard.storage["/scan/reapproach"]["result"] = result
        leaf.initialise()
        return ticks_until_done(h, 10)[1]

    probe_found("touched")
    assert not leaf.feedback_message.startswith("probing the hole"), leaf.feedback_message  # not as it was
    wall = (np.linalg.norm(pts[:, :2], axis=1) >= 0.06) & (np.linalg.norm(pts[:, :2], axis=1) < 0.07)
    h.contacts.extend(pts[wall], normals[wall], 2000.0, 1.0)
    _close_ring(leaf, 0.06, 0.16)
    leaf.initialise()
    assert probe_found("open") == Status.SUCCESS, leaf.feedback_message
    assert leaf.ends["hole probe: touched"] == 1 and leaf.ends["hole probe: open"] == 1


WOUND = (7, 0.0, math.radians(340))  # the arm's turn room: joint 7 turns the pad about its normal, and is on its limit


@pytest.mark.parametrize("held, room, cause", [((7,), None, "reach"), ((), None, "contact lost"),
                                               ((7,), WOUND, "wrist"), ((2, 7), WOUND, "reach")])
def test_a_contact_lost_while_the_arm_holds_a_joint_at_its_limit_is_out_of_reach(held, room, cause):
    """... of the arm as it is, or of its wrist wound onto the stop of the joint that turns the
    pad about its normal (when that is the one joint held)."""
    leaf, h = planner_harness(disc(0.02), (0.015, 0.0))
    h.tick(make_features())
    assert leaf.target is not None
    h.set(JOINTS_HELD, held)  # what the mission writes after the arm moved
    h.set(TURN_ROOM, None if room is None else lambda: room)  # what the mission writes at the start
    h.tick(make_features())
    h.set(JOINTS_HELD, ())
    h.tick(make_features(in_contact=False))  # the pad could not follow: the contact is lost
    assert leaf.ends[cause] == 1 and leaf.blocks == 1
    for _ in range(20):  # in touch again: the planner chooses anew
        h.tick(make_features())
    left = leaf.frontier_left()
    if held:
        assert f"joint {' and '.join(map(str, held))} at its limit" in leaf.last_end
        assert left["explained"].get(cause, 0.0) > 0.0 and cause not in left["unexplained"]
    else:
        assert not left["explained"]


def test_when_the_coverage_falls_short_the_frontier_a_wound_wrist_stopped_is_re_approached(monkeypatch):
    from tactile_bt.tree.behaviours import frontier_jobs, frontier_left

    for module in (frontier_left, frontier_jobs):  # 10 cm² taken to lie beyond
        monkeypatch.setattr(module, "untouched_beyond", lambda *a, **k: 1e-3)
    leaf, h = planner_harness(disc(0.02), (0.0, 0.0), reapproach_key="/scan/reapproach", min_coverage=0.95)
    assert h.tick(make_features()) == Status.RUNNING
    for angle in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):  # the wrist stopped every way out
        leaf.map.block((0.0, 0.0), 0.03, (math.cos(angle), math.sin(angle)), cause=WRIST)
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    assert status == Status.FAILURE and "the wrist stopped" in leaf.feedback_message
    assert leaf.frontier_left()["explained"].get(WRIST, 0.0) > 0.0  # explained, but the coverage is short
    point, _ = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]["probe"]
    assert np.linalg.norm(point[:2]) > 0.03  # beyond the rim (20 mm)


def test_a_stalled_coverage_waits_for_a_border_sweep_the_planner_has_due():
    leaf = CoverageStalled(window_s=1.0, min_samples=10, frontier_key="/scan/frontier_left")
    h = LeafHarness(leaf, pose=pose(DOWN, (0.0, 0.0, 0.05)))
    h.contacts.extend(*disc(0.01), 2000.0, 0.0)  # and no more: the coverage stalls
    left = {"explained": {"table": 0.2}, "unexplained": {}, "estimated_coverage": 0.96, "sweep_due": True}
    h.set("/scan/frontier_left", left)
    assert all(h.tick(make_features()) == Status.RUNNING for _ in range(400))  # 2 s: stalled twice over
    assert "a border sweep is due first" in leaf.feedback_message
    h.set("/scan/frontier_left", {**left, "sweep_due": False})  # swept: the planner has nothing left to do
    assert h.tick(make_features()) == Status.SUCCESS
    assert leaf.feedback_message.startswith("coverage stalled")


@pytest.mark.parametrize("unexplained, status", [({"edge": 0.05}, Status.FAILURE), ({}, Status.SUCCESS)])
def test_a_stalled_coverage_with_unexplained_frontier_is_no_success(unexplained, status):
    leaf = CoverageStalled(window_s=1.0, min_samples=10, frontier_key="/scan/frontier_left")
    h = LeafHarness(leaf, pose=pose(DOWN, (0.0, 0.0, 0.05)))
    h.contacts.extend(*disc(0.01), 2000.0, 0.0)  # and no more: the coverage stalls
    h.set("/scan/frontier_left", {"explained": {"table": 0.2}, "unexplained": unexplained})
    result = Status.RUNNING
    for _ in range(400):
        result = h.tick(make_features())
        if result != Status.RUNNING:
            break
    assert result == status
    assert leaf.feedback_message.startswith("coverage stalled")
    assert ("50 mm unexplained (50 edge)" in leaf.feedback_message) == (status == Status.FAILURE)
    assert "200 mm explained (200 table)" in leaf.feedback_message


# ------------------------------------------------------------------------ the mission's set-up


def _storage(key):
    return py_trees.blackboard.Blackboard.storage.get(key)


def test_the_mission_writes_the_table_height_of_the_set_up(tmp_path):
    from tactile_bt import run_mission

    run_mission(str(REPO / "trees/force_hold.yaml"), str(REPO / "sim/pen.yaml"), duration=0.02,
                overrides=["objects.1.height=0.004"])
    assert _storage(TABLE_Z_KEY) == pytest.approx(0.004)
    # a scene without a table: NaN, the guards are off
    scene = tmp_path / "no_table.yaml"
    scene.write_text("name: no_table\nmount: {type: cartesian, position: [0, 0, 0.123], rpy_deg: [180, 0, 0]}\n"
                     "objects:\n  - {type: sphere, radius: 0.06, position: [0, 0, 0.06], stiffness: 1.0e3}\n")
    run_mission(str(REPO / "trees/force_hold.yaml"), str(scene), duration=0.02)
    assert math.isnan(_storage(TABLE_Z_KEY))


def test_a_calibrated_table_height_from_the_command_line_wins_over_the_scene():
    from tactile_bt import load_tree, run_mission

    tree = load_tree(str(REPO / "trees/scan_object.yaml"), blackboard=[f"{TABLE_Z_KEY}=0.012"])
    run_mission(tree, str(REPO / "sim/scan_box.yaml"), duration=0.02)
    assert _storage(TABLE_Z_KEY) == pytest.approx(0.012)


def test_roll_to_rolls_about_an_offset_contact_without_pressing_the_pad_in():
    leaf = RollTo(target_key="/test/cop", kp=6.0)
    h = LeafHarness(leaf)
    h.set("/test/cop", (0.03, 0.0))
    h.tick(make_features(cop_px=(12.5, 9.5)))  # the contact at x = 25 mm, y = 10 mm
    twist = h.twist_of(leaf)
    x, y = 0.025, 0.010
    assert twist[3] != 0 and twist[4] != 0
    # the contact point's speed v + ω × p has no component along the pad normal
    w = twist[3:]
    assert twist[2] + np.cross(w, [x, y, 0.0])[2] == pytest.approx(0.0, abs=1e-15)


def test_square_to_slope_turns_about_the_contact():
    leaf = SquareToSlope(kp=2.0)
    h = LeafHarness(leaf, pose=pose(tilted(35, yaw_deg=20.0), (0.0, 0.0, 0.05)))
    h.tick(make_features(cop_px=(1.5, 9.5)))  # the contact at x = -30 mm, y = 10 mm
    v = h.twist_of(leaf)
    assert v[5] != 0 and v[2:5].tolist() == [0, 0, 0]
    # the contact point's speed v + ω × p is zero: it keeps its place on the pad
    assert_allclose(v[:3] + np.cross(v[3:], [-0.03, 0.01, 0.0]), 0.0, atol=1e-15)


def test_an_attempt_that_ends_on_the_way_blocks_its_target_and_the_frontier_on_the_way():
    # a strip of touched surface along x; the pad at x = -30 mm heads for the rim along the
    # strip's +y side further on, and the attempt ends where it is
    pts, normals = disc(0.06, step=0.001)
    keep = np.abs(pts[:, 1]) <= 0.02
    leaf, h = planner_harness((pts[keep], normals[keep]), (-0.03, 0.015))
    h.tick(make_features())
    assert leaf.target is not None
    target = leaf._target_xy.copy()
    leaf._block(np.array([-0.03, 0.015, 0.05]), "test")
    rows, cols, out = leaf._candidates()
    xy = leaf.map.centre_of(rows, cols)
    assert not np.any(np.linalg.norm(xy - target, axis=1) < 1e-9)  # the target is out of reach


def _all_frontier_at_the_table(patch, contact, **kw):
    """A planner that requires 0.95 of the surface, every frontier of ``patch`` blocked by the
    table; its status once it has chosen again."""
    leaf, h = planner_harness(patch, contact[:2], height=contact[2], table=0.0, min_coverage=0.95, **kw)
    assert h.tick(make_features()) == Status.RUNNING
    for angle in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
        leaf.map.block(contact[:2], 0.1, (math.cos(angle), math.sin(angle)), cause="table")
    leaf.target = None
    _, status = ticks_until_done(h, 10)
    return leaf, status


def _face(lowest_m, length_m):
    """Contacts on a 40° face 60 mm wide, ``length_m`` long in world x, whose lowest lie
    ``lowest_m`` above the table (z = 0); and a contact point on it."""
    g = np.arange(0.0, length_m, 0.001)
    X, Y = np.meshgrid(g, np.arange(0.0, 0.06, 0.001) - 0.03)
    slope = math.radians(40)
    pts = np.column_stack((X.ravel(), Y.ravel(), lowest_m + X.ravel() * math.tan(slope)))
    normals = np.tile((-math.sin(slope), 0.0, math.cos(slope)), (len(pts), 1))
    return (pts, normals), (0.03, 0.0, 0.03)


def test_the_table_does_not_excuse_a_plane_face_left_above_it():
    # a 40° face 60 mm wide whose lowest contacts are 5 mm above the table: the pad stopped
    # there, but the face goes on 6 mm further down, about a tenth of what was touched
    leaf, status = _all_frontier_at_the_table(*_face(0.005, 0.06))
    assert status == Status.FAILURE
    assert "plane faces" in leaf.feedback_message and "near the table below" in leaf.feedback_message
    assert leaf.frontier_left()["estimated_coverage"] < 0.95


@pytest.mark.parametrize("sweeps", [0, 1])
def test_a_band_at_the_foot_worth_a_sweep_is_due_before_the_scan_may_end(sweeps):
    # the same face 120 mm long, 3 mm above the table: the band below is a few per cent of what
    # was touched, enough for the goal but worth a sweep. Where one is left to make, the planner
    # asks for it rather than succeed, and says it is due (coverage_stalled waits for it)
    leaf, status = _all_frontier_at_the_table(*_face(0.003, 0.12), reapproach_key="/scan/reapproach",
                                              max_sweeps=sweeps)
    left = py_trees.blackboard.Blackboard.storage["/scan/frontier_left"]
    assert 0.95 <= left["estimated_coverage"] < 0.99
    assert left["sweep_due"] == bool(sweeps)
    if sweeps:
        assert status == Status.FAILURE and leaf.feedback_message.startswith("sweeping the foot of the face")
        assert not leaf.frontier_left()["sweep_due"]  # the one sweep allowed is taken
    else:
        assert status == Status.SUCCESS, leaf.feedback_message


def test_a_side_rounding_off_to_the_table_is_explained_by_it():
    # a spherical cap (30 mm radius) touched down to 60°, 4 mm above the table: what lies below
    # steepens beyond anything touched
    r = 0.03
    g = np.arange(-r, r + 1e-9, 0.001)
    X, Y = np.meshgrid(g, g)
    rho = np.hypot(X, Y).ravel()
    keep = rho <= r * math.sin(math.radians(60))
    x, y = X.ravel()[keep], Y.ravel()[keep]
    z = np.sqrt(r * r - x * x - y * y)
    pts = np.column_stack((x, y, z - r * math.cos(math.radians(60)) + 0.004))
    normals = np.column_stack((x, y, z)) / r
    leaf, status = _all_frontier_at_the_table((pts, normals), (0.0, 0.0, pts[:, 2].max()))
    assert status == Status.SUCCESS, leaf.feedback_message
    assert leaf.frontier_left()["estimated_coverage"] == 1.0


def test_an_edge_the_pad_rolled_over_at_a_few_places_leaves_no_band_to_the_table():
    # a 60 mm level top 30 mm above the table; at three places on its edges the pad rolled over,
    # tilted 29°, and recorded its imprint in its own plane: 4 mm wide strips from 12 mm inside
    # to 6 mm beyond the edge, as if a 29° face went on down there. A face's frontier runs along
    # it; a few cells apart are the edge's, and the table explains them
    g = np.arange(-0.03, 0.03 + 1e-9, 0.001)
    X, Y = np.meshgrid(g, g)
    top = np.column_stack((X.ravel(), Y.ravel(), np.full(X.size, 0.03)))
    tilt = math.radians(29)
    strips = []
    for out, along in (((1.0, 0.0), -0.01), ((0.0, 1.0), 0.015), ((-1.0, 0.0), 0.005)):
        out = np.array(out)
        side = np.array([-out[1], out[0]])
        inside = np.abs(top[:, :2] @ side - along) <= 0.002
        top = top[~(inside & (top[:, :2] @ out >= 0.018))]
        s, a = np.meshgrid(np.arange(-0.012, 0.006 + 1e-9, 0.001), np.arange(-0.002, 0.002 + 1e-9, 0.001))
        xy = out * (0.03 + s.ravel()[:, None]) + side * (along + a.ravel()[:, None])
        z = 0.03 - np.maximum(s.ravel(), -0.012) * math.tan(tilt)
        n = np.tile((out[0] * math.sin(tilt), out[1] * math.sin(tilt), math.cos(tilt)), (len(xy), 1))
        strips.append((np.column_stack((xy, z)), n))
    pts = np.vstack([top] + [p for p, _ in strips])
    normals = np.vstack([np.tile((0.0, 0.0, 1.0), (len(top), 1))] + [n for _, n in strips])
    leaf, status = _all_frontier_at_the_table((pts, normals), (0.0, 0.0, 0.03))
    assert status == Status.SUCCESS, leaf.feedback_message
    assert leaf.frontier_left()["untouched_near_table_m2"] == 0.0


def test_a_return_to_the_last_contact_is_no_end_of_the_surface_and_no_re_approach():
    leaf, h = planner_harness(disc(0.02), (0.0, 0.0), reapproach_key="/scan/reapproach")
    h.tick(make_features())
    job = {"probe": (np.array([0.01, 0.0, 0.05]), np.array([0.0, 0.0, 1.0])), "top_z": 0.05, "return": True,
           "home": (np.array([0.01, 0.0, 0.05]), np.array([0.0, 0.0, 1.0])), "result": "surface"}
    h.set("/scan/reapproach", job)
    leaf.initialise()
    h.tick(make_features())
    assert job.get("applied") and not leaf.ends and not leaf.plan.tried


def test_a_verdict_of_an_earlier_scan_does_not_end_the_next_one():
    leaf, h = planner_harness(disc(0.02), (0.0, 0.0), reapproach_key="/scan/reapproach")
    h.set("/scan/reapproach", {"verdict": "no reachable frontier left, but 32 mm unexplained"})
    h.set(ATTEMPT_END_KEY, {"attempt": 1, "cause": "stall", "message": "stalled"})
    FrontierGuidance(key="/scan/guidance", reapproach_key="/scan/reapproach").setup()
    storage = py_trees.blackboard.Blackboard.storage
    assert storage["/scan/reapproach"] is None and storage[ATTEMPT_END_KEY] is None
