"""SE(3) helpers: adjoint (paper Eq. 4), exponential, integration."""

import numpy as np
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import (adjoint, body_to_spatial, exp_twist, integrate_spatial, invert, make_pose,
                                        pad_point, transform_points)


def random_pose(rng):
    return make_pose(Rotation.random(random_state=rng.integers(1 << 31)), rng.normal(size=3))


def test_invert_round_trip():
    rng = np.random.default_rng(1)
    T = random_pose(rng)
    assert_allclose(T @ invert(T), np.eye(4), atol=1e-12)


def test_body_to_spatial_equals_adjoint_matrix():
    rng = np.random.default_rng(2)
    for _ in range(5):
        T = random_pose(rng)
        V = rng.normal(size=6)
        assert_allclose(body_to_spatial(T, V), adjoint(T) @ V, atol=1e-12)


def test_exp_rotation_matches_scipy():
    rng = np.random.default_rng(3)
    for _ in range(10):
        V = rng.normal(size=6)
        dt = 0.3
        T = exp_twist(V, dt)
        assert_allclose(T[:3, :3], Rotation.from_rotvec(V[3:] * dt).as_matrix(), atol=1e-12)


def test_exp_of_pure_translation_and_small_steps_compose():
    V = np.array([0.1, -0.2, 0.3, 0.0, 0.0, 0.0])
    assert_allclose(exp_twist(V, 2.0)[:3, 3], 2 * V[:3])
    # Ten small steps equal one large step of the same constant twist.
    V = np.array([0.01, 0.02, -0.01, 0.3, -0.2, 0.5])
    T = np.eye(4)
    for _ in range(10):
        T = exp_twist(V, 0.01) @ T
    assert_allclose(T, exp_twist(V, 0.1), atol=1e-12)


def test_spatial_twist_moves_the_sensor_as_its_body_twist():
    """V_g = Ad(T_gs) V_s: integrating either gives the same motion of the sensor."""
    rng = np.random.default_rng(4)
    T = random_pose(rng)
    V_s = rng.normal(size=6) * 0.1
    dt = 0.05
    by_body = T @ exp_twist(V_s, dt)
    by_spatial = integrate_spatial(T, body_to_spatial(T, V_s), dt)
    assert_allclose(by_spatial, by_body, atol=1e-12)


def test_transform_points():
    T = make_pose(Rotation.from_euler("z", 90, degrees=True), (1.0, 0.0, 0.0))
    assert_allclose(transform_points(T, np.array([[1.0, 0.0, 0.0]])), [[1.0, 1.0, 0.0]], atol=1e-12)


def test_a_point_in_the_pad_plane_goes_to_the_world_as_the_pose_takes_it():
    rng = np.random.default_rng(7)
    for _ in range(5):
        T = random_pose(rng)
        x, y = rng.normal(scale=0.04, size=2)
        assert_allclose(pad_point(T, x, y), transform_points(T, np.array([[x, y, 0.0]]))[0], atol=1e-12)
