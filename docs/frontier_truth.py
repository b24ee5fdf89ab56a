"""Where a scan's frontier left lies, by the reason the scan gives for it, against the object's
true slope there.

The scan explains frontier it leaves by the slope of the touched surface (``tilt``: steeper
than the pad may tilt), which it reads from the normals it recorded: the pad's own orientation
while it touched. A flat pad bridging a concave surface (the inside of a ring) records its own
tilt, not the surface's. This script runs a scan, classifies the frontier it left as the
planner does, and prints, for each reason, the recorded tilt, the object's true tilt at the same
samples (from the scene's own shape), how far those samples lie off the object (outside it:
in the air, where the imprint of an edge contact reaches beyond the edge), and how flat the
samples within 4 mm lie (the spread off their fitted plane over the spread across it: a plane
fit tells the slope only where this is small). A first line says the same of every contact
sample, and a last one sets the untouched area the scan's estimate counts (in the table plane)
beside what the contacts truly left of the scan region (in the table plane and on the surface,
whose area the true coverage weighs).

    python docs/frontier_truth.py --scene sim/scan_torus.yaml --seed 0
    python docs/frontier_truth.py --unseen torus_wide --seed 0
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Radius (m) of the samples a plane is fitted to, and the step (m) of the shape's gradient.
_FIT_M = 0.004
_STEP_M = 1e-4


def off_object(objects, points: np.ndarray) -> np.ndarray:
    """Signed distance (m) of ``points`` ``(k, 3)`` from the nearest object (not the table):
    positive outside it."""
    solid = [o for o in objects if type(o).__name__ != "Table"]
    return np.min(np.stack([o.sdf(points) for o in solid]), axis=0)


def true_tilt(objects, points: np.ndarray) -> np.ndarray:
    """Tilt (deg) from the vertical of the outward normal of the nearest object (not the table)
    at ``points`` ``(k, 3)``, from the gradient of its signed distance."""
    solid = [o for o in objects if type(o).__name__ != "Table"]
    d = np.stack([o.sdf(points) for o in solid])
    nearest = np.argmin(d, axis=0)
    grad = np.zeros_like(points)
    for i, o in enumerate(solid):
        sel = nearest == i
        for axis in range(3):
            step = np.zeros(3)
            step[axis] = _STEP_M
            grad[sel, axis] = (o.sdf(points[sel] + step) - o.sdf(points[sel] - step)) / (2 * _STEP_M)
    grad /= np.maximum(np.linalg.norm(grad, axis=1, keepdims=True), 1e-12)
    return np.degrees(np.arccos(np.clip(grad[:, 2], -1.0, 1.0)))


def flatness(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """The spread off the plane fitted to the samples within :data:`_FIT_M` of each centre,
    over the spread across it (NaN with fewer than 12 samples)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    out = np.full(len(centres), np.nan)
    for i, c in enumerate(centres):
        near = points[tree.query_ball_point(c, _FIT_M)]
        if len(near) >= 12:
            spread = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov((near - near.mean(axis=0)).T)), 0.0))
            out[i] = spread[0] / max(spread[1], 1e-12)
    return out


def main(argv: list[str] | None = None) -> None:
    from tactile_bt import run_mission
    from tactile_bt.sim.scene import load_scene
    from tactile_bt.tree.behaviours.frontier import FrontierGuidance
    from tactile_bt.tree.loader import load_tree

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--scene", default=str(ROOT / "sim/scan_torus.yaml"))
    where.add_argument("--unseen", help="an object of docs/unseen_scans.py, e.g. torus_wide")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=600.0, help="mission time (s)")
    parser.add_argument("--param", action="append", default=[], metavar="NODE.PARAM=VALUE",
                        help="set a parameter of the tree, as tactile-bt run --param does (repeatable)")
    args = parser.parse_args(argv)
    scene_file = args.scene
    if args.unseen:
        import unseen_scans

        scene_file = unseen_scans.write_scene(args.unseen, Path(tempfile.mkdtemp(prefix="frontier_truth_")))
    scene = load_scene(scene_file)
    tree = load_tree(ROOT / "trees/scan_object.yaml", params=args.param, pad=scene.sensor.geometry)
    result = run_mission(tree, scene, duration=args.duration, seed=args.seed)
    leaf = next(n for n in tree.root.iterate() if isinstance(n, FrontierGuidance))
    m, points = leaf.map, np.asarray(leaf._cloud.points)
    rows, cols, _, reason = leaf._classify()
    reason = reason.astype(str)
    cell = m.cell_of(points[:, :2])
    print(f"{scene.name}, seed {args.seed}: {result.summary.status}: {result.summary.reason[:160]}")
    off = off_object(scene.objects, points) * 1e3
    print(f"{len(points)} contact samples: {np.mean(off > 1.0):.0%} more than 1 mm outside the object (the "
          f"farthest {off.max():.1f} mm), {np.mean(off < -1.0):.0%} more than 1 mm inside it")
    print("| reason | frontier cells | recorded tilt (median, deg) | true tilt (10/50/90 %, deg) | "
          "off the object (median / largest, mm) | off-plane / across spread (median) |")
    print("|---|---|---|---|---|---|")
    for name in sorted(set(reason) - {"gap"}):
        sel = np.flatnonzero(reason == name)
        centres = []
        for r, c in zip(rows[sel], cols[sel]):
            inside = points[(cell[:, 0] == r) & (cell[:, 1] == c)]
            centres.append(inside.mean(axis=0) if len(inside) else np.full(3, np.nan))
        centres = np.array(centres)
        centres = centres[np.isfinite(centres).all(axis=1)]
        truth = true_tilt(scene.objects, centres)
        recorded = np.degrees(m.tilt(rows[sel], cols[sel]))
        lo, mid, hi = np.percentile(truth, [10, 50, 90])
        away = off_object(scene.objects, centres) * 1e3
        print(f"| {name or 'open'} | {len(sel)} | {np.nanmedian(recorded):.0f} | {lo:.0f} / {mid:.0f} / {hi:.0f} | "
              f"{np.median(away):.1f} / {away.max():.1f} | {np.nanmedian(flatness(points, centres)):.2f} |")
    print(left_untouched(scene, leaf.frontier_left(), points))


def left_untouched(scene, left: dict, points: np.ndarray) -> str:
    """One line: the untouched area the estimate counts (cm², table plane: near the table, in
    valleys, beyond reach, along open holes' rims) and what the contact ``points`` truly left of
    the scan region (farther than the coverage radius from every contact), in the table plane
    and on the surface."""
    from tactile_bt.mission import accuracy

    region = accuracy.scene_region(scene)
    _, obj = accuracy.scan_object(scene, region)
    t_pts, t_nrm, t_w = accuracy.sample_surface(accuracy.true_surface(obj))
    inside = accuracy.region_mask(t_pts, t_nrm, region)
    missed = inside & ~accuracy.covered_by(t_pts, points)
    flat = t_w * np.abs(t_nrm[:, 2])
    parts = {"near the table": left["untouched_near_table_m2"], "in valleys": left["untouched_in_valleys_m2"],
             "beyond reach": left["untouched_beyond_reach_m2"], "at open holes' rims": left["untouched_at_hole_rims_m2"]}
    counted = sum(parts.values())
    detail = ", ".join(f"{v * 1e4:.1f} {k}" for k, v in parts.items() if v > 0) or "none"
    return (f"untouched: the estimate counts {counted * 1e4:.1f} cm² in the table plane ({detail}; estimated "
            f"coverage {left['estimated_coverage']:.3f}); the contacts left {flat[missed].sum() * 1e4:.1f} cm² of the "
            f"region in the table plane (of {flat[inside].sum() * 1e4:.1f}) and {t_w[missed].sum() * 1e4:.1f} cm² on "
            f"its surface (of {t_w[inside].sum() * 1e4:.1f}; true coverage {1 - t_w[missed].sum() / t_w[inside].sum():.3f})")


if __name__ == "__main__":
    main()
