"""Probes into a valley the flat pad bridges: points spread over it, and the corner-first pose
that lowers the pad's corner furthest without coming near the touched surface (contacts layer,
pure geometry)."""

import math

import numpy as np
import numpy.testing as npt
import pytest
from scipy import ndimage

from tactile_bt.contacts.frontier_map import FrontierMap
from scipy.spatial.transform import Rotation

from tactile_bt.contacts.hole_probe import (below_rim_z, corner_first, least_turn, pad_rotation, probe_points,
                                           steep_rim_cells)

PAD = (0.08, 0.08)


def ring_map(rng, inner_m=0.035, outer_m=0.085, top_m=0.05, tube_m=0.025):
    """A map of the upper side of a ring lying on the table (a torus, tube ``tube_m`` around a
    circle halfway between ``inner_m`` and ``outer_m`` from its axis), touched where it is
    tilted less than 55°: what a flat pad bridging its hole reaches."""
    major = 0.5 * (inner_m + outer_m)
    a = rng.uniform(0.0, 2 * math.pi, 60000)
    b = rng.uniform(-math.radians(55), math.radians(55), 60000)  # from the top of the tube
    r = major + tube_m * np.sin(b)
    z = top_m - tube_m + tube_m * np.cos(b)
    pts = np.column_stack((r * np.cos(a), r * np.sin(a), z))
    normals = np.column_stack((np.sin(b) * np.cos(a), np.sin(b) * np.sin(a), np.cos(b)))
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.12)
    m.add(pts, normals)
    return m, major - tube_m * math.sin(math.radians(55))


def test_the_points_of_a_ring_s_hole_start_at_its_middle_and_spread_inside_it():
    m, rim = ring_map(np.random.default_rng(1))
    valleys = probe_points(m, m.valleys(min(PAD)), most=5)
    assert len(valleys) == 1
    v = valleys[0]
    assert np.linalg.norm(v["centre"]) < 0.004                          # the middle first
    npt.assert_allclose(v["points"][0], v["centre"])
    r = np.linalg.norm(v["points"], axis=1)
    edge = np.max(np.linalg.norm(m.centre_of(*np.nonzero(m.valleys(min(PAD)))), axis=1))  # the valley's edge
    assert len(r) == 5 and np.all(r < rim)                               # every point inside the hole
    assert np.all(np.abs(r[1:] - (edge - 0.006)) < 0.004)                # the others 6 mm inside its edge
    gaps = np.linalg.norm(v["points"][:, None] - v["points"][None], axis=-1) + np.eye(5)
    assert gaps.min() > 0.02                                             # spread round it
    turn = np.diff(np.unwrap(np.arctan2(v["points"][1:, 1], v["points"][1:, 0])))
    assert np.all(turn > 0) or np.all(turn < 0)                          # visited in turn round the middle
    cells = np.linalg.norm(v["cells"], axis=1)                           # marked empty if open: not the rim's band
    assert np.all(cells < edge - 0.003) and v["area_m2"] > math.pi * (edge - 0.004) ** 2


def test_a_corner_first_pose_has_its_corner_lowest_its_diagonal_rising_and_its_face_down():
    rng = np.random.default_rng(2)
    for _ in range(5):
        yaw, tilt = rng.uniform(0, 2 * math.pi), rng.uniform(0.2, 1.3)
        R = pad_rotation(PAD, yaw, tilt)
        npt.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        corners = np.array([[sx * 0.04, sy * 0.04, 0.0] for sx in (-1, 1) for sy in (-1, 1)]) @ R.T
        assert np.argmin(corners[:, 2]) == 0                                # the corner at (-w/2, -h/2)
        d = corners[3] - corners[0]
        npt.assert_allclose(math.atan2(d[2], math.hypot(d[0], d[1])), tilt, atol=1e-9)
        npt.assert_allclose(math.atan2(d[1], d[0]) % (2 * math.pi), yaw % (2 * math.pi), atol=1e-9)
        assert R[2, 2] < 0                                                  # sensor z down


def test_the_corner_goes_deep_into_a_ring_s_hole_with_the_pad_clear_of_everything_touched():
    m, rim = ring_map(np.random.default_rng(3))
    clearance, floor = 0.002, 0.003
    for xy in (np.zeros(2), np.array([0.012, -0.008])):
        R, z = corner_first(m, xy, PAD, math.radians(70), clearance, floor)
        assert floor <= z < 0.025                           # half-way down a 50 mm ring, or deeper
        assert math.acos(-R[2, 2]) <= math.radians(70) + 1e-9
        u, v = np.meshgrid(np.linspace(-0.04, 0.04, 41), np.linspace(-0.04, 0.04, 41))
        local = np.column_stack((u.ravel() + 0.04, v.ravel() + 0.04, np.zeros(u.size)))
        pad = local @ R.T + np.array([xy[0], xy[1], z])     # the pad, its corner at the point
        rc = m.cell_of(pad[:, :2])
        under = m.z_max[rc[:, 0], rc[:, 1]]
        touched = m.count[rc[:, 0], rc[:, 1]] > 0
        assert np.all(pad[touched, 2] >= under[touched] + clearance - 0.0015)  # within a check step


def test_no_corner_first_pose_where_the_touched_surface_is_everywhere():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.1)
    x, y = (a.ravel() for a in np.meshgrid(np.arange(-0.09, 0.09, 0.001), np.arange(-0.09, 0.09, 0.001)))
    m.add(np.column_stack((x, y, np.full_like(x, 0.03))), np.tile([0.0, 0.0, 1.0], (len(x), 1)))
    assert corner_first(m, np.zeros(2), PAD, math.radians(70), 0.002, 0.0) is None  # a plane: nothing below it


def test_the_least_turn_lies_the_same_and_is_the_nearest_to_the_pad():
    rng = np.random.default_rng(4)
    corners = np.array([[sx * 0.04, sy * 0.04, 0.0] for sx in (-1, 1) for sy in (-1, 1)])
    for _ in range(10):
        R = pad_rotation(PAD, rng.uniform(0, 2 * math.pi), rng.uniform(0.3, 1.2))
        current = Rotation.from_euler("xz", [math.pi, rng.uniform(0, 2 * math.pi)]).as_matrix()  # a level pad
        Rk = least_turn(R, current, PAD)
        npt.assert_allclose(Rk[:, 2], R[:, 2], atol=1e-12)                        # the same normal
        a, b = corners @ R.T, corners @ Rk.T
        assert np.all(np.min(np.linalg.norm(a[:, None] - b[None], axis=-1), axis=1) < 1e-12)  # the same corners
        npt.assert_allclose(b[np.argmin(b[:, 2])], a[np.argmin(a[:, 2])], atol=1e-12)  # the same corner lowest
        # of the four ways the square pad lies so, the nearest to the pad as it is
        def angle(A):
            return np.linalg.norm(Rotation.from_matrix(A @ current.T).as_rotvec())

        quarters = [R @ Rotation.from_rotvec([0.0, 0.0, k * math.pi / 2]).as_matrix() for k in range(4)]
        assert angle(Rk) <= min(angle(Q) for Q in quarters) + 1e-12


@pytest.mark.parametrize("inner_m, touched_deg, wall", [(0.035, 55, False), (0.03, 45, True)])
def test_a_corner_lowered_by_the_rim_to_the_height_that_tells_its_wall_touches_only_a_wall_within_the_tilt(
        inner_m, touched_deg, wall):
    # a ring 50 mm tall, its tube 25 mm across, touched where the flat pad bridging its hole
    # reached: the shipped torus (hole 70 mm, touched to 55°: what is left under the rim is the
    # wall, steeper than 60°) and a ring whose hole is 60 mm (touched to 45°: the inner side
    # within the pad's tilt goes on under the rim)
    rng = np.random.default_rng(5)
    major, tube, tilt = inner_m + 0.025, 0.025, math.radians(70)
    a = rng.uniform(0.0, 2 * math.pi, 60000)
    b = rng.uniform(-math.radians(touched_deg), math.radians(touched_deg), 60000)
    r = major + tube * np.sin(b)
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.12)
    m.add(np.column_stack((r * np.cos(a), r * np.sin(a), 0.025 + tube * np.cos(b))),
          np.column_stack((np.sin(b) * np.cos(a), np.sin(b) * np.sin(a), np.cos(b))))
    v = probe_points(m, m.valleys(min(PAD)), most=5)[0]
    assert 0.004 < v["inside_m"] <= 0.006
    for xy in v["points"][1:]:
        z = below_rim_z(m, xy, v["inside_m"], tilt)
        away = np.linalg.norm(m.centre_of(*np.nonzero(m.count > 0)) - xy, axis=1)
        drop = v["inside_m"] * math.tan(tilt)
        top = [np.max(m.z_max[m.count > 0][away <= v["inside_m"] + d]) for d in (0.002, 0.007)]
        assert top[0] - drop <= z <= top[1] - drop                      # the rim's highest sample near it, less the drop
        _, corner_z = corner_first(m, xy, PAD, tilt, 0.002, 0.003)
        assert corner_z < z                                             # the corner gets that low there
        off = major - np.linalg.norm(xy)                                # the ring's own surface at the point
        surface_z = 0.025 + math.sqrt(tube**2 - off**2) if abs(off) < tube else -math.inf
        assert (surface_z > z) == wall                                  # touched before it: a wall within the tilt
    assert below_rim_z(m, np.zeros(2), 0.006, tilt) == -math.inf        # nothing touched near the middle


def test_a_corner_that_came_below_the_wall_at_the_tilt_limit_clears_the_rim_band_along_the_rim_near_it():
    # the shipped torus's hole found open: the band along its rim stays counted, but where a
    # corner lowered by the rim came below where a wall at the tilt limit would stand, the rim
    # falls away steeper than the pad may lie there, and that part of the band holds nothing
    # but for the cells next to the touched edge, where a rounded rim may still lie within the tilt
    m, _ = ring_map(np.random.default_rng(6))
    tilt, along = math.radians(70), 0.02
    v = probe_points(m, m.valleys(min(PAD)), most=5)[0]
    m.mark_empty(v["cells"], opened=True)
    band = m.hole_rims()
    band_xy = m.centre_of(*np.nonzero(band))
    assert band.sum() * m.cell_m**2 > 1e-4                               # a band of more than 1 cm² left
    rim = v["points"][1:]
    low = np.array([corner_first(m, xy, PAD, tilt, 0.002, 0.003)[1] for xy in rim])
    high = np.array([below_rim_z(m, xy, v["inside_m"], tilt) + 0.002 for xy in rim])
    assert np.all(low < high - 0.002)
    reached = np.concatenate((low[:1], high[1:]))                        # only the first came low enough
    cells = steep_rim_cells(m, rim, reached, tilt, along)
    next_to_touched = ndimage.binary_dilation(m.touched, structure=np.ones((3, 3), dtype=bool))  # marking empty keeps it
    near = (np.linalg.norm(band_xy - rim[0], axis=1) <= along) & ~next_to_touched[np.nonzero(band)]
    assert len(cells) == near.sum() > 0                                  # the band near it, and only there
    assert np.all(np.linalg.norm(cells - rim[0], axis=1) <= along)
    assert band[tuple(m.cell_of(cells).T)].all()
    assert len(steep_rim_cells(m, rim, high, tilt, along)) == 0          # none came low enough: none
    assert len(steep_rim_cells(m, v["points"][:1], [-1.0], tilt, 0.2)) == 0  # the middle: far from the rim
    m.mark_empty(steep_rim_cells(m, rim, low, tilt, 0.5 * min(PAD)), opened=True)
    left = m.hole_rims()                                                 # every point low: all the band near them
    far = np.min(np.linalg.norm(m.centre_of(*np.nonzero(left))[:, None] - rim[None], axis=-1), axis=1) > 0.5 * min(PAD)
    assert np.all(far | next_to_touched[np.nonzero(left)])
    assert left.sum() < 0.8 * len(band_xy)
