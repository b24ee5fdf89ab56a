"""Runs of foot below the frontier the table explains on plane faces, and the sweeps chosen."""

import math

import numpy as np
import numpy.testing as npt

from tactile_bt.contacts.sweep_plan import SweepPlan, foot_runs, to_corners

SLOPE = math.radians(40)


def face_cells(rng, yaw_deg, half=0.08, count=40, corner=0):
    """Frontier cells 4–14 mm up a 40° face of a square pyramid (base ``2 half``) turned
    ``yaw_deg``, with noisy normals; and ``corner`` stray cells at a ridge."""
    yaw = math.radians(yaw_deg)
    out = np.array([math.cos(yaw), math.sin(yaw)])
    along = np.array([-out[1], out[0]])
    z = rng.uniform(0.004, 0.014, count)
    s = np.sort(rng.uniform(-0.05, 0.05, count))
    xy = out * (half - z[:, None] / math.tan(SLOPE)) + along * s[:, None]
    n = np.column_stack((out[0] * math.sin(SLOPE) + rng.normal(0, 0.01, count),
                         out[1] * math.sin(SLOPE) + rng.normal(0, 0.01, count), np.full(count, math.cos(SLOPE))))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    if corner:
        diagonal = (out + along) / math.sqrt(2)
        xy = np.vstack((xy, diagonal * half * 1.3 + rng.normal(0, 0.001, (corner, 2))))
        z = np.concatenate((z, np.full(corner, 0.005)))
        n = np.vstack((n, np.tile([diagonal[0] * 0.6, diagonal[1] * 0.6, 0.8], (corner, 1))))
    return xy, z, n, out, along, s


def test_a_face_gives_one_run_along_its_foot_at_the_sweeping_height():
    rng = np.random.default_rng(0)
    xy, z, n, out, along, s = face_cells(rng, 25)
    runs = foot_runs(xy, z, n, foot_z=0.002)
    assert len(runs) == 1
    run = runs[0]
    npt.assert_allclose(run["out"], out, atol=0.02)
    npt.assert_allclose(abs(run["along"] @ along), 1.0, atol=1e-3)
    # the start lies on the face's foot line at 2 mm: 80 mm out less 2 mm / tan 40°
    npt.assert_allclose(run["start"] @ out, 0.08 - 0.002 / math.tan(SLOPE), atol=0.001)
    npt.assert_allclose(run["length_m"], s[-1] - s[0], atol=0.002)
    # the band left above the foot reaches up to the frontier: the cells' heights, 4–14 mm
    assert np.percentile(z, 80) <= run["band_top_z"] <= z.max()


def test_a_ridge_s_few_cells_make_no_run_and_two_faces_make_two():
    rng = np.random.default_rng(1)
    a = face_cells(rng, 25, corner=3)
    b = face_cells(rng, 115)
    runs = foot_runs(np.vstack((a[0], b[0])), np.concatenate((a[1], b[1])), np.vstack((a[2], b[2])), 0.002)
    assert len(runs) == 2
    outs = sorted((r["out"] for r in runs), key=lambda o: math.atan2(o[1], o[0]))
    npt.assert_allclose(outs[0], a[3], atol=0.02)
    npt.assert_allclose(outs[1], b[3], atol=0.02)
    # each run names its cells: the faces' 40 each, none of the ridge's 3 (indices 40-42)
    cells = np.sort(np.concatenate([r["cells"] for r in runs]))
    npt.assert_array_equal(cells, np.concatenate((np.arange(40), np.arange(43, 83))))


def test_a_gap_splits_a_run_and_a_level_surface_has_no_foot():
    rng = np.random.default_rng(2)
    xy, z, n, out, along, s = face_cells(rng, 0, count=60)
    keep = np.abs(s) > 0.02  # a 40 mm gap in the middle
    assert len(foot_runs(xy[keep], z[keep], n[keep], 0.002)) == 2
    level = np.tile([0.0, 0.0, 1.0], (len(xy), 1))
    assert foot_runs(xy, z, level, 0.002) == []


def test_the_plan_sweeps_the_nearest_run_once_and_at_most_its_count():
    rng = np.random.default_rng(3)
    a, b = face_cells(rng, 0), face_cells(rng, 180)
    cells = (np.vstack((a[0], b[0])), np.concatenate((a[1], b[1])), np.vstack((a[2], b[2])))
    runs = foot_runs(*cells, 0.002)
    plan = SweepPlan(most=5)
    first = plan.choose(runs, from_xy=np.array([-0.1, 0.0]))
    npt.assert_allclose(first["out"], [-1.0, 0.0], atol=0.02)  # the face nearer (-100, 0) mm
    second = plan.choose(runs, from_xy=np.array([-0.1, 0.0]))
    npt.assert_allclose(second["out"], [1.0, 0.0], atol=0.02)
    assert plan.choose(runs, from_xy=np.zeros(2)) is None
    assert SweepPlan(most=0).choose(runs, from_xy=np.zeros(2)) is None


def test_a_longer_run_of_a_swept_foot_is_swept_again_and_one_the_border_covered_is_not():
    """The frontier left along a foot grows as the scan goes on: a run of the same face that
    reaches beyond what an earlier sweep covered (the run and the border's overhang beyond its
    ends) is swept; one within it is not. Another face's foot is a run of its own."""
    rng = np.random.default_rng(4)
    xy, z, n, out, along, s = face_cells(rng, 30)
    middle = np.abs(s) < 0.02
    plan = SweepPlan(most=5, reach_m=0.01)
    (first,) = foot_runs(xy[middle], z[middle], n[middle], 0.002)
    assert plan.choose([first], from_xy=np.zeros(2)) is first
    within = np.abs(s) < 0.028  # 8 mm more each way: under the border's 10 mm overhang
    assert plan.choose(foot_runs(xy[within], z[within], n[within], 0.002), from_xy=np.zeros(2)) is None
    (longer,) = foot_runs(xy, z, n, 0.002)  # the whole 100 mm
    assert plan.choose([longer], from_xy=np.zeros(2)) is longer
    assert plan.choose([longer], from_xy=np.zeros(2)) is None  # swept now
    other = foot_runs(*face_cells(rng, 210)[:3], 0.002)
    assert plan.choose(other, from_xy=np.zeros(2)) is other[0]


def test_runs_are_carried_on_to_the_corners_where_the_feet_meet():
    """The frontier on each face of a square pyramid stops 28 mm short of the base's corners:
    every run is carried on to the corners, where its foot line meets its neighbours', and the
    opposite face, parallel, moves nothing."""
    rng = np.random.default_rng(5)
    yaw = 20
    faces = [face_cells(rng, yaw + 90 * k) for k in range(4)]
    runs = foot_runs(np.vstack([f[0] for f in faces]), np.concatenate([f[1] for f in faces]),
                     np.vstack([f[2] for f in faces]), 0.002)
    assert len(runs) == 4
    foot = 0.08 - 0.002 / math.tan(SLOPE)  # how far out the feet lie at 2 mm
    corners = [foot * np.array([math.cos(a) - math.sin(a), math.sin(a) + math.cos(a)])
               for a in np.radians(yaw + 90 * np.arange(4))]
    for run, moved in zip(runs, to_corners(runs, most_m=0.04)):
        assert run["length_m"] < 0.11
        npt.assert_allclose(moved["length_m"], 2 * foot, atol=0.002)
        ends = [moved["start"], moved["start"] + moved["along"] * moved["length_m"]]
        for end in ends:
            assert min(np.linalg.norm(end - c) for c in corners) < 0.002
        npt.assert_allclose(moved["centre"], moved["start"] + moved["along"] * moved["length_m"] / 2)
        assert moved["cells"] is run["cells"]


def test_a_corner_farther_than_the_limit_or_a_lone_face_moves_no_end():
    rng = np.random.default_rng(6)
    a, b = face_cells(rng, 0), face_cells(rng, 90)
    runs = foot_runs(np.vstack((a[0], b[0])), np.concatenate((a[1], b[1])), np.vstack((a[2], b[2])), 0.002)
    assert to_corners(runs, most_m=0.01) == runs  # the corner lies 28 mm beyond both ends
    moved = to_corners(runs, most_m=0.04)
    assert all(m["length_m"] > r["length_m"] + 0.02 for m, r in zip(moved, runs))  # each moved one end
    assert all(m["length_m"] < r["length_m"] + 0.04 for m, r in zip(moved, runs))  # and one only
    (lone,) = foot_runs(*face_cells(rng, 45)[:3], 0.002)
    assert to_corners([lone], most_m=0.08) == [lone]


def test_a_foot_swept_before_still_marks_its_corners():
    """Once a face's foot is swept its frontier is gone; carried on to the corners, its run
    still tells its neighbour where their feet meet."""
    rng = np.random.default_rng(7)
    a, b = face_cells(rng, 0), face_cells(rng, 90)
    runs = foot_runs(np.vstack((a[0], b[0])), np.concatenate((a[1], b[1])), np.vstack((a[2], b[2])), 0.002)
    swept = to_corners(runs, most_m=0.04)[0]
    alone = [runs[1]]
    assert to_corners(alone, most_m=0.04) == alone
    (moved,) = to_corners(alone, most_m=0.04, others=[swept])
    npt.assert_allclose(moved["length_m"], to_corners(runs, most_m=0.04)[1]["length_m"], atol=1e-9)
