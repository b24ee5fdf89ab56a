"""How near the table a pad's corner gets inside the hole of a ring narrower than the pad.

A flat pad bridges a hole narrower than itself, and the scan's estimate counts such a hole as
untouched surface (a valley), which it may be (a bowl) or not (the table seen through a ring).
Only a part of the pad that reaches down into the hole can tell. This script searches the pad's
poses with a corner first (the lowest point of a tilted pad, its diagonal pointing along a
direction ``yaw`` in the table plane, tilted up to ``--max-tilt``) over points along a line
across the hole of a scene's torus, and prints, for each point, the lowest height above the
table its corner reaches with no part of the pad inside the object (the scene's own shape and
pad), and the mean slope of the wall from the rim of the scan region down to there.

    python docs/hole_reach.py                           # sim/scan_torus.yaml
    python docs/hole_reach.py --scene sim/scan_torus.yaml --max-tilt 70
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def pad_points(size_m: tuple[float, float], tilt: float, yaw: float, step_m: float = 0.0025) -> np.ndarray:
    """Points of a pad ``size_m`` (m) whose corner is at the origin, lowest, its diagonal
    pointing along ``yaw`` (rad) and rising at ``tilt`` (rad) from the table plane, ``(k, 3)``."""
    w, h = size_m
    u, v = np.meshgrid(np.arange(0.0, w + 1e-9, step_m), np.arange(0.0, h + 1e-9, step_m))
    along = np.array([math.cos(yaw) * math.cos(tilt), math.sin(yaw) * math.cos(tilt), math.sin(tilt)])
    side = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    d = math.atan2(h, w)  # the diagonal's angle to the first edge
    e1 = math.cos(d) * along - math.sin(d) * side
    e2 = math.sin(d) * along + math.cos(d) * side
    return u.reshape(-1, 1) * e1 + v.reshape(-1, 1) * e2


def lowest_reach(obj, table_z: float, xy: np.ndarray, size_m, max_tilt: float, clearance_m: float = 5e-4,
                  dz_m: float = 0.001) -> tuple[float, float, float]:
    """Lowest height (m, above the table) at which the pad's corner can be at ``xy`` with every
    point of the pad ``clearance_m`` outside ``obj``, and the tilt and yaw (rad) it takes there."""
    best = (math.inf, math.nan, math.nan)
    top = float(obj.bounds()[1][2]) - table_z
    for tilt in np.radians(np.arange(10.0, math.degrees(max_tilt) + 1e-9, 5.0)):
        for yaw in np.radians(np.arange(0.0, 360.0, 10.0)):
            pts = pad_points(size_m, tilt, yaw)
            for z in np.arange(0.0, min(best[0], top), dz_m):
                if obj.sdf(pts + np.array([xy[0], xy[1], table_z + z])).min() > clearance_m:
                    best = (z, tilt, yaw)
                    break
    return best


def main(argv: list[str] | None = None) -> None:
    from tactile_bt.sim.scene import load_scene
    from tactile_bt.sim.shapes.torus import Torus

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=str(ROOT / "sim/scan_torus.yaml"))
    parser.add_argument("--max-tilt", type=float, default=70.0, help="the pad's largest tilt (degrees)")
    args = parser.parse_args(argv)
    scene = load_scene(args.scene)
    ring = next(o for o in scene.objects if isinstance(o, Torus))
    table_z = next((float(o.height) for o in scene.objects if type(o).__name__ == "Table"), 0.0)
    size = scene.sensor.geometry.size_m
    centre = np.asarray(ring.pose, dtype=float)[:3, 3]
    R, r = float(ring.major_radius), float(ring.minor_radius)
    region = math.radians(float((scene.data.get("scan_region") or {}).get("max_angle_deg", 60.0)))
    rim_r, rim_z = R - r * math.sin(region), centre[2] + r * math.cos(region)  # the region's inner rim
    print(f"hole {2 * (R - r) * 1e3:.0f} mm across at its narrowest; pad {size[0] * 1e3:.0f} × {size[1] * 1e3:.0f} mm; "
          f"the scan region's rim {rim_r * 1e3:.1f} mm from the axis, {(rim_z - table_z) * 1e3:.1f} mm above the table")
    print("| corner from the axis | lowest above the table | tilt | from the rim | mean slope from the rim |")
    print("|---|---|---|---|---|")
    for x in np.arange(0.0, R - r, 0.01):
        z, tilt, _ = lowest_reach(ring, table_z, centre[:2] + np.array([-x, 0.0]), size, math.radians(args.max_tilt))
        run = rim_r - x
        slope = math.degrees(math.atan2(rim_z - table_z - z, run))
        print(f"| {x * 1e3:.0f} mm | {z * 1e3:.0f} mm | {math.degrees(tilt):.0f}° | {run * 1e3:.0f} mm | {slope:.0f}° |")


if __name__ == "__main__":
    main()
