"""The pad's geometry (tactile_bt.sense.geometry.PadGeometry) is the one place for its size and
its tactel <-> metre conversions, and a scene's ``sensor.pitch``, ``rows`` and ``cols`` reach every
part of a mission: perception, calibration, the leaves' px units and logged errors, the contact
recorder, the arm and the replay."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt.errors import TreeError
from tactile_bt.mission.replay import replay_mission
from tactile_bt.mission.run import run_mission
from tactile_bt.perception.features import extract
from tactile_bt.sense.calibration import NOMINAL_SATURATION_PA, TactelCalibration
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.sim.scene import load_scene
from tactile_bt.testing import LeafHarness, contact_frame, fresh_blackboard, make_features
from tactile_bt.tree.behaviours import Centre, RecordContacts
from tactile_bt.tree.behaviours.contact_points import imprint_points
from tactile_bt.tree.loader import load_tree
from tactile_bt.tree.parameters import bind_blackboard, parse_quantity

ROOT = Path(__file__).resolve().parents[2]
PITCH = 0.004
ROWS, COLS = 12, 20
OVERRIDES = [f"sensor.pitch={PITCH}", f"sensor.rows={ROWS}", f"sensor.cols={COLS}"]
SMALL = PadGeometry(ROWS, COLS, PITCH)


@pytest.fixture(autouse=True)
def _clean_blackboard():
    with fresh_blackboard():
        yield


# --------------------------------------------------------------------------- PadGeometry itself
def test_centre_of_the_default_pad_is_7_5_and_its_size_is_80_mm():
    pad = PadGeometry()
    assert pad.centre_px == (7.5, 7.5)
    assert pad.shape == (16, 16) and pad.tactels == 256
    assert_allclose(pad.size_m, (0.08, 0.08))
    assert_allclose(pad.tactel_area_m2, 25e-6)
    assert_allclose(pad.half_width_m, 0.04)
    assert_allclose(pad.half_diagonal_m, 0.04 * np.sqrt(2.0))
    assert_allclose(pad.px_to_m(pad.centre_px), (0.0, 0.0), atol=1e-15)


def test_centre_and_corners_of_a_12_by_20_pad():
    assert SMALL.centre_px == (9.5, 5.5)  # x along the 20 columns, y along the 12 rows
    assert_allclose(SMALL.size_m, (0.08, 0.048))
    corners = SMALL.corners_m()
    assert corners.shape == (4, 3)
    assert_allclose(np.abs(corners[:, :2]), [[0.04, 0.024]] * 4)
    assert_allclose(corners[:, 2], 0.0)
    assert {tuple(np.sign(c[:2])) for c in corners} == {(-1, -1), (1, -1), (1, 1), (-1, 1)}
    # the outer tactels' centres lie half a pitch inside the corners
    assert_allclose(SMALL.px_to_m([[0, 0], [COLS - 1, ROWS - 1]]), [[-0.038, -0.022], [0.038, 0.022]])
    assert_allclose(SMALL.half_diagonal_m, np.hypot(0.04, 0.024))
    assert_allclose(SMALL.half_width_m, 0.04)


@pytest.mark.parametrize("seed", range(5))
def test_px_and_metres_round_trip(seed):
    rng = np.random.default_rng(seed)
    pad = PadGeometry(int(rng.integers(1, 40)), int(rng.integers(1, 40)), float(rng.uniform(1e-4, 0.02)))
    px = rng.uniform(-5.0, 45.0, size=(50, 2))
    m = pad.px_to_m(px)
    assert_allclose(pad.m_to_px(m), px, rtol=1e-12, atol=1e-9)
    assert_allclose(pad.px_to_m(pad.m_to_px(m)), m, rtol=1e-12, atol=1e-15)
    # one tactel is one pitch, and the per-cycle scalar form agrees with the array form
    assert_allclose(np.diff(pad.px_to_m([[0.0, 0.0], [1.0, 1.0]]), axis=0), [[pad.pitch, pad.pitch]])
    for (x, y), expected in zip(px[:5], m[:5]):
        assert_allclose(pad.xy_px_to_m(x, y), expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("rows, cols, pitch", [(0, 16, 0.005), (16, -1, 0.005), (2.5, 16, 0.005),
                                               (16, 16, 0.0), (16, 16, -0.005), (16, 16, float("nan")),
                                               (16, 16, float("inf"))])
def test_a_pad_without_tactels_or_pitch_is_an_error(rows, cols, pitch):
    with pytest.raises(ValueError, match="a pad needs"):
        PadGeometry(rows, cols, pitch)


# --------------------------------------------------------------------------- perception, calibration
def test_features_convert_with_the_pad_they_were_extracted_with():
    image = contact_frame(cop_px=(13.0, 4.0), force_n=1.5, pad=SMALL)
    f = extract(image, pad=SMALL)
    assert f.pad is SMALL
    assert_allclose(f.cop_px, (13.0, 4.0), atol=0.05)
    assert_allclose(f.cop, SMALL.px_to_m(f.cop_px))
    assert_allclose(f.cop, ((13.0 - 9.5) * PITCH, (4.0 - 5.5) * PITCH), atol=0.05 * PITCH)
    assert_allclose(f.pressure, f.force / (f.area * PITCH**2))
    with pytest.raises(ValueError, match="12x20 tactels, the pad 16x16"):
        extract(image, pad=PadGeometry())


def test_the_nominal_calibration_saturates_at_10_kpa_on_the_pads_tactel():
    cal = TactelCalibration.nominal(pad=SMALL)
    assert cal.shape == (ROWS, COLS)
    assert_allclose(cal.saturation_force, NOMINAL_SATURATION_PA * PITCH**2, rtol=1e-3)
    assert_allclose(TactelCalibration.nominal().saturation_force, 0.25, rtol=1e-3)
    assert TactelCalibration.random(np.random.default_rng(0), pad=SMALL).shape == (ROWS, COLS)
    with pytest.raises(ValueError, match="differ from the pad"):
        TactelCalibration.nominal(16, 16, pad=SMALL)


# --------------------------------------------------------------------------- leaves
def test_centre_logs_its_cop_error_in_tactels_of_the_harness_pad():
    h = LeafHarness(Centre(), pad=SMALL)
    assert h.features.pad is SMALL  # the default features: a centred contact on this pad
    h.tick()
    assert_allclose([h.errors["cop_x_px"], h.errors["cop_y_px"]], [0.0, 0.0], atol=1e-12)  # default: centred
    cx, cy = SMALL.centre_px
    h.tick(make_features(cop_px=(cx + 1.0, cy - 2.0), pad=SMALL))
    assert_allclose([h.errors["cop_x_px"], h.errors["cop_y_px"]], [1.0, -2.0], rtol=1e-12)
    assert "cop_x_px=+1" in h.behaviour.feedback_message
    # the twist follows the error in metres: 1 px is 4 mm here (kp 4/s: 16 mm/s)
    assert_allclose(abs(h.twist[0]), Centre().pid.kp[0] * PITCH, rtol=1e-9)


def test_centre_logs_in_default_tactels_under_the_default_pad():
    h = LeafHarness(Centre())
    h.tick(make_features(cop_px=(8.5, 7.5)))
    assert_allclose(h.errors["cop_x_px"], 1.0, rtol=1e-12)


def test_a_blackboard_reference_in_tactels_uses_the_pad_on_the_blackboard():
    leaf = Centre(converge=True)
    bind_blackboard(leaf, "band", "/goal/band")
    h = LeafHarness(leaf, pad=SMALL)
    h.set("/goal/band", "0.5 px")
    h.tick()
    assert_allclose(leaf.band, [0.5 * PITCH] * 2)


def test_load_tree_converts_tactels_with_the_pad_given():
    text = "root:\n  centre: {name: c, target_m: [1 px, 0 mm], band: 0.5 tactel}\n"
    default = load_tree("t.yaml", text=text)
    small = load_tree("t.yaml", text=text, pad=SMALL)
    assert_allclose(default.root.band, [0.0025] * 2)
    assert_allclose(default.root.target_m, (0.005, 0.0))
    assert_allclose(small.root.band, [0.002] * 2)
    assert_allclose(small.root.target_m, (0.004, 0.0))
    assert small.pad is SMALL and len(small.pad_fields) == 2
    assert small.pad_fields[0].startswith("t.yaml:2:") and small.pad_fields[0].endswith("centre.target_m")
    assert_allclose(parse_quantity("2 px", "m", SMALL), 0.008)
    assert_allclose(parse_quantity("2 px", "m"), 0.010)


def test_record_contacts_maps_the_imprint_through_the_features_pad():
    image = contact_frame(cop_px=(15.0, 5.5), force_n=2.0, length_px=0.0, width_px=3.0, pad=SMALL)
    f = extract(image, pad=SMALL)
    points, pressure = imprint_points(f)
    assert len(points) > 5
    assert_allclose(points[:, :2].mean(axis=0), ((15.0 - 9.5) * PITCH, 0.0), atol=0.3 * PITCH)
    assert np.all(np.abs(points[:, :2]) <= (0.04, 0.024))
    assert np.all(pressure > 0)
    # the recorder carries a line's local contact point through the pad: point = T_gs . cop
    line = contact_frame(cop_px=(15.0, 5.5), force_n=2.0, orientation_rad=np.pi / 2, length_px=6.0, width_px=2.0,
                         pad=SMALL)
    leaf = RecordContacts(point="local", max_pressure_ratio=np.inf)  # 2 N on 12 tactels: 10 kPa
    h = LeafHarness(leaf, pad=SMALL)
    h.tick(frame=line)
    assert len(h.contacts) == 1
    assert_allclose(h.contacts.points[0, :2], h.features_raw.cop, atol=0.3 * PITCH)


# --------------------------------------------------------------------------- missions
def test_a_pen_mission_on_a_4_mm_pad_logs_the_pressure_of_4_mm_tactels():
    result = run_mission(ROOT / "trees" / "force_hold.yaml", ROOT / "sim" / "pen.yaml", duration=2.5,
                         overrides=OVERRIDES)
    assert result.report["status"] == "completed"
    log = result.log
    touching = log["in_contact"] == 1
    assert touching.sum() > 100
    force, area, pressure = log["force_n"][touching], log["area"][touching], log["pressure_raw_pa"][touching]
    assert_allclose(pressure, force / (area * PITCH**2), rtol=1e-9)
    # the frames are 12x20 tactels: every COP lies on that grid
    assert np.nanmin(log["cop_x_px"]) >= 0 and np.nanmax(log["cop_x_px"]) <= COLS - 1
    assert np.nanmin(log["cop_y_px"]) >= 0 and np.nanmax(log["cop_y_px"]) <= ROWS - 1


def test_a_cable_mission_on_a_12_by_20_pad_records_points_on_the_cable(tmp_path):
    record = tmp_path / "cable.tbr"
    result = run_mission(ROOT / "trees" / "cable_follow.yaml", ROOT / "sim" / "cable.yaml", duration=3.0,
                         overrides=OVERRIDES, recording=record)
    report = result.report
    assert report["status"] == "completed" and report["contacts"] > 300
    # px -> m with the 4 mm pitch and the 12x20 centre puts the contacts on the true cable
    assert report["path_error_m"]["mean"] < 2e-3
    assert report["path_error_cop_m"]["mean"] < 2e-3
    assert report["path_error_m"]["followed_m"] > 0.03
    # the COP servo logged its error in tactels of this pad
    assert np.isfinite(result.log["error_cop_x_px"]).sum() > 100
    # the arm bounds its steps by this pad's half diagonal
    world = load_scene(ROOT / "sim" / "cable.yaml", OVERRIDES).build_world(np.random.default_rng(0))
    assert_allclose(world.mount.arm.pad_radius, SMALL.half_diagonal_m)
    assert world.sensor.calibration.shape == (ROWS, COLS)

    # the replay rebuilds the pad from the recording: the same errors, in the same tactels
    replay = replay_mission(ROOT / "trees" / "cable_follow.yaml", record)
    for key in ("pressure_raw_pa", "error_cop_x_px", "error_cop_y_px"):
        assert_allclose(replay.log[key], result.log[key], equal_nan=True)


def test_a_tree_loaded_for_another_pitch_is_refused(tmp_path):
    tree_file = tmp_path / "centre.yaml"
    tree_file.write_text("root:\n  centre: {band: 0.5 px}\n")
    with pytest.raises(TreeError, match=r"centre.band: lengths in tactels were converted with a 5 mm pitch.*4 mm"):
        run_mission(load_tree(tree_file), ROOT / "sim" / "pen.yaml", duration=0.02, overrides=OVERRIDES)
    # loaded with the scene's pad it runs; so does a tree without tactels
    run_mission(load_tree(tree_file, pad=SMALL), ROOT / "sim" / "pen.yaml", duration=0.02, overrides=OVERRIDES)
    tree_file.write_text("root:\n  centre: {band: 2 mm}\n")
    run_mission(load_tree(tree_file), ROOT / "sim" / "pen.yaml", duration=0.02, overrides=OVERRIDES)
