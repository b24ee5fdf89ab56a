"""Cable following on every shipped cable scene, or on random cables that are not in the
repository: run trees/cable_follow.yaml with twice each scene's budget and print the figures
the README quotes (a Markdown table).

    python docs/cable_scenes.py                      # sim/cable*.yaml
    python docs/cable_scenes.py --random 4 --seed 7  # 4 random cables, bases placed in reach

A row passes when the run ends by itself before the budget with path error mean <= 1 mm and
max <= 3 mm, >= 85 % of the cable followed, and |COP x error| <= 1 px (99th percentile after the
approach) or a report warning about a joint.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

from tactile_bt import run_mission
from tactile_bt.control.spatial import make_pose
from tactile_bt.robot.kinematics import LWR4Kinematics, Q_READY
from tactile_bt.robot.lwr4_params import Q_MAX, Q_MIN
from tactile_bt.sim.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent


def random_cable(rng: np.random.Generator, index: int) -> str:
    """A scene with a random cable (3-8 mm thick, 1e4-1e6 N/m, bends of 60-150 mm radius),
    heading and start turn; the arm base is placed afterwards by :func:`place_base`."""
    heading = float(rng.uniform(-180, 180))
    radius = float(rng.choice([0.0015, 0.002, 0.003, 0.004]))
    stiffness = float(rng.choice([1e4, 1e5, 1e6]))
    path = [f"      - straight: {rng.uniform(0.07, 0.12):.3f}"]
    length = 0.1
    while length < 0.42:
        if rng.random() < 0.7:
            r, angle = float(rng.uniform(0.06, 0.15)), float(rng.uniform(30, 100)) * float(rng.choice([-1, 1]))
            path.append(f"      - arc: {{radius: {r:.3f}, angle_deg: {angle:.0f}}}")
            length += r * math.radians(abs(angle))
        else:
            piece = float(rng.uniform(0.03, 0.1))
            path.append(f"      - straight: {piece:.3f}")
            length += piece
    h = math.radians(heading)
    side = 0.004 * float(rng.choice([-1, 1]))
    x, y = 0.04 * math.cos(h) - side * math.sin(h), 0.04 * math.sin(h) + side * math.cos(h)
    return (f"name: random_cable_{index}\nrate_hz: 250\nduration_s: 40\nseed: {index}\nmount:\n  type: lwr4\n"
            f"  position: [{x:.4f}, {y:.4f}, {2 * radius + 0.005:.4f}]\n"
            f"  rpy_deg: [180, 0, {heading + 90 + float(rng.uniform(-20, 20)):.1f}]\n"
            "objects:\n  - type: table\n    height: 0.0\n    stiffness: 1.0e6\n"
            f"  - type: cable\n    radius: {radius}\n    stiffness: {stiffness:g}\n    friction: 0.3\n"
            f"    start: [0.0, 0.0]\n    heading_deg: {heading:.1f}\n    path:\n" + "\n".join(path) + "\n")


def place_base(scene_file: Path) -> None:
    """Put the arm's base where every pad pose along the cable (pad down, y along the cable) is
    reachable with the largest joint margin (a 0.1 m grid search), and write it into the scene."""
    cable = load_scene(scene_file).cable
    points = cable.centreline_world()[:, :2]
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))))
    targets = []
    for si in np.linspace(0.04, s[-1] - 0.01, 10):
        k = min(int(np.searchsorted(s, si)), len(points) - 2)
        heading = math.atan2(*(points[k + 1] - points[k])[::-1])
        targets.append(LWR4Kinematics.pad_down_pose([*points[k], 0.009], heading - math.pi / 2))
    best = (-math.inf, None)
    for bx in np.arange(-0.6, 0.61, 0.1):
        for by in np.arange(-0.6, 0.61, 0.1):
            kin = LWR4Kinematics()
            kin.base = make_pose(None, [bx, by, -0.33])
            q, margin = Q_READY.copy(), math.inf
            try:
                for T in targets:
                    q = kin.ik_pose(T, q0=q)
                    margin = min(margin, float(np.min(np.minimum(q - Q_MIN, Q_MAX - q))))
            except ValueError:
                continue
            best = max(best, (margin, (round(float(bx), 2), round(float(by), 2))), key=lambda b: b[0])
    if best[1] is None:
        raise SystemExit(f"{scene_file}: no base reaches the whole cable")
    text = scene_file.read_text().replace("  type: lwr4\n", f"  type: lwr4\n  base: [{best[1][0]}, {best[1][1]}, -0.33]\n")
    scene_file.write_text(text)


def check(scene_file: Path) -> str:
    scene = load_scene(scene_file)
    budget = 2.0 * scene.duration_s
    result = run_mission(ROOT / "trees" / "cable_follow.yaml", scene, duration=budget)
    r, log = result.summary, result.log
    error_x = log["error_cop_x_px"]
    started = np.isfinite(error_x)
    p99 = float(np.percentile(np.abs(error_x[started]), 99)) if started.any() else math.nan
    p = r.path_error_m
    share = p["followed_m"] / p["cable_length_m"]
    ok = (r.status == "success" and r.sim_time_s < budget and p["mean"] <= 1e-3 and p["max"] <= 3e-3
          and share >= 0.85 and (p99 <= 1.0 or bool(r.warnings)))
    cable = scene.cable
    return (f"| `{scene_file.name}` | {cable.radius * 2e3:g} mm, {scene.objects[[o is cable for o in scene.objects].index(True)].stiffness:.0e} N/m, "
            f"{p['cable_length_m'] * 1e3:.0f} mm | {r.status}: {r.reason.removeprefix('cable_end: ').removeprefix('end of cable: ')} | "
            f"{r.sim_time_s:.1f} of {budget:.0f} s | {p['mean'] * 1e3:.2f} / {p['max'] * 1e3:.2f} mm | {share:.0%} | "
            f"{p99:.2f} px | {'; '.join(r.warnings) or '—'} | {'yes' if ok else '**no**'} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=0, help="check this many random cables instead")
    parser.add_argument("--seed", type=int, default=7, help="seed of the random cables")
    args = parser.parse_args()
    if args.random:
        rng = np.random.default_rng(args.seed)
        folder = Path(tempfile.mkdtemp(prefix="random_cables_"))
        files = []
        for i in range(args.random):
            path = folder / f"random_cable_{i}.yaml"
            path.write_text(random_cable(rng, i))
            place_base(path)
            files.append(path)
    else:
        files = sorted((ROOT / "sim").glob("cable*.yaml"))
    print("| scene | cable | end | mission time | path error mean / max | followed | p99 \\|COP x\\| | warnings | passes |")
    print("|---|---|---|---|---|---|---|---|---|")
    for f in files:
        print(check(f), flush=True)


if __name__ == "__main__":
    main()
