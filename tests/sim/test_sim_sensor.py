"""Simulated pad and objects: force images of a table and a cable, foam spread, raw frames,
cable geometry (polyline, signed lateral distance, distance to the centreline)."""

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.perception.features import extract, wrap_half_pi
from tactile_bt.sim.objects import CONTACT_REFERENCE_AREA_M2, Cable, Table, polyline_from_segments
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt.sim.world import CartesianMount, World
from tactile_bt.control.spatial import make_pose

PITCH = defaults.PITCH_M
FACE_DOWN = Rotation.from_euler("x", 180, degrees=True)  # sensor z (towards the object) = −world z


def model(seed=0, **params):
    return SensorModel(SensorParams(**params), np.random.default_rng(seed))


def spread_radius(sensor: SensorModel) -> int:
    """Reach of the foam's Gaussian in tactels (truncated at 2.5 σ)."""
    return max(1, int(np.ceil(2.5 * sensor.params.foam_spread)))


def series_stiffness(sensor: SensorModel, obj) -> float:
    """Per-area stiffness (Pa/m) of the foam in series with the object."""
    return 1.0 / (1.0 / sensor.params.foam_stiffness + 1.0 / obj.area_stiffness)


# --------------------------------------------------------------------------------- table


def test_pad_pressed_flat_on_a_table_gives_a_uniform_image():
    sensor, table = model(), Table(height=0.01, stiffness=1e6)
    depth = 0.3e-3
    T = make_pose(FACE_DOWN, (0.02, -0.03, 0.01 - depth))
    force, deepest = sensor.force_image(T, [table])
    assert deepest == pytest.approx(depth)
    # pressure = (foam in series with the table) × depth, on every tactel the foam's spread
    # cannot carry off the pad
    k = spread_radius(sensor)
    expected = series_stiffness(sensor, table) * depth * PITCH**2
    assert_allclose(force[k:-k, k:-k], expected, rtol=1e-9)
    # all but the outermost ring within a few % of each other
    interior = force[1:-1, 1:-1]
    assert np.ptp(interior) <= 0.03 * interior.mean()
    # the border passes part of its load off the pad, but is still loaded
    assert np.all(force > 0.5 * expected) and np.all(force <= expected * (1 + 1e-9))


def test_calibrated_raw_frame_of_a_flat_press_is_uniform_despite_tactel_spread():
    """The tactels' characteristics differ by ~15 %, so raw counts differ; the pad's own
    calibration undoes that (noise off, only 12-bit quantisation left)."""
    sensor, table = model(seed=4, noise_counts=0.0, noise_relative=0.0, noise_common=0.0), Table(height=0.0)
    T = make_pose(FACE_DOWN, (0.0, 0.0, -0.3e-3))
    force, _ = sensor.force_image(T, [table])
    raw = sensor.raw_frame(force)
    k = spread_radius(sensor)
    interior_raw = raw[k:-k, k:-k].astype(float)
    assert np.ptp(interior_raw) > 0.05 * interior_raw.mean()
    calibrated = sensor.calibration.force_from_raw(raw)[k:-k, k:-k]
    assert np.ptp(calibrated) <= 0.03 * calibrated.mean()
    assert calibrated.mean() == pytest.approx(force[k:-k, k:-k].mean(), rel=0.01)


def test_pad_in_the_air_feels_nothing():
    sensor = model()
    T = make_pose(FACE_DOWN, (0.0, 0.0, 0.002))  # 2 mm above the table
    force, deepest = sensor.force_image(T, [Table(height=0.0)])
    assert_array_equal(force, np.zeros((16, 16)))
    assert deepest == 0.0
    assert not extract(force).in_contact


def test_pad_facing_away_from_the_table_feels_nothing():
    """Upside down above the table top: the sensing surface is not in the table."""
    force, _ = model().force_image(make_pose(None, (0.0, 0.0, 0.001)), [Table(height=0.0)])
    assert not force.any()


def test_lifting_the_pad_after_a_press_releases_it():
    sensor, table = model(), Table(height=0.0)
    pressed, _ = sensor.force_image(make_pose(FACE_DOWN, (0, 0, -0.5e-3)), [table])
    assert pressed.min() > 0
    lifted, _ = sensor.force_image(make_pose(FACE_DOWN, (0, 0, 0.005)), [table])
    assert not lifted.any()


def test_pressure_feature_noise_matches_the_papers_sensor_noise_level():
    """Default noise: a steady 40-tactel contact at 2 kPa shows a pressure std of ~0.04 × target
    before smoothing (docs/architecture.md, paper Sec. V)."""
    sensor = model(seed=11)
    force = np.zeros((16, 16))
    force[4:12, 6:11] = 2000.0 * PITCH**2  # 40 tactels at 2 kPa
    pressure = np.array([extract(sensor.calibration.force_from_raw(sensor.raw_frame(force))).pressure
                         for _ in range(300)])
    assert pressure.mean() == pytest.approx(2000.0, rel=0.02)
    assert 0.03 <= pressure.std() / 2000.0 <= 0.05


def test_pressure_noise_on_a_cable_contact_at_the_target_is_the_papers_level():
    """The pad pressed on the cable of sim/cable.yaml until the clean pressure is 2 kPa."""
    from scipy.optimize import brentq

    from tactile_bt.sim.scene import load_scene

    scene = load_scene(Path(__file__).resolve().parents[2] / "sim" / "cable.yaml")
    sensor = SensorModel(scene.sensor, np.random.default_rng(5))
    T = make_pose(Rotation.from_euler("z", 180, degrees=True) * FACE_DOWN, (0.0, 0.04, 0.0))  # first straight

    def clean_pressure_error(z):
        T[2, 3] = z
        sensor.invalidate()
        return extract(sensor.force_image(T, scene.objects)[0]).pressure - 2000.0

    T[2, 3] = brentq(clean_pressure_error, 0.0045, 0.0059)
    sensor.invalidate()
    force, _ = sensor.force_image(T, scene.objects)
    samples = [extract(sensor.calibration.force_from_raw(sensor.raw_frame(force))) for _ in range(400)]
    pressure = np.array([f.pressure for f in samples])
    assert 30 <= np.mean([f.area for f in samples]) <= 70
    assert 0.03 <= pressure.std() / 2000.0 <= 0.05


# --------------------------------------------------------------------------------- cable


@pytest.mark.parametrize("yaw_deg", [0.0, 20.0])
@pytest.mark.parametrize("cable_deg", [0, 30, 45, 60, 75, 90, 120, 150])
def test_cable_under_the_pad_gives_a_line_along_the_cable(cable_deg, yaw_deg):
    th = np.deg2rad(cable_deg)
    d = np.array([np.cos(th), np.sin(th)])
    cable = Cable(path=np.array([-0.12 * d, 0.12 * d]), radius=0.003)
    R = Rotation.from_euler("z", yaw_deg, degrees=True) * FACE_DOWN
    T = make_pose(R, (0.0, 0.0, 2 * cable.radius - 1.0e-3))  # pressed 1 mm into the cable
    force, _ = model().force_image(T, [cable])
    f = extract(force, method="moments")
    assert f.in_contact and f.area >= 16
    d_s = R.as_matrix().T @ np.append(d, 0.0)  # cable direction in the sensor frame
    assert abs(d_s[2]) < 1e-12
    expected = np.arctan2(d_s[1], d_s[0])
    assert abs(np.rad2deg(wrap_half_pi(f.orientation - expected))) <= 2.0
    assert np.linalg.norm(f.cop) < 0.5e-3  # the cable runs through the pad centre


def test_cable_offset_shows_in_the_cop():
    """A cable 4 mm to the side of the pad centre: the COP lies on the cable's line."""
    offset = 0.004
    cable = Cable(path=np.array([[-0.1, offset], [0.1, offset]]), radius=0.003)
    R = Rotation.from_euler("z", 20, degrees=True) * FACE_DOWN
    T = make_pose(R, (0.0, 0.0, 2 * cable.radius - 1.0e-3))
    f = extract(model().force_image(T, [cable])[0])
    cop_world = T @ np.array([f.cop[0], f.cop[1], 0.0, 1.0])
    assert cop_world[1] == pytest.approx(offset, abs=0.5e-3)


def test_pressing_deeper_gives_more_force():
    cable = Cable(path=np.array([[-0.1, 0.0], [0.1, 0.0]]), radius=0.003)
    sensor = model()
    totals = []
    for depth in (0.2e-3, 0.5e-3, 1.0e-3):
        force, _ = sensor.force_image(make_pose(FACE_DOWN, (0.0, 0.0, 0.006 - depth)), [cable])
        totals.append(force.sum())
    assert totals[0] > 0 and np.all(np.diff(totals) > 0)


# --------------------------------------------------------------------------------- foam spread


def test_spread_conserves_an_interior_load():
    sensor = model()
    k = spread_radius(sensor)
    rng = np.random.default_rng(2)
    force = np.zeros((16, 16))
    force[k:-k, k:-k] = rng.uniform(0.0, 0.2, (16 - 2 * k, 16 - 2 * k))
    out = sensor.spread(force)
    assert out.sum() == pytest.approx(force.sum(), rel=1e-12)
    assert np.all(out >= 0.0)


def test_spread_of_a_point_load_is_a_symmetric_kernel_not_a_point():
    sensor = model()
    k = spread_radius(sensor)
    force = np.zeros((16, 16))
    force[6, 9] = 1.0
    out = sensor.spread(force)
    assert out.sum() == pytest.approx(1.0, rel=1e-12)
    assert out[6, 9] == out.max() and out[6, 9] < 1.0
    # the four neighbours get the same share, and the diagonal ones a smaller one
    n4 = [out[5, 9], out[7, 9], out[6, 8], out[6, 10]]
    assert n4[0] > 0 and np.allclose(n4, n4[0], rtol=1e-12)
    assert 0 < out[5, 8] < n4[0]
    patch = out[6 - k:6 + k + 1, 9 - k:9 + k + 1]
    for mirrored in (patch[::-1, :], patch[:, ::-1], patch.T):  # symmetric about both axes
        assert_allclose(patch, mirrored, rtol=1e-12)
    assert np.count_nonzero(out) == (2 * k + 1) ** 2  # truncated kernel


def test_spread_loses_load_over_the_border():
    sensor = model()
    force = np.zeros((16, 16))
    force[0, 0] = 1.0
    assert 0.0 < sensor.spread(force).sum() < 0.9


def test_no_spread_leaves_the_image_unchanged():
    force = np.random.default_rng(0).uniform(0, 1, (16, 16))
    assert_array_equal(model(foam_spread=0.0).spread(force), force)


# --------------------------------------------------------------------------------- raw frames


def test_raw_frame_is_12_bit_and_saturates():
    sensor = model()
    rng = np.random.default_rng(3)
    raw = sensor.raw_frame(rng.uniform(0.0, 0.3, (16, 16)))
    assert raw.dtype == np.uint16 and raw.shape == (16, 16)
    assert raw.min() >= 0 and raw.max() <= defaults.ADC_MAX
    # noisy readings of a crushed pad stay inside the ADC range, most at full scale
    saturated = sensor.raw_frame(np.full((16, 16), 100.0))
    assert saturated.max() == defaults.ADC_MAX and np.mean(saturated == defaults.ADC_MAX) > 0.9
    # negative or absurd inputs stay inside the ADC range too
    raw = sensor.raw_frame(np.full((16, 16), -1.0))
    assert raw.max() <= defaults.ADC_MAX


def test_raw_frame_saturates_at_full_scale_without_noise():
    sensor = model(calibration_spread=0.0, noise_counts=0.0, noise_relative=0.0, noise_common=0.0)
    assert_array_equal(sensor.raw_frame(np.full((16, 16), 1.0)), defaults.ADC_MAX)
    assert_array_equal(sensor.raw_frame(np.full((16, 16), 100.0)), defaults.ADC_MAX)
    # below saturation the raw value still grows with the force
    raw = sensor.raw_frame(np.linspace(0.0, 0.2, 256).reshape(16, 16)).ravel()
    assert np.all(np.diff(raw.astype(int)) >= 0) and raw[-1] < defaults.ADC_MAX


def test_raw_frame_of_an_unloaded_pad_is_its_offset_plus_noise():
    sensor = model(seed=1, noise_counts=2.0)
    frames = np.array([sensor.raw_frame(np.zeros((16, 16))) for _ in range(40)], dtype=float)
    residual = frames - sensor.calibration.offset
    assert abs(residual.mean()) < 0.1
    assert residual.std() == pytest.approx(2.0, rel=0.1)


def test_same_seed_gives_identical_frames_and_another_seed_does_not():
    force = np.zeros((16, 16))
    force[5:9, 4:12] = 0.05
    a, b, c = model(seed=7), model(seed=7), model(seed=8)
    frames_a = [a.raw_frame(force) for _ in range(3)]
    frames_b = [b.raw_frame(force) for _ in range(3)]
    for fa, fb in zip(frames_a, frames_b):
        assert_array_equal(fa, fb)
    assert not np.array_equal(frames_a[0], frames_a[1])  # fresh noise every frame
    assert not np.array_equal(frames_a[0], c.raw_frame(force))


def test_world_senses_and_moves_the_pad():
    table = Table(height=0.0)
    world = World([table], model(seed=0), CartesianMount(make_pose(FACE_DOWN, (0.0, 0.0, 0.001))))
    world.sense()
    assert world.last_penetration == 0.0
    # move down by 1.5 mm: a spatial twist of −z for 0.15 s at 10 mm/s
    world.move(np.array([0.0, 0.0, -0.01, 0.0, 0.0, 0.0]), 0.15)
    assert world.pose[2, 3] == pytest.approx(-0.5e-3)
    raw = world.sense()
    assert world.last_penetration == pytest.approx(0.5e-3)
    f = extract(world.calibration.force_from_raw(raw))
    assert f.in_contact and f.area > 200


# --------------------------------------------------------------------------------- polyline


@pytest.mark.parametrize("angle,end", [(90.0, (0.15, 0.1)), (-90.0, (0.15, -0.1))])
def test_polyline_straight_then_quarter_arc_ends_where_geometry_says(angle, end):
    R = 0.1
    pts = polyline_from_segments((0.0, 0.0), 0.0, [{"straight": 0.05}, {"arc": {"radius": R, "angle_deg": angle}}])
    assert_allclose(pts[0], [0.0, 0.0])
    assert_allclose(pts[-1], end, atol=1e-12)
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert step.max() <= 0.001 + 1e-12
    assert step.sum() == pytest.approx(0.05 + R * np.pi / 2, rel=1e-4)
    centre = np.array([0.05, np.sign(angle) * R])
    on_arc = pts[pts[:, 0] > 0.05 + 1e-12]
    assert_allclose(np.linalg.norm(on_arc - centre, axis=1), R, rtol=1e-12)


def test_polyline_heading_is_carried_through_the_arc():
    pts = polyline_from_segments((0.01, 0.02), 90.0, [{"arc": {"radius": 0.05, "angle_deg": 90}}, {"straight": 0.03}])
    # heading +y, left quarter turn (centre at −x) → heading −x, end of arc at (−0.04, 0.07)
    assert_allclose(pts[-1], [0.01 - 0.05 - 0.03, 0.02 + 0.05], atol=1e-12)


def test_polyline_rejects_unknown_segments():
    with pytest.raises(ValueError, match="straight"):
        polyline_from_segments((0, 0), 0, [{"spiral": 1}])


# --------------------------------------------------------------------------------- cable geometry


@pytest.fixture(scope="module")
def diagonal_cable():
    d = np.array([np.cos(0.6), np.sin(0.6)])
    return Cable(path=np.array([-0.05 * d, 0.05 * d]), radius=0.003), d


def test_lateral_distance_is_signed_left_positive_and_exact_on_a_straight(diagonal_cable):
    cable, d = diagonal_cable
    left = np.array([-d[1], d[0]])  # d rotated by +90°
    rng = np.random.default_rng(6)
    along = rng.uniform(-0.04, 0.04, 50)
    lateral = rng.uniform(-0.012, 0.012, 50)
    xy = along[:, None] * d + lateral[:, None] * left
    assert_allclose(cable.lateral_distance(xy), lateral, atol=1e-9)


def test_lateral_distance_on_an_arc_is_close_to_exact():
    R = 0.08
    path = polyline_from_segments((0.0, 0.0), 0.0, [{"arc": {"radius": R, "angle_deg": 90}}])
    cable = Cable(path=path)
    centre = np.array([0.0, R])  # left turn from heading +x: the centre is on the left
    rng = np.random.default_rng(8)
    phi = rng.uniform(-np.pi / 2 + 0.2, -0.2, 40)
    rho = R + rng.uniform(-0.008, 0.008, 40)
    xy = centre + rho[:, None] * np.stack((np.cos(phi), np.sin(phi)), axis=1)
    # inside the turn (towards the centre) is the left side: positive
    assert_allclose(cable.lateral_distance(xy), R - rho, atol=1e-4)


def test_distance_to_centreline_for_known_points():
    R = 0.1
    path = polyline_from_segments((0.0, 0.0), 0.0, [{"straight": 0.05}, {"arc": {"radius": R, "angle_deg": 90}}])
    cable = Cable(path=path)
    pts = np.array([
        [0.02, 0.003],  # beside the straight
        [0.03, -0.007],  # other side
        [-0.003, -0.004],  # beyond the start: distance to the end point
        [0.05, R],  # the arc's centre
        [0.05 + (R + 0.005) * np.cos(-np.pi / 4), R + (R + 0.005) * np.sin(-np.pi / 4)],  # outside the arc
    ])
    expected = [0.003, 0.007, 0.005, R, 0.005]
    assert_allclose(cable.distance_to_centreline(pts), expected, atol=2e-6)


def test_cable_sdf_and_bounds():
    cable = Cable(path=np.array([[-0.05, 0.0], [0.05, 0.0]]), radius=0.003, table_height=0.01)
    pts = np.array([[0.0, 0.0, 0.013], [0.0, 0.0, 0.016], [0.0, 0.005, 0.013], [0.0, 0.0, 0.0125]])
    assert_allclose(cable.sdf(pts), [-0.003, 0.0, 0.002, -0.0025], atol=1e-9)
    lo, hi = cable.bounds()
    assert lo[2] == 0.01 and hi[2] == pytest.approx(0.016)
    assert cable.area_stiffness == pytest.approx(cable.stiffness / CONTACT_REFERENCE_AREA_M2)


def test_cable_rejects_a_bad_path():
    with pytest.raises(ValueError):
        Cable(path=np.array([[0.0, 0.0]]))
