"""The mission loop: one control cycle per tick, in the order of DESIGN.md.

sense → calibrate → extract → smooth → blackboard → tree tick → ServoController →
Ad(T_gs) → mount/robot → log. Nothing else reaches across: the tree never talks to the robot.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import py_trees
from py_trees.common import Status

from tactile_bt.errors import MissionLengthError
from tactile_bt import defaults
from tactile_bt.tree.behaviours import NAMESPACE, TactileBehaviour
from tactile_bt.tree.behaviours.base import cycle_writer
from tactile_bt.tree.behaviours.record import ContactCloud, RecordContacts
from tactile_bt.control.servo import ServoCommand
from tactile_bt.perception.features import extract
from tactile_bt.perception.smoothing import FeatureSmoother
from tactile_bt.mission.metrics import controlled_feature_metrics, path_error
from tactile_bt.control.spatial import body_to_spatial

__all__ = ["run_mission", "ControlLoop", "MissionResult", "MissionLog", "calibration_path"]

_ERRORS = tuple(defaults.METRIC_BANDS)  # the logged error of every controllable feature


class MissionLog:
    """Preallocated per-cycle time series; :meth:`arrays` gives the rows written so far."""

    SCALARS = (
        "t",
        "in_contact",
        "force_n",
        "area",
        "pressure_raw_pa",
        "pressure_pa",
        "cop_x_px",
        "cop_y_px",
        "orientation_raw_rad",
        "orientation_rad",
        "penetration_m",
        *(f"error_{e}" for e in _ERRORS),
    )

    def __init__(self, n: int) -> None:
        self.n = 0
        self.scalars = {k: np.full(n, np.nan) for k in self.SCALARS}
        self.twist = np.zeros((n, 6))
        self.position = np.zeros((n, 3))
        self.rotation = np.zeros((n, 3, 3))
        self.joints: np.ndarray | None = None  # (n, 7) rad, when the pad is on the arm

    def record(self, k: int, t: float, loop: "ControlLoop", twist_s: np.ndarray, pose: np.ndarray,
               penetration: float = float("nan")) -> None:
        """Store cycle ``k`` (mission time ``t``) of a control loop."""
        f_raw, f = loop.features_raw, loop.features
        s = self.scalars
        s["t"][k] = t
        s["in_contact"][k] = f_raw.in_contact
        s["force_n"][k] = f_raw.force
        s["area"][k] = f_raw.area
        s["pressure_raw_pa"][k] = f_raw.pressure
        s["pressure_pa"][k] = f.pressure
        s["cop_x_px"][k], s["cop_y_px"][k] = f_raw.cop_px.tolist()
        s["orientation_raw_rad"][k] = f_raw.orientation
        s["orientation_rad"][k] = f.orientation
        s["penetration_m"][k] = penetration
        for name, value in loop.command.errors.items():
            s["error_" + name][k] = value
        self.twist[k] = twist_s
        self.position[k] = pose[:3, 3]
        self.rotation[k] = pose[:3, :3]
        self.n = k + 1

    def arrays(self) -> dict[str, np.ndarray]:
        n = self.n
        out = {k: v[:n].copy() for k, v in self.scalars.items()}
        out["twist_s"] = self.twist[:n].copy()
        out["position_m"] = self.position[:n].copy()
        out["rotation"] = self.rotation[:n].copy()
        if self.joints is not None:
            out["joints_rad"] = self.joints[:n].copy()
        return out


@dataclass
class MissionResult:
    """What a mission leaves: the report, every logged series and the recorded contacts.

    Attributes
    ----------
    report : dict
        Same content as ``report.json``.
    log : dict of numpy arrays
        Time series keyed by name, all with the ``t`` array's length.
    contacts : (N, 6) array
        World points (m) and outward surface normals recorded by ``record_contacts``.
    contact_data : (N, 8) array
        The same with pressure (Pa) and mission time (s).
    surface : trimesh.Trimesh or None
        The surface reconstructed from the contacts (world frame, m), when the tree or the run
        asked for one (``record_contacts: {reconstruct: ...}`` or ``run_mission(reconstruct=...)``).
    """

    report: dict
    log: dict
    contact_data: np.ndarray = field(default_factory=lambda: np.zeros((0, 8)))
    surface: object = None

    @property
    def contacts(self) -> np.ndarray:
        return self.contact_data[:, :6]

    def plot(self, path: str | Path | None = None):
        """Feature errors against mission time (paper Figs. 8–10, 12b); saved when ``path``."""
        from tactile_bt.mission.outputs import plot_errors

        return plot_errors(self, path)

    def save(self, out: str | Path) -> None:
        """Write report.json, log.npz, errors.png and contacts.ply into ``out``; for a scan
        also surface.ply and render.png."""
        from tactile_bt.mission.outputs import write_outputs

        write_outputs(self, Path(out))


def calibration_path(recording: str | Path) -> Path:
    """Where a mission recording keeps the calibration of its tactels."""
    return Path(f"{recording}.calibration.npz")


def _resolve(tree, scene, overrides, params=None, blackboard=None):
    from tactile_bt.tree.loader import load_tree
    from tactile_bt.sim.scene import Scene, load_scene

    if not isinstance(tree, py_trees.trees.BehaviourTree):
        tree = load_tree(tree, params=params, blackboard=blackboard)
    elif params or blackboard:
        raise ValueError("params and blackboard apply to a tree file; set them on a BehaviourTree in Python")
    if not isinstance(scene, Scene):
        scene = load_scene(scene, list(overrides or ()))
    return tree, scene


def _failure_reason(root: py_trees.behaviour.Behaviour) -> str:
    """Name and message of the deepest failed node that says why (a leaf, or a decorator such
    as a timed-out mission_timeout whose child was merely stopped)."""
    failed = [b for b in root.iterate() if b.status == Status.FAILURE and b.feedback_message]
    if failed:
        node = failed[0]  # iterate() yields children before their parents
        return f"{node.name}: {node.feedback_message}"
    return root.feedback_message


class ControlLoop:
    """One control cycle of DESIGN.md, without the robot: raw frame → sensor-frame twist.

    calibrate → extract → smooth → blackboard → tree tick → summed twist. Used by the
    simulated mission, by the hardware loop and by the benchmark, so all three time the same
    code.

    Parameters
    ----------
    tree : py_trees.trees.BehaviourTree
    calibration : TactelCalibration
        Raw counts → newtons per tactel.
    dt : float
        Control period (s).
    orientation_method : "moments" or "hough"
    threshold : float
        Binarisation threshold (N per tactel).
    profile : bool
        Accumulate the time spent per stage in :attr:`stage_times`.
    """

    def __init__(self, tree, calibration, dt: float, orientation_method: str = "moments",
                 threshold: float = defaults.CONTACT_THRESHOLD_N, profile: bool = False) -> None:
        self.tree = tree
        self.calibration = calibration
        self.dt = float(dt)
        self.orientation_method = orientation_method
        self.threshold = float(threshold)
        self.command = ServoCommand(defaults.TWIST_LINEAR_LIMIT_MPS, defaults.TWIST_ANGULAR_LIMIT_RPS)
        self.contacts = ContactCloud()
        self.smoother = FeatureSmoother(defaults.SMOOTHING_SAMPLES)
        self.writer = cycle_writer("mission", self.command, self.contacts, self.dt)
        tree.setup()
        leaves = [b for b in tree.root.iterate() if isinstance(b, TactileBehaviour)]
        self._orientation_leaves = [b for b in leaves if "orientation" in b.uses]
        self.features_raw = None
        self.features = None
        #: With ``profile=True``: accumulated seconds in perception (calibrate, extract,
        #: smooth) and in the tree tick plus controller, over ``stage_cycles`` cycles.
        self.stage_times = [0.0, 0.0] if profile else None
        self.stage_cycles = 0
        self._storage = py_trees.blackboard.Blackboard.storage
        self._keys = tuple(f"{NAMESPACE}/{k}" for k in ("time", "pose", "features_raw", "features"))

    def cycle(self, raw: np.ndarray, pose: np.ndarray, t: float) -> np.ndarray:
        """Run one cycle on a raw frame taken at mission time ``t`` (s) with the pad at ``pose``
        (``T_gs``); returns the sensor-frame twist ``V_s`` to apply."""
        clock = time.perf_counter if self.stage_times is not None else None
        if clock:
            t0 = clock()
        image = self.calibration.force_from_raw(raw)
        # Orientation only when a running leaf uses it (a leaf starting this tick sees NaN once).
        needs_orientation = any(b.status == Status.RUNNING for b in self._orientation_leaves)
        f_raw = extract(image, self.threshold, self.orientation_method if needs_orientation else None)
        f = self.smoother(f_raw)
        if clock:
            t1 = clock()
        # Straight into the blackboard's storage: the keys are registered by ``writer`` above;
        # the client's access bookkeeping would cost more than the control law (DESIGN budget).
        storage = self._storage
        storage[self._keys[0]] = t
        storage[self._keys[1]] = pose
        storage[self._keys[2]] = f_raw
        storage[self._keys[3]] = f
        self.features_raw, self.features = f_raw, f
        self.command.clear()
        self.tree.tick()
        twist = self.command.twist()
        if clock:
            self.stage_times[0] += t1 - t0
            self.stage_times[1] += clock() - t1
            self.stage_cycles += 1
        return twist


def run_mission(
    tree,
    scene,
    duration: float | None = None,
    seed: int | None = None,
    overrides: list[str] | None = None,
    out: str | Path | None = None,
    progress: Callable[[float, float], None] | None = None,
    orientation_method: str = "moments",
    threshold: float = defaults.CONTACT_THRESHOLD_N,
    via_emulator: bool = False,
    record: str | Path | None = None,
    reconstruct: str | None = None,
    scan_region: dict | None = None,
    params: list[str] | None = None,
    blackboard: list[str] | None = None,
) -> MissionResult:
    """Run a tree against a simulated scene.

    Parameters
    ----------
    tree : BehaviourTree or path to a YAML tree
    scene : Scene or path to a YAML scene
    duration : float, optional
        Mission time (s); defaults to the scene's ``duration_s``. The mission also ends when
        the tree's root succeeds or fails.
    seed : int, optional
        Seed of every random draw (sensor characteristics, noise); defaults to the scene's.
        The same seed gives the same run, bit for bit.
    overrides : list of ``key.path=value``, optional
        Scene overrides, as ``--set`` on the command line.
    out : path, optional
        Directory for report.json, log.npz, errors.png and contacts.ply.
    progress : callable(t, duration), optional
        Called about 20 times per mission second of simulated time.
    orientation_method : "moments" or "hough"
    threshold : float
        Binarisation threshold of the force image (N per tactel).
    via_emulator : bool
        Carry every simulated frame through the device emulator, a pseudo-terminal and the
        serial driver (:mod:`tactile_bt.sense.hardware`), as a real sensor's frames would come.
    record : path, optional
        Record every raw frame with its pose into this chunked recording (and the simulated
        pad's calibration next to it, ``<record>.calibration.npz``) for ``replay_mission``.
    reconstruct : str, optional
        Reconstruct the contact cloud into a surface with this method (``auto``, ``delaunay``,
        ``surface``, ``hull``; ``none`` for no surface), overriding the tree's
        ``record_contacts: {reconstruct: ...}``. See :mod:`tactile_bt.contacts.reconstruct`.
    scan_region : dict, optional
        The part of the scene's object the scan sets out to cover, for the accuracy figures
        (:mod:`tactile_bt.mission.accuracy`); defaults to the scene's ``scan_region``, else the
        whole object.
    params : list of ``NODE.PARAM=VALUE``, optional
        Tree parameters, as ``--param`` on the command line (see :func:`tactile_bt.tree.loader.load_tree`);
        only with a tree file.
    blackboard : list of ``KEY=VALUE``, optional
        Blackboard keys the tree reads, written before it starts, as ``--blackboard``; only with a
        tree file.
    """
    tree, scene = _resolve(tree, scene, overrides, params, blackboard)
    scan = _scan_settings(tree, scene, reconstruct, scan_region)
    duration = float(scene.duration_s if duration is None else duration)
    seed = int(scene.seed if seed is None else seed)
    rng = np.random.default_rng(seed)
    world = scene.build_world(rng)
    dt = 1.0 / scene.rate_hz
    n_cycles = int(round(duration * scene.rate_hz))
    _check_cycles(n_cycles, duration, scene.rate_hz)
    if out is not None:  # before the mission: a path that cannot be written loses nothing
        from tactile_bt.mission.outputs import prepare_output_dir

        prepare_output_dir(out)

    loop = ControlLoop(tree, world.calibration, dt, orientation_method, threshold)
    contacts = loop.contacts

    log = MissionLog(n_cycles)
    joints = getattr(world.mount, "joint_angles", None)
    if joints is not None:
        log.joints = np.zeros((n_cycles, len(joints())))
    status = "completed"
    reason = ""
    progress_every = max(1, int(scene.rate_hz / 20))
    stack = contextlib.ExitStack()
    link = recorder = None
    if via_emulator:
        from tactile_bt.sense.hardware.link import EmulatedSensorLink

        link = stack.enter_context(EmulatedSensorLink(scene.sensor.rows, scene.sensor.cols))
    if record is not None:
        from tactile_bt.sense.hardware.recording import Recorder

        world.calibration.save(calibration_path(record))
        recorder = stack.enter_context(Recorder(record, scene.sensor.rows, scene.sensor.cols,
                                                metadata={"scene": scene.file, "seed": seed, "rate_hz": scene.rate_hz}))
    wall_start = time.perf_counter()
    try:
        for k in range(n_cycles):
            t = k * dt
            # scene events → sense → perceive → tick → controller → Ad(T_gs) → robot
            world.update(t)
            pose = world.pose
            raw = world.sense()
            if link is not None:  # through the device emulator, a pty and the serial driver
                raw = link.transfer(raw)
            if recorder is not None:
                recorder.write(raw, pose, timestamp=t)
            twist_s = loop.cycle(raw, pose, t)
            world.move(body_to_spatial(pose, twist_s), dt)
            log.record(k, t, loop, twist_s, pose, world.last_penetration)
            if joints is not None:
                log.joints[k] = joints()
            if progress is not None and k % progress_every == 0:
                progress(t, duration)
            root_status = tree.root.status
            if root_status == Status.SUCCESS:
                status = "success"
                break
            if root_status == Status.FAILURE:
                status = "failure"
                reason = _failure_reason(tree.root)
                break
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            status, reason = "interrupted", f"interrupted at {log.n * dt:.2f} s of mission time"
        else:
            status, reason = "error", f"{type(exc).__name__}: {exc}"
        result = _finish(tree, scene, seed, log, contacts, status, reason, wall_start, dt, scan)
        if out is not None:
            result.save(out)
        raise
    finally:
        tree.interrupt()
        stack.close()
    result = _finish(tree, scene, seed, log, contacts, status, reason, wall_start, dt, scan)
    if out is not None:
        result.save(out)
    return result


#: Largest mission the preallocated log holds (cycles): 10 min at 1.9 kHz, 76 min at 250 Hz.
MAX_CYCLES = 1_140_000


def _check_cycles(n_cycles: int, duration: float, rate_hz: float) -> None:
    if n_cycles < 1:
        raise MissionLengthError(f"duration {duration:g} s is shorter than one control cycle at {rate_hz:g} Hz")
    if n_cycles > MAX_CYCLES:
        raise MissionLengthError(f"duration {duration:g} s at {rate_hz:g} Hz is {n_cycles} cycles, more than the "
                                 f"{MAX_CYCLES} one mission logs; split the mission or lower rate_hz")


def _scan_settings(tree, scene, reconstruct, scan_region) -> dict | None:
    """Reconstruction method and scan region of a mission (checked before it runs), or None
    when it reconstructs nothing: ``reconstruct`` or else the tree's ``record_contacts``."""
    method = reconstruct
    if method is None:
        chosen = (b.reconstruct for b in tree.root.iterate() if isinstance(b, RecordContacts))
        method = next((m for m in chosen if m != "none"), "none")
    if method == "none":
        return None
    from tactile_bt.mission.accuracy import scan_settings

    return scan_settings(method, scene, scan_region)


def _finish(tree, scene, seed, log, contacts, status, reason, wall_start, dt, scan=None) -> MissionResult:
    wall = time.perf_counter() - wall_start
    arrays = log.arrays()
    sim_time = log.n * dt
    metrics = controlled_feature_metrics(arrays)
    if status == "completed" and not np.any(arrays["in_contact"] == 1):
        status, reason = "failure", "no contact was made"
    report = {
        "tree": getattr(tree, "source", getattr(tree.root, "name", "tree")),
        # absolute, so that `tactile-bt view DIR` finds the scene from any directory
        "scene": str(Path(scene.file).resolve()) if scene.file else "",
        "seed": seed,
        "status": status,
        "reason": reason,
        "rate_hz": scene.rate_hz,
        "sim_time_s": sim_time,
        "wall_time_s": wall,
        "real_time_factor": sim_time / wall if wall > 0 else float("inf"),
        "ticks": log.n,
        "metrics": metrics,
        "contacts": len(contacts),
    }
    cable = scene.cable
    if cable is not None:
        report["path_error_m"] = path_error(contacts.points[:, :2], cable)
        # The same for the plain centre of pressure of every cycle in contact, for comparison.
        touching = (arrays["in_contact"] == 1) & np.isfinite(arrays["cop_x_px"])
        if touching.any():
            c = (np.stack((arrays["cop_x_px"], arrays["cop_y_px"]), axis=1)[touching]
                 - (defaults.COLS - 1) / 2) * defaults.PITCH_M
            R = arrays["rotation"][touching]
            world = np.einsum("nij,nj->ni", R[:, :, :2], c) + arrays["position_m"][touching]
            cop_error = path_error(world[:, :2], cable)
            report["path_error_cop_m"] = {"mean": cop_error["mean"], "max": cop_error["max"]}
    surface = None
    if scan is not None and len(contacts):
        from tactile_bt.mission.accuracy import contact_continuity, evaluate_scan

        try:
            surface, figures = evaluate_scan(scene, contacts.data, scan["method"], scan["region"])
        except Exception as exc:  # a failed reconstruction must not lose the mission's outputs
            figures = {"method": scan["method"], "error": f"{type(exc).__name__}: {exc}"}
        figures.update(contact_continuity(arrays["t"], arrays["in_contact"]))
        report["reconstruction"] = figures
    return MissionResult(report=report, log=arrays, contact_data=contacts.data.copy(), surface=surface)
