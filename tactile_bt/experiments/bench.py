"""Speed figures of ``tactile-bt bench``, each a ratio measured within one run.

* feature extraction: :func:`tactile_bt.perception.features.extract` against the obvious scikit-image
  ``label`` + ``regionprops`` implementation of the same features, on the same frames;
* one control cycle (calibration, features, smoothing, tree tick, summed twist) against the
  526 µs frame period of the sensor at 1.9 kHz;
* the closed-loop cable mission (on the compliant arm and on the ideal mount) and the stripe
  scan of the ellipsoid against real time at 250 Hz, with where the time goes per cycle (each
  stage also as its share of the 4 ms cycle);
* the cable mission with and without the per-tick log of every node's status, alternated;
* the README's main command (``tactile-bt run`` of the cable mission) in a fresh process, first
  with an empty cache of compiled kernels (``NUMBA_CACHE_DIR`` a new directory: what a fresh
  install pays once) and then with the cache filled, against the mission time;
* sweep throughput: runs per second of a small ``tactile-bt sweep`` in this process and on a
  local Dask cluster of 2 worker processes, and their ratio.

Times are the median of repeated runs (``time.perf_counter``); nothing here asserts a time.

Layer: experiments.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tactile_bt import defaults, shipped

__all__ = ["run_bench", "format_bench", "bench_reconstruction", "bench_sweep", "bench_mission", "bench_scan",
           "bench_first_run", "bench_node_status"]

#: The folder the running tactile_bt is imported from (PYTHONPATH of the fresh processes).
IMPORT_ROOT = Path(__file__).resolve().parents[2]
TREE = shipped.path("trees/cable_follow.yaml")
SCENE = shipped.path("sim/cable.yaml")
SCAN_TREE = shipped.path("trees/surface_scan_stripes.yaml")
SCAN_SCENE = shipped.path("sim/scan_ellipsoid.yaml")
#: The cable scene with the pad on the ideal Cartesian mount instead of the compliant arm.
IDEAL = ["mount.type=cartesian"]


def _per_call(fn, repeats: int, number: int) -> float:
    """Median over ``repeats`` of the mean time (s) of ``number`` calls."""
    fn()
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        samples.append((time.perf_counter() - t0) / number)
    return float(np.median(samples))


def _cable_frames(n: int = 32):
    """Raw frames and calibration of the pad pressing on the cable, at several poses."""
    from tactile_bt.sim.scene import load_scene

    scene = load_scene(SCENE, IDEAL)
    world = scene.build_world(np.random.default_rng(0))
    T = world.pose.copy()
    rng = np.random.default_rng(1)
    frames = []
    for _ in range(n):
        pose = T.copy()
        pose[:3, 3] = (rng.uniform(-0.006, 0.006), rng.uniform(0.03, 0.06), 0.0052)
        world.mount.pose = pose
        frames.append(world.sense())
    return frames, world.calibration


def bench_features(repeats: int = 7, number: int = 200) -> dict:
    from tactile_bt.perception.features import extract
    from tactile_bt.perception.baseline import extract_with_regionprops

    frames, calibration = _cable_frames()
    images = [calibration.force_from_raw(f) for f in frames]
    it = iter(range(1 << 62))

    def ours():
        extract(images[next(it) % len(images)])

    def baseline():
        extract_with_regionprops(images[next(it) % len(images)], defaults.CONTACT_THRESHOLD_N)

    def hough():
        extract(images[next(it) % len(images)], method="hough")

    t_ours = _per_call(ours, repeats, number)
    t_base = _per_call(baseline, repeats, max(1, number // 5))
    t_hough = _per_call(hough, repeats, max(1, number // 5))
    return {
        "extract_moments_us": t_ours * 1e6,
        "extract_hough_us": t_hough * 1e6,
        "regionprops_baseline_us": t_base * 1e6,
        "speedup_vs_regionprops": t_base / t_ours,
        "target_speedup": 20.0,
    }


def bench_control_cycle(repeats: int = 7, number: int = 500) -> dict:
    from tactile_bt.tree.loader import load_tree
    from tactile_bt.mission.loop import ControlLoop

    frames, calibration = _cable_frames()
    tree = load_tree(TREE)
    loop = ControlLoop(tree, calibration, 1.0 / defaults.RATE_HZ)
    pose = np.eye(4)
    state = {"k": 0}

    def cycle():
        k = state["k"]
        loop.cycle(frames[k % len(frames)], pose, k / defaults.RATE_HZ)
        state["k"] = k + 1

    for _ in range(50):  # past the approach: the servo leaves are running
        cycle()
    t = _per_call(cycle, repeats, number)
    period = 1.0 / defaults.MAX_SENSOR_RATE_HZ
    return {
        "control_cycle_us": t * 1e6,
        "frame_period_1900hz_us": period * 1e6,
        "share_of_frame_period": t / period,
    }


#: The force gains of trees/cable_follow.yaml suit the compliant arm; on the ideal mount the
#: contact is 10-100x stiffer, and these are the gains that suit it.
IDEAL_FORCE_GAINS = "{target_pa: 2000, kp: 5.0e-6, ki: 5.0e-6}"


def _cable_tree(ideal: bool):
    from tactile_bt.tree.loader import load_tree

    if not ideal:
        return load_tree(TREE)
    text = TREE.read_text().replace("force_hold: {target_pa: 2000}", f"force_hold: {IDEAL_FORCE_GAINS}")
    return load_tree(TREE, text=text)


def _stages(tree, scene_path, overrides, seconds: float) -> dict:
    """Where the time of a mission goes, per cycle: the same loop as the mission's, timed per
    stage (µs), and each stage's share of the cycle period (the mission time it simulates)."""
    from tactile_bt.control.spatial import body_to_spatial
    from tactile_bt.mission.loop import ControlLoop
    from tactile_bt.sim.scene import load_scene

    scene = load_scene(scene_path, overrides)
    world = scene.build_world(np.random.default_rng(0))
    loop = ControlLoop(tree, world.calibration, 1.0 / scene.rate_hz, profile=True, pad=scene.sensor.geometry)
    stages = np.zeros(3)
    n = max(1, int(seconds * scene.rate_hz))
    for k in range(n):
        t = k / scene.rate_hz
        t0 = time.perf_counter()
        world.update(t)
        raw = world.sense()
        t1 = time.perf_counter()
        pose = world.pose
        twist = loop.cycle(raw, pose, t)
        t2 = time.perf_counter()
        world.move(body_to_spatial(pose, twist), 1.0 / scene.rate_hz)
        stages += (t1 - t0, t2 - t1, time.perf_counter() - t2)
    stages = stages / n * 1e6
    perception, tick = (np.array(loop.stage_times) / max(loop.stage_cycles, 1) * 1e6).tolist()
    per_cycle = {
        "simulated_sensor": stages[0],
        "control_loop": stages[1],
        "of_which_perception": perception,
        "of_which_tree_tick_and_controller": tick,
        "mount_move": stages[2],
    }
    period_us = 1e6 / scene.rate_hz
    return {"mount": scene.mount.type, "cycle_period_us": period_us, "per_cycle_us": per_cycle,
            "share_of_cycle_period": {k: v / period_us for k, v in per_cycle.items()}}


def bench_mission(duration: float = 20.0, ideal: bool = False, stage_seconds: float = 10.0) -> dict:
    """Closed-loop cable mission on the arm (or the ideal mount) against real time; where the
    time goes (over the first ``stage_seconds`` of mission time)."""
    from tactile_bt.mission.run import run_mission

    overrides = IDEAL if ideal else None
    result = run_mission(_cable_tree(ideal), SCENE, duration=duration, seed=0, overrides=overrides)
    return {
        "status": result.summary.status,
        "real_time_factor": result.summary.real_time_factor,
        "sim_time_s": result.summary.sim_time_s,
        "wall_time_s": result.summary.wall_time_s,
        "target_real_time_factor": 25.0,
        **_stages(_cable_tree(ideal), SCENE, overrides, min(duration, stage_seconds)),
    }


def bench_node_status(duration: float = 20.0, repeats: int = 3) -> dict:
    """The cable mission on the arm with and without the node status log (``node_status``),
    alternated ``repeats`` times in this process; each real-time factor is the best of its runs
    (the least disturbed by other work on the machine)."""
    from tactile_bt.mission.run import run_mission

    rtf = {True: [], False: []}
    for _ in range(repeats):
        for logged in (False, True):
            result = run_mission(_cable_tree(False), SCENE, duration=duration, seed=0, node_status=logged)
            rtf[logged].append(result.summary.real_time_factor)
    with_, without = max(rtf[True]), max(rtf[False])
    return {"mission_s": duration, "repeats": repeats, "real_time_factor_with": with_,
            "real_time_factor_without": without, "drop": 1.0 - with_ / without, "target_drop": 0.05}


def bench_scan(duration: float = 240.0, stage_seconds: float = 5.0) -> dict:
    """The stripe scan of the ellipsoid (``trees/surface_scan_stripes.yaml`` on
    ``sim/scan_ellipsoid.yaml``, on the compliant arm) against real time, for ``duration`` s of
    mission time (240 s: the scene's budget), and where the time goes."""
    from tactile_bt.mission.run import run_mission
    from tactile_bt.tree.loader import load_tree

    result = run_mission(SCAN_TREE, SCAN_SCENE, duration=duration, seed=0, reconstruct="none")
    return {
        "status": result.summary.status,
        "real_time_factor": result.summary.real_time_factor,
        "sim_time_s": result.summary.sim_time_s,
        "wall_time_s": result.summary.wall_time_s,
        "target_real_time_factor": 15.0,
        **_stages(load_tree(SCAN_TREE), SCAN_SCENE, None, min(duration, stage_seconds)),
    }


def _timed_run(command: list[str], env: dict, out: str) -> tuple[float, float]:
    """Wall time (s) of a ``tactile-bt run`` in a fresh process, and its mission time (s)."""
    started = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise RuntimeError(f"bench: {' '.join(command)} failed: {done.stderr.strip()[-500:]}")
    report = Path(out) / "report.json"
    sim = float(json.loads(report.read_text())["sim_time_s"]) if report.is_file() else float("nan")
    return wall, sim


def bench_first_run(duration: float | None = None, command: list[str] | None = None) -> dict:
    """The README's main command in fresh Python processes: the cable mission (``tactile-bt run
    ... --out DIR``), first with an empty cache of compiled kernels (``NUMBA_CACHE_DIR`` a new
    directory, as after a fresh install: the kernels are compiled), then again with that cache
    filled (they are loaded); and its render (``tactile-bt view DIR --png DIR/render.png``,
    which compiles nothing).  ``duration`` shortens the mission (default: the scene's, the
    README's); ``command`` replaces the mission's command and skips the render (for tests).

    Returns the wall times (s, process start to exit), the mission time, and the ratios: cold
    over warm, and mission time over each (the real-time factor including start-up); and the
    whole main command (mission and render) on an empty and on a filled cache.
    """
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        cmd = command or [sys.executable, "-m", "tactile_bt.cli", "run", str(TREE), "--scene", str(SCENE),
                          "--out", out]
        if duration is not None and command is None:
            cmd += ["--duration", f"{duration:g}"]
        path = os.pathsep.join(p for p in (str(IMPORT_ROOT), os.environ.get("PYTHONPATH", "")) if p)
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=path)
        cold, sim = _timed_run(cmd, env, out)
        view = None
        if command is None:
            view, _ = _timed_run([sys.executable, "-m", "tactile_bt.cli", "view", out, "--png",
                                  str(Path(out) / "render.png")], env, out)
        warm, _ = _timed_run(cmd, env, out)
    return {
        "command": "tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --out DIR"
                   + (f" --duration {duration:g}" if duration is not None else ""),
        "mission_s": sim,
        "cold_cache_s": cold,
        "warm_cache_s": warm,
        "cold_over_warm": cold / warm,
        "cold_real_time_factor": sim / cold,
        "warm_real_time_factor": sim / warm,
        "view_s": view,
        "main_command_cold_s": None if view is None else cold + view,
        "main_command_warm_s": None if view is None else warm + view,
    }


def bench_mesh_scene() -> dict:
    """Loading the mesh scene: the signed-distance grid is built once per process."""
    from tactile_bt.sim.scene import load_scene

    started = time.perf_counter()
    scene = load_scene(shipped.path("sim/object.yaml"))
    first = time.perf_counter() - started
    grid = next(o for o in scene.objects if o.type_name == "mesh").grid
    started = time.perf_counter()
    load_scene(shipped.path("sim/object.yaml"))
    return {"first_load_s": first, "sdf_grid_build_s": grid.build_time_s,
            "cached_load_s": time.perf_counter() - started, "grid_points": int(grid.values.size)}


def _synthetic_cloud(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points with normals on the upper half of a lying cylinder (R 50 mm, 200 mm long),
    with 0.1 mm noise: what a scan of its upper side records."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-1.3, 1.3, n)
    x = rng.uniform(-0.1, 0.1, n)
    normals = np.column_stack((np.zeros(n), np.sin(theta), np.cos(theta)))
    points = np.column_stack((x, 0.05 * normals[:, 1], 0.05 + 0.05 * normals[:, 2]))
    return points + rng.normal(0.0, 1e-4, points.shape), normals


def bench_reconstruction(n: int = 20000, methods=("delaunay", "surface", "hull", "auto"), repeats: int = 1,
                         seed: int = 0) -> dict:
    """Time :func:`~tactile_bt.contacts.reconstruct.reconstruct` on a synthetic ``n``-point scan cloud (target: under 2 s).

    Returns
    -------
    dict
        ``points``, ``target_s`` (2.0) and, per method, ``<method>_s`` (best of ``repeats``
        wall times, s) and ``<method>_faces``.
    """
    from tactile_bt.contacts.reconstruct import reconstruct

    points, normals = _synthetic_cloud(n, seed)
    out: dict = {"points": int(n), "target_s": 2.0}
    for method in methods:
        best, faces = float("inf"), 0
        for _ in range(max(1, repeats)):
            r = reconstruct(points, normals, method=method)
            best, faces = min(best, r.time_s), r.info["faces"]
        out[f"{method}_s"] = best
        out[f"{method}_faces"] = faces
    return out


def _warm_up() -> None:
    """One short mission, so that a worker has imported and compiled what the runs use."""
    from tactile_bt.mission.run import run_mission

    run_mission(shipped.path("trees/force_hold.yaml"), shipped.path("sim/pen.yaml"), duration=0.1, seed=0)


def bench_sweep(runs: int = 8, duration: float = 2.0, workers: int = 2, repeats: int = 2) -> dict:
    """Throughput of a sweep: ``runs`` force-hold missions of ``duration`` s on the pen (seeds
    0, 1, ...), in this process and on a local Dask cluster of ``workers`` processes.

    The cluster's start and one warm-up mission per worker are not timed: the figure is the
    steady rate of a long study, the best of ``repeats`` (the machine may be shared). Without
    Dask only the first figure is measured.
    """
    from tactile_bt.experiments.executors import DaskExecutor, InProcess, dask_available
    from tactile_bt.experiments.sweep import SweepSpec, execute, plan

    tree, scene = shipped.path("trees/force_hold.yaml"), shipped.path("sim/pen.yaml")
    spec = SweepSpec(file="<bench>", tree=str(tree), tree_label="trees/force_hold.yaml",
                     scenes=(("sim/pen.yaml", str(scene)),), seeds=tuple(range(runs)), duration=duration)
    todo = plan(spec)

    def rate(executor) -> float:
        best = 0.0
        for _ in range(max(1, repeats)):
            started = time.perf_counter()
            rows = [row for _, row, _ in executor.run(execute, todo)]
            elapsed = time.perf_counter() - started
            failed = [r for r in rows if r["status"] == "error"]
            if failed:
                raise RuntimeError(f"a bench run failed: {failed[0]['reason']}")
            best = max(best, len(rows) / elapsed)
        return best

    _warm_up()
    out = {"runs": int(runs), "mission_s": float(duration), "workers": int(workers), "repeats": int(repeats),
           "runs_per_s_1_worker": rate(InProcess())}
    if not dask_available():
        out.update(runs_per_s_n_workers=None, speedup=None, note="dask is not installed")
        return out
    with DaskExecutor(workers=workers) as executor:
        executor.client.run(_warm_up)
        out["runs_per_s_n_workers"] = rate(executor)
    out["speedup"] = out["runs_per_s_n_workers"] / out["runs_per_s_1_worker"]
    return out


def run_bench(quick: bool = False) -> dict:
    """All speed figures; ``quick`` uses fewer repetitions and shorter missions (the cable
    mission 5 s, the scan 30 s of its 240 s, the first runs 5 s)."""
    repeats = 3 if quick else 7
    return {
        "features": bench_features(repeats, 100 if quick else 300),
        "control_cycle": bench_control_cycle(repeats, 200 if quick else 1000),
        "cable_mission": bench_mission(5.0 if quick else 20.0),
        "cable_mission_ideal_mount": bench_mission(5.0 if quick else 20.0, ideal=True),
        "node_status": bench_node_status(5.0 if quick else 20.0, repeats=2 if quick else 3),
        "stripe_scan": bench_scan(30.0 if quick else 240.0),
        "first_run": bench_first_run(5.0 if quick else None),
        "mesh_scene": bench_mesh_scene(),
        "reconstruction": bench_reconstruction(n=20000, repeats=1 if quick else 3),
        "sweep": bench_sweep(runs=4 if quick else 8, repeats=1 if quick else 2),
    }


def format_bench(figures: dict) -> str:
    f, c = figures["features"], figures["control_cycle"]
    lines = [
        f"feature extraction  {f['extract_moments_us']:7.1f} µs  vs regionprops {f['regionprops_baseline_us']:7.1f} µs"
        f"  → {f['speedup_vs_regionprops']:.1f}x faster (target ≥ {f['target_speedup']:.0f}x)",
        f"                    Hough orientation {f['extract_hough_us']:.1f} µs",
        f"control cycle       {c['control_cycle_us']:7.1f} µs  = {c['share_of_frame_period']:.0%} of the 1.9 kHz frame period",
    ]
    for key, label in (("cable_mission", "cable mission"), ("cable_mission_ideal_mount", "cable mission"),
                       ("stripe_scan", "stripe scan  ")):
        if key not in figures:
            continue
        m = figures[key]
        lines.append(f"{label} ({m['mount']:9s}) {m['real_time_factor']:5.1f}x real time at 250 Hz "
                     f"(target ≥ {m['target_real_time_factor']:.0f}x)")
        shares = m.get("share_of_cycle_period", {})
        lines.append("  per cycle: " + ", ".join(
            f"{k} {v:.0f} µs" + (f" ({shares[k]:.1%})" if k in shares else "") for k, v in m["per_cycle_us"].items()))
    if "node_status" in figures:
        s = figures["node_status"]
        lines.append(f"node status log     cable mission {s['real_time_factor_without']:.1f}x real time without, "
                     f"{s['real_time_factor_with']:.1f}x with, {s['drop']:.1%} slower (target < {s['target_drop']:.0%}; "
                     f"best of {s['repeats']} alternated runs of {s['mission_s']:g} s)")
    if "first_run" in figures:
        r = figures["first_run"]
        lines.append(f"first run           {r['cold_cache_s']:.1f} s with an empty kernel cache, {r['warm_cache_s']:.1f} s "
                     f"cached ({r['cold_over_warm']:.1f}x), for {r['mission_s']:.1f} s of mission: "
                     f"{r['cold_real_time_factor']:.1f}x and {r['warm_real_time_factor']:.1f}x real time")
        lines.append(f"  ({r['command']})")
        if r.get("view_s") is not None:
            lines.append(f"main command        {r['main_command_cold_s']:.1f} s the first time, "
                         f"{r['main_command_warm_s']:.1f} s after (mission, then its render: {r['view_s']:.1f} s)")
    if "reconstruction" in figures:
        r = figures["reconstruction"]
        times = ", ".join(f"{k[:-2]} {v:.2f} s" for k, v in r.items() if k.endswith("_s") and k != "target_s")
        lines.append(f"reconstruction      20,000 contacts: {times} (target < {r.get('target_s', 2.0):g} s)")
    if "mesh_scene" in figures:
        g = figures["mesh_scene"]
        lines.append(f"mesh scene load     {g['first_load_s']:.2f} s first ({g['sdf_grid_build_s']:.2f} s SDF grid of "
                     f"{g['grid_points']} points), {g['cached_load_s'] * 1e3:.0f} ms cached")
    if "sweep" in figures:
        w = figures["sweep"]
        line = (f"sweep throughput    {w['runs']} runs of {w['mission_s']:g} s: {w['runs_per_s_1_worker']:.2f} runs/s "
                f"with 1 worker")
        if w.get("runs_per_s_n_workers") is not None:
            line += (f", {w['runs_per_s_n_workers']:.2f} runs/s with {w['workers']} Dask workers "
                     f"→ {w['speedup']:.2f}x")
        else:
            line += f" ({w.get('note', 'no Dask figure')})"
        lines.append(line)
    return "\n".join(lines)
