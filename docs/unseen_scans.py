"""The object scan on objects that are not shipped: other sizes, poses, stiffnesses and shapes of
the kinds the shipped scan scenes have, built in a temporary directory and judged as
``docs/exploration_scenes.py`` judges the shipped ones (true success, honest failure or FALSE
SUCCESS, and the force bounds).

    python docs/unseen_scans.py                 # seed 0, every object
    python docs/unseen_scans.py --seeds 0 1 --only lumpy_soft torus_wide
    python docs/unseen_scans.py --seeds 0 1 2 --param "frontier_guidance.speed_mps=30 mm/s"

The tree never sees these scenes when it is tuned: they stand in for a user's own objects (the
README's "Objects that are not shipped" names the few seeds that led to a change afterwards). Each
is on the table with the LWR 4's base 0.39 m behind and 0.13 m above the pad's start, 3 mm above
the object's top, as in the shipped scan scenes, and the region is that of its kind (the top
face within 10° for a box, the upper side within 60° otherwise). The lumpy meshes are made as
``sim/meshes/make_scan_stone.py`` makes the stone, with other sizes and bumps (another seed); the
pyramid on a hexagon is a mesh too (the scenes' ``pyramid`` is square).
The exit status is 1 when any row is a false success or fails on force.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

import exploration_scenes  # noqa: E402  (docs/exploration_scenes.py, beside this file)


def _turned(yaw_deg: int) -> str:
    """``yaw_deg`` as a description writes it (with a minus sign)."""
    return f"{yaw_deg}".replace("-", "\N{MINUS SIGN}")


def _stiffness(stiffness: float) -> tuple[str, str]:
    """``stiffness`` (N/m) as a description and as the scene writes it: ("5e4", "5.0e4")."""
    exponent = math.floor(math.log10(stiffness))
    mantissa = stiffness / 10**exponent
    return f"{mantissa:g}e{exponent}", f"{mantissa:.1f}e{exponent}"


def _box(size_m: tuple, yaw_deg: int, stiffness: float, note: str = "") -> tuple:
    """The entry of a box ``size_m`` (x, y, z) standing on the table, turned ``yaw_deg`` about
    the vertical, ``stiffness`` (N/m); ``note`` follows its size in the description."""
    mm = " × ".join(str(round(1e3 * v)) for v in size_m)
    k, k_yaml = _stiffness(stiffness)
    return (f"box {mm} mm{note}, {k} N/m, turned {_turned(yaw_deg)}°", size_m[2], 10,
            f"  - {{type: box, size: [{', '.join(f'{v:g}' for v in size_m)}], position: [0, 0, {size_m[2] / 2:g}], "
            f"rpy_deg: [0, 0, {yaw_deg}], stiffness: {k_yaml}, friction: 0.5}}\n", 0.0)


def _lying(kind: str, radius_m: float, length_m: float, yaw_deg: int, stiffness: float) -> tuple:
    """The entry of a capsule or cylinder (``kind``) lying on the table along its axis, turned
    ``yaw_deg`` about the vertical, ``stiffness`` (N/m); a capsule's ``length_m`` is its
    cylinder's, without the caps."""
    k, k_yaml = _stiffness(stiffness)
    long = length_m + (2 * radius_m if kind == "capsule" else 0.0)
    return (f"{kind} {round(2e3 * radius_m)} mm across, {round(1e3 * long)} mm long, {k} N/m, turned "
            f"{_turned(yaw_deg)}°", 2 * radius_m, 60,
            f"  - {{type: {kind}, radius: {radius_m:g}, length: {length_m:g}, position: [0, 0, {radius_m:g}], "
            f"rpy_deg: [0, 0, {yaw_deg}], stiffness: {k_yaml}, friction: 0.5}}\n", 0.0)


def _torus(major_m: float, minor_m: float, hole: str) -> tuple:
    """The entry of a ring lying flat on the table (1e5 N/m), the pad starting over its tube:
    ``hole`` says how its hole compares with the pad."""
    mm = [round(1e3 * v) for v in (2 * (major_m + minor_m), 2 * minor_m, 2 * (major_m - minor_m))]
    return (f"torus {mm[0]} mm across, {mm[1]} mm tall, its hole {mm[2]} mm ({hole}), 1e5 N/m", 2 * minor_m, 60,
            f"  - {{type: torus, major_radius: {major_m:g}, minor_radius: {minor_m:g}, position: [0, 0, {minor_m:g}], "
            "stiffness: 1.0e5, friction: 0.5}\n", -major_m)


def _pyramid(base_m: float, slope_deg: float, yaw_deg: int, stiffness: float) -> tuple:
    """The entry of a square pyramid standing on the table, ``base_m`` across, its faces
    ``slope_deg`` steep, turned ``yaw_deg`` about the vertical, ``stiffness`` (N/m)."""
    k, k_yaml = _stiffness(stiffness)
    return (f"square pyramid, {round(1e3 * base_m)} mm base, faces at {slope_deg:g}°, {k} N/m, turned "
            f"{_turned(yaw_deg)}°", 0.5 * base_m * math.tan(math.radians(slope_deg)), 60,
            f"  - {{type: pyramid, base: {base_m:.2f}, slope_deg: {slope_deg:g}, position: [0, 0, 0], "
            f"rpy_deg: [0, 0, {yaw_deg}], stiffness: {k_yaml}, friction: 0.5}}\n", 0.0)


def _grooved_block(size_m: tuple, groove_m: float, depth_m: float, yaw_deg: int) -> tuple:
    """The entry of a block ``size_m`` (x, y, z) standing on the table (1e5 N/m), a groove
    ``groove_m`` wide and ``depth_m`` deep along its top, turned ``yaw_deg`` about the vertical."""
    mm = " × ".join(str(round(1e3 * v)) for v in size_m)
    return (f"block {mm} mm with a groove {round(1e3 * groove_m)} mm wide and {round(1e3 * depth_m)} mm deep, 1e5 N/m, "
            f"turned {_turned(yaw_deg)}°", size_m[2], 60,
            f"  - {{type: grooved_block, size: [{', '.join(f'{v:g}' for v in size_m)}], groove_width: {groove_m:g}, "
            f"groove_depth: {depth_m:g}, position: [0, 0, {size_m[2] / 2:g}], rpy_deg: [0, 0, {yaw_deg}], "
            "stiffness: 1.0e5, friction: 0.5}\n", 0.0)


#: name -> (description, top height (m), region's largest angle (deg), objects YAML, pad start x (m)).
#: A lumpy mesh's top is known only once it is made: its entry gives the mesh's name instead.
OBJECTS = {
    "box_small": _box((0.08, 0.06, 0.03), 60, 5.0e4, " (smaller than the pad)"),
    "capsule_thin": _lying("capsule", 0.025, 0.12, -40, 5.0e4),
    "groove_narrow": _grooved_block((0.14, 0.16, 0.04), 0.09, 0.008, 20),
    "pyramid_small": _pyramid(0.12, 35, 10, 2.0e5),
    "torus_wide": _torus(0.08, 0.03, "wider than the pad"),
    "torus_narrow": _torus(0.05, 0.03, "half the pad"),
    "torus_mid": _torus(0.07, 0.022, "between the pad's width and diagonal"),
    "torus_60": _torus(0.055, 0.025, "three quarters of the pad"),
    "torus_64": _torus(0.057, 0.025, "four fifths of the pad"),
    "torus_54": _torus(0.052, 0.025, "two thirds of the pad"),
    "pyramid_steep": _pyramid(0.10, 45, 30, 1.0e5),
    "pyramid_wide": _pyramid(0.14, 30, 40, 1.5e5),
    "pyramid_shallow": _pyramid(0.13, 25, 5, 2.0e5),
    "pyramid_40": _pyramid(0.10, 40, -20, 1.0e5),
    "groove_shallow": _grooved_block((0.15, 0.17, 0.035), 0.115, 0.006, -45),
    "groove_mid": _grooved_block((0.15, 0.15, 0.035), 0.10, 0.007, 35),
    "cylinder_turned": _lying("cylinder", 0.035, 0.15, 35, 5.0e4),
    "box_big": _box((0.13, 0.11, 0.045), -25, 2.0e5),
    "lumpy_soft": ("lumpy mesh 108 × 72 × 29 mm, soft (2e4 N/m), turned −50°", "lumpy_soft", 60,
                   "  - {type: mesh, path: lumpy_soft.ply, scale: 1.0, resolution: 0.001, position: [0, 0, 0], "
                   "rpy_deg: [0, 0, -50], stiffness: 2.0e4, friction: 0.5}\n", 0.0),
    "lumpy_big": ("lumpy mesh 159 × 103 × 63 mm, 1e5 N/m, turned 15°", "lumpy_big", 60,
                  "  - {type: mesh, path: lumpy_big.ply, scale: 1.0, resolution: 0.001, position: [0, 0, 0], "
                  "rpy_deg: [0, 0, 15], stiffness: 1.0e5, friction: 0.5}\n", 0.0),
    # added later: other sizes and poses of the same kinds
    "torus_thin": _torus(0.065, 0.02, "between the pad's width and diagonal"),
    "torus_big": _torus(0.09, 0.025, "wider than the pad"),
    "pyramid_35": _pyramid(0.15, 35, 70, 1.0e5),
    "pyramid_50": _pyramid(0.11, 50, -35, 2.0e5),
    "groove_deep": _grooved_block((0.16, 0.14, 0.03), 0.108, 0.010, 60),
    "capsule_fat": _lying("capsule", 0.03, 0.10, 75, 1.0e5),
    "box_flat": _box((0.10, 0.07, 0.025), 15, 1.0e5),
    "cylinder_small": _lying("cylinder", 0.03, 0.12, -60, 5.0e4),
    # added later: a ridged polyhedron that is not square (the scenes' pyramid is), as a mesh
    "pyramid_hex": ("hexagonal pyramid, 140 mm across its corners, faces at 35°, 1.5e5 N/m, turned 10°", "pyramid_hex",
                    60, "  - {type: mesh, path: pyramid_hex.ply, scale: 1.0, resolution: 0.001, position: [0, 0, 0], "
                    "rpy_deg: [0, 0, 10], stiffness: 1.5e5, friction: 0.5}\n", 0.0),
}
#: The lumpy meshes: semi-axes (m) and seed of make_scan_stone.py's recipe.
MESHES = {"lumpy_soft": ((0.054, 0.036, 0.028), 11), "lumpy_big": ((0.075, 0.05, 0.062), 3)}
#: The pyramids on a regular polygon: sides, circumradius of the base (m) and the faces' slope (deg).
POLYGON_PYRAMIDS = {"pyramid_hex": (6, 0.07, 35.0)}
#: A scene with a goal of its own, as docs/exploration_scenes.py has for the shipped groove.
COVERAGE_OF = {"unseen_groove_narrow": 0.90, "unseen_groove_shallow": 0.90, "unseen_groove_mid": 0.90,
               "unseen_groove_deep": 0.90}


def _polygon_pyramid(sides: int, radius_m: float, slope_deg: float):
    """A pyramid standing on the regular polygon of ``sides`` corners ``radius_m`` (m) from its
    middle, its faces ``slope_deg`` steep (a closed ``trimesh.Trimesh``, base at z = 0)."""
    import numpy as np
    import trimesh

    angles = 2 * np.pi * np.arange(sides) / sides
    base = np.column_stack((radius_m * np.cos(angles), radius_m * np.sin(angles), np.zeros(sides)))
    height = radius_m * math.cos(math.pi / sides) * math.tan(math.radians(slope_deg))
    vertices = np.vstack((base, [[0.0, 0.0, height], [0.0, 0.0, 0.0]]))
    faces = [[k, (k + 1) % sides, sides] for k in range(sides)] + [[(k + 1) % sides, k, sides + 1] for k in range(sides)]
    return trimesh.Trimesh(vertices, faces, process=True)


def _make_mesh(name: str, folder: Path) -> float:
    """Write the mesh ``name`` (a lumpy mesh or a pyramid on a polygon) into ``folder``; its top
    height (m)."""
    if name in POLYGON_PYRAMIDS:
        mesh = _polygon_pyramid(*POLYGON_PYRAMIDS[name])
        mesh.export(folder / f"{name}.ply")
        return float(mesh.bounds[1][2])
    spec = importlib.util.spec_from_file_location("make_scan_stone", ROOT / "sim" / "meshes" / "make_scan_stone.py")
    recipe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(recipe)
    recipe.SEMI_AXES, recipe.SEED = MESHES[name]
    mesh = recipe.make()
    mesh.export(folder / f"{name}.ply")
    return float(mesh.bounds[1][2])


def write_scene(name: str, folder: Path) -> Path:
    """The scene file of the object ``name`` in ``folder``."""
    description, top, angle, objects, x = OBJECTS[name]
    if isinstance(top, str):
        top = _make_mesh(top, folder)
    z = top + 0.003
    text = (f"name: unseen_{name}\ndescription: {description}\nrate_hz: 250\nduration_s: 300\nseed: 0\n"
            f"mount:\n  type: lwr4\n  position: [{x}, 0.0, {z:.4f}]\n  rpy_deg: [180, 0, 180]\n"
            f"  base: [{x - 0.392:.4f}, 0.0, {z + 0.128:.4f}]\n"
            f"scan_region: {{normal: [0, 0, 1], max_angle_deg: {angle}}}\nobjects:\n{objects}"
            f"  - {{type: table, height: 0.0, stiffness: 1.0e6}}\n")
    path = folder / f"unseen_{name}.yaml"
    path.write_text(text)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="seeds of every object (default: 0)")
    parser.add_argument("--only", nargs="+", default=None, choices=sorted(OBJECTS), metavar="OBJECT",
                        help=f"only these objects ({', '.join(sorted(OBJECTS))})")
    parser.add_argument("--workers", type=int, default=2, help="missions run at once (default: 2)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows to this JSON file")
    exploration_scenes.add_param_option(parser)
    args = parser.parse_args(argv)
    exploration_scenes.check_params(parser, args.param)
    with tempfile.TemporaryDirectory(prefix="unseen_") as folder:
        files = [write_scene(name, Path(folder)) for name in (args.only or OBJECTS)]
        jobs = [("scan", f, seed, None, tuple(args.param)) for f in files for seed in args.seeds]
        with ProcessPoolExecutor(max_workers=max(args.workers, 1), initializer=exploration_scenes.SCAN_COVERAGE_OF.update,
                                 initargs=(COVERAGE_OF,)) as pool:
            rows = list(pool.map(exploration_scenes._job, jobs))
    for row in rows:
        row["description"] = OBJECTS[row["scene"].removeprefix("unseen_")][0]
    return exploration_scenes.finish(rows, True, args.json)


if __name__ == "__main__":
    sys.exit(main())
