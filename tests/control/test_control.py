"""Servo controller: the signs of J⁻¹ (Eq. 5) proven on geometry, PID, projections, limits."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt.control.chatter import ChatterDamper
from tactile_bt.control.servo import (
    PID,
    PROJECTIONS,
    ServoCommand,
    feature_error,
    feature_errors_of,
    inverse_task_jacobian,
    limit_twist,
    projection,
)
from tactile_bt.control.spatial import exp_twist, invert
from tactile_bt.testing import make_features

DT = 0.004
PITCH = 0.005


def command(features, target_cop=(0.0, 0.0), target_p=2000.0, target_a=np.pi / 2, P=(1, 1, 1, 1, 1, 1)):
    """Paper Eq. 3 with unit gains: V = P J⁻¹ Δf."""
    df = np.array(feature_error(features, target_cop, target_p, target_a))
    return projection(P) @ inverse_task_jacobian(0.05) @ df


def point_in_sensor_after(twist, point_s, dt=0.01):
    """Where a world-fixed point appears in the sensor frame after the sensor moved by twist."""
    T = exp_twist(twist, dt)  # new sensor pose in the old sensor frame
    return (invert(T) @ np.append(point_s, 1.0))[:3]


@pytest.mark.parametrize("cop_px", [(10.0, 7.5), (4.0, 7.5), (7.5, 11.0), (7.5, 2.0), (12.0, 3.0)])
def test_sliding_moves_the_cop_back_to_the_target(cop_px):
    """A COP right of the target must produce motion that moves it back (rows vx, vy)."""
    f = make_features(cop_px=cop_px)
    V = command(f, P=PROJECTIONS["position"])
    before = f.cop
    after = point_in_sensor_after(V, np.array([before[0], before[1], 0.002]))
    assert np.linalg.norm(after[:2]) < np.linalg.norm(before)


@pytest.mark.parametrize("cop_px", [(10.0, 7.5), (4.0, 7.5), (7.5, 11.0), (7.5, 2.0)])
def test_rolling_moves_the_cop_back_over_a_sphere(cop_px):
    """Rows ωx, ωy: rolling over a sphere moves the contact point towards the target."""
    f = make_features(cop_px=cop_px)
    V = command(f, P=(0, 0, 0, 1, 1, 0))
    assert_allclose(V[:3], 0.0)
    # Sphere of radius 40 mm touching the pad (z = 0) at the COP, centre on the object side (+z).
    rho = 0.04
    centre = np.array([f.cop[0], f.cop[1], rho])
    T = exp_twist(V, 0.01)
    centre_new = (invert(T) @ np.append(centre, 1.0))[:3]
    contact_new = centre_new[:2]  # foot of the normal through the centre on the pad plane
    assert np.linalg.norm(contact_new) < np.linalg.norm(f.cop)


@pytest.mark.parametrize("pressure,sign", [(1500.0, 1.0), (2600.0, -1.0)])
def test_force_row_presses_when_too_light(pressure, sign):
    V = command(make_features(pressure=pressure), P=PROJECTIONS["force"])
    assert np.sign(V[2]) == sign
    assert_allclose(np.delete(V, 2), 0.0)


@pytest.mark.parametrize("alpha_deg", [60.0, 80.0, -80.0, -60.0, 10.0])
def test_turning_rotates_the_edge_towards_the_target(alpha_deg):
    """Row ωz: a line at α in the pad turns towards the target angle (modulo π)."""
    alpha = np.deg2rad(alpha_deg)
    f = make_features(orientation=alpha)
    V = command(f, target_a=np.pi / 2, P=PROJECTIONS["edge"])
    direction = np.array([np.cos(alpha), np.sin(alpha), 0.0])
    T = exp_twist(V, 0.01)
    d_new = invert(T)[:3, :3] @ direction
    alpha_new = np.arctan2(d_new[1], d_new[0])

    def err(a):
        return abs((a - np.pi / 2 + np.pi / 2) % np.pi - np.pi / 2)

    assert err(alpha_new) < err(alpha)


def test_angular_error_is_taken_modulo_pi():
    f = make_features(orientation=np.deg2rad(-89.0))
    df = feature_error(f, target_orientation=np.pi / 2)
    assert_allclose(df[3], np.deg2rad(-1.0), atol=1e-12)


def test_no_contact_gives_nan_errors():
    assert np.all(np.isnan(feature_error(make_features(in_contact=False))))


@pytest.mark.parametrize("components", [(2,), (3,), (0, 1), (0, 1, 2, 3), (3, 0), (1,)])
def test_a_leaf_s_error_function_gives_feature_error_s_components(components):
    """The per-cycle error function of a servo leaf's components is Δf of feature_error, and a
    component not computed (not controlled) is NaN."""
    f = make_features(cop_px=(9.0, 6.0), orientation=np.deg2rad(-80.0))
    targets = ((0.001, -0.002), 2000.0, np.pi / 2)
    full = feature_error(f, *targets)
    assert_allclose(feature_errors_of(components)(f, targets), [full[c] for c in components], atol=1e-12)
    partial = feature_errors_of(components, computed=[0])(f, targets)
    assert_allclose(partial[0], full[components[0]], atol=1e-12)
    assert np.all(np.isnan(partial[1:]))


def test_unknown_feature_component_is_refused():
    with pytest.raises(ValueError, match="0..3"):
        feature_errors_of((4,))


def test_projection_rejects_non_binary_diagonal():
    with pytest.raises(ValueError, match="0/1"):
        projection((1, 0.5, 0, 0, 0, 0))


def test_pid_integral_removes_steady_error_and_respects_anti_windup():
    pid = PID(kp=1.0, ki=2.0, kd=0.0, output_limit=0.5)
    for _ in range(2000):
        u = pid.update([1.0], DT)
    assert_allclose(u, [0.5])
    # The integral never exceeds what the output limit can use (no windup).
    assert abs(pid.integral[0] * 2.0) <= 0.5 + 1e-12
    # After the error flips, the output leaves saturation at once instead of unwinding for long.
    u = pid.update([-0.2], DT)
    assert u[0] < 0.5


def test_pid_derivative_is_per_second_and_nan_holds_state():
    pid = PID(kp=0.0, kd=1.0)
    pid.update([0.0], DT)
    assert_allclose(pid.update([0.004], DT), [1.0])
    before = pid.integral
    assert_allclose(pid.update([np.nan], DT), [0.0])
    assert_allclose(pid.integral, before)


def test_pid_rejects_negative_gains():
    with pytest.raises(ValueError):
        PID(kp=-1.0)


def test_servo_command_sums_parts_and_limits():
    c = ServoCommand(linear_limit=0.01, angular_limit=0.1)
    c.add("a", np.array([0.006, 0, 0, 0, 0, 0.05]))
    c.add("b", np.array([0.006, 0, 0, 0, 0, 0.08]))
    V = c.twist()
    assert_allclose(np.linalg.norm(V[:3]), 0.01)
    assert_allclose(V[5], 0.1)
    assert set(c.parts) == {"a", "b"}
    with pytest.raises(ValueError, match="finite"):
        c.add("bad", np.array([np.nan, 0, 0, 0, 0, 0]))
    c.clear()
    assert_allclose(c.twist(), 0.0)


def test_limit_twist_keeps_direction():
    V = np.array([3.0, 4.0, 0.0, 0.0, 0.0, 0.0])
    assert_allclose(limit_twist(V, 1.0, 1.0)[:2], [0.6, 0.8])


# ------------------------------------------------------------------ chatter


def _damper(limit=1.0):
    return ChatterDamper([limit], jump_share=0.5, step=0.25, recover_s=1.0, gain_min=0.3, smooth_s=0.1, gap_s=0.05)


def test_a_servo_output_that_does_not_chatter_passes_unchanged():
    damper = _damper()
    u = [0.8 * np.sin(0.05 * k) for k in range(500)]  # reverses, but smoothly
    assert [damper.apply([v], 0.004)[0] for v in u] == u
    damper = _damper()
    damper.apply([1.0], 0.004)
    assert damper.apply([-1.0], 0.004) == [-1.0]  # one reversal alone is no chatter
    assert damper.counted == 0


def test_a_saturated_output_switching_sign_every_cycle_is_damped_and_recovers():
    damper = _damper()
    out = [damper.apply([1.0 if k % 2 else -1.0], 0.004)[0] for k in range(250)]
    tail = np.array(out[-50:])
    assert np.max(np.abs(tail)) < 0.1  # from ±1 to a small ripple
    assert np.max(np.abs(np.diff(tail))) < 0.1
    assert damper.level[0] == 1.0
    calm = [damper.apply([0.5], 0.004)[0] for _ in range(500)]  # 2 s without chatter
    assert calm[-1] == 0.5 and damper.level[0] == 0.0
