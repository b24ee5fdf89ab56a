"""A mission: a tree run against a simulated scene, one control cycle per tick.

scene events → sense → (serial link) → :class:`~tactile_bt.mission.loop.ControlLoop`
(calibrate → extract → smooth → blackboard → tree tick → twist) →
:class:`~tactile_bt.mission.supervisor.Supervisor` → ``Ad(T_gs)`` → mount → log, then
:func:`~tactile_bt.mission.result.finish_mission`. Nothing else reaches across: the tree never
talks to the robot.

Layer: mission.
"""

from __future__ import annotations

import contextlib
import math
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import py_trees

from tactile_bt import defaults
from tactile_bt.control.spatial import body_to_spatial
from tactile_bt.arguments import check_output_dir
from tactile_bt.errors import MissionInterrupted, MissionLengthError
from tactile_bt.mission.log import MissionLog
from tactile_bt.mission.loop import ControlLoop, root_outcome
from tactile_bt.mission.outputs import prepare_output_dir, present_outputs
from tactile_bt.mission.result import MissionResult, finish_mission
from tactile_bt.mission.supervisor import Supervisor, SupervisorLimits
from tactile_bt.mission.watch import MissionWatcher, finish_watchers, start_watchers
from tactile_bt.tree.blackboard import write_joints_held, write_turn_room
from tactile_bt.sim import warmup as kernel_build
from tactile_bt.tree.behaviours.contact_points import RecordContacts

__all__ = ["run_mission", "calibration_path", "scene_table_height", "MAX_CYCLES"]


def calibration_path(recording: str | Path) -> Path:
    """Where a mission recording keeps the calibration of its tactels."""
    return Path(f"{recording}.calibration.npz")


def _resolve(tree, scene, overrides, params=None, blackboard=None):
    """The tree and scene of a mission: a tree file is loaded with the scene's pad, which
    converts its lengths in tactels (``band: 0.5 px``)."""
    from tactile_bt.tree.loader import LoadedTree, load_tree
    from tactile_bt.sim.scene import Scene, load_scene

    is_tree = isinstance(tree, py_trees.trees.BehaviourTree)
    if is_tree and (params or blackboard):
        raise ValueError("params and blackboard apply to a tree file; set them on a BehaviourTree in Python")
    if not isinstance(scene, Scene):
        scene = load_scene(scene, list(overrides or ()))
    pad = scene.sensor.geometry
    if not is_tree:
        tree = load_tree(tree, params=params, blackboard=blackboard, pad=pad)
    elif isinstance(tree, LoadedTree):
        tree.check_pad(pad, f"the pad of scene {scene.file} (scene.sensor.geometry)")
    return tree, scene


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
    recording: str | Path | None = None,
    reconstruct: str | None = None,
    scan_region: dict | None = None,
    params: list[str] | None = None,
    blackboard: list[str] | None = None,
    node_status: bool = True,
    watchers: Sequence[MissionWatcher] = (),
) -> MissionResult:
    """Run a tree against a simulated scene.

    Parameters
    ----------
    tree : BehaviourTree or path to a YAML tree
        A tree file is loaded with the scene's pad (``scene.sensor.geometry``): its lengths in
        tactels (``band: 0.5 px``) use the scene's pitch. A tree from
        :func:`~tactile_bt.tree.loader.load_tree` whose tactels were converted with another
        pitch is an error (:class:`~tactile_bt.errors.TreeError`).
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
    recording : path, optional
        Record every raw frame with its pose into this chunked recording (and the simulated
        pad's calibration next to it, ``<recording>.calibration.npz``) for ``replay_mission``.
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
    node_status : bool
        Log every node's status per tick (``node_names``, ``node_status`` in the log, and
        ``tree.png``); False only to measure what that costs.
    watchers : sequence of MissionWatcher
        Shown every cycle (:mod:`tactile_bt.mission.watch`), e.g. the rerun recording
        (:class:`~tactile_bt.mission.recording_rerun.RerunRecorder`).
    """
    kernel_build.start()  # on a cold kernel cache: a second process starts compiling kernels
    try:  # Ctrl-C while loading and compiling: out still holds what it held
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
            check_output_dir(out)

        # ... and the rest here, before the mission's clock starts; waiting on the second process,
        # import what the outputs need
        if kernel_build.compiling() and hasattr(progress, "stage"):  # not "0 %" for a quarter of a minute
            progress.stage("compiling the simulator's kernels (once after an install)")
        kernel_build.finish(idle=None if out is None else _import_output_modules)
    except KeyboardInterrupt:
        if out is None:
            raise
        raise MissionInterrupted(out, earlier=present_outputs(out)) from None
    pad = scene.sensor.geometry
    table_z_m = _write_setup(scene)  # before the tree's setup, so that --blackboard can override it
    write_joints_held(None)  # nothing held yet (nor left from an earlier mission in this process)
    write_turn_room(getattr(world.mount, "turn_room", None))  # read by the tree when it needs it
    loop = ControlLoop(tree, world.calibration, dt, orientation_method, threshold, pad=pad)
    contacts = loop.contacts
    supervisor = Supervisor(SupervisorLimits.for_tree(tree, scene.supervisor))

    log = MissionLog(n_cycles)
    joints = getattr(world.mount, "joint_angles", None)
    arm_state = getattr(world.mount, "saturation", None)  # the arm: saturated joints, unrealised twist
    if joints is not None:
        log.track_joints(len(joints()), getattr(world.mount, "limits", None))
    if node_status:
        log.track_nodes(tree.root)
    status = "completed"
    reason = ""
    progress_every = max(1, int(scene.rate_hz / 20))
    stack = contextlib.ExitStack()
    link = recorder = None
    if via_emulator:
        from tactile_bt.sense.hardware.link import EmulatedSensorLink

        link = stack.enter_context(EmulatedSensorLink(pad.rows, pad.cols))
    if recording is not None:
        from tactile_bt.sense.hardware.recording import Recorder

        world.calibration.save(calibration_path(recording))
        recorder = stack.enter_context(Recorder(recording, pad.rows, pad.cols,
                                                metadata={"scene": scene.file, "seed": seed, "rate_hz": scene.rate_hz,
                                                          "pitch_m": pad.pitch,
                                                          "table_z_m": None if math.isnan(table_z_m) else table_z_m}))
    if out is not None:  # the run starts writing: an earlier run's outputs go
        prepare_output_dir(out)
    watchers = start_watchers(watchers, loop, log, scene)
    wall_start = time.perf_counter()
    try:
        for k in range(n_cycles):
            t = k * dt
            # scene events → sense → perceive → tick → controller → supervisor → Ad(T_gs) → robot
            world.update(t)
            pose = world.pose
            raw = world.sense()
            if link is not None:  # through the device emulator, a pty and the serial driver
                raw = link.transfer(raw)
            if recorder is not None:
                recorder.write(raw, pose, timestamp=t)
            twist_s = loop.cycle(raw, pose, t)
            twist_s = supervisor.check(loop.features, pose, twist_s, t)
            world.move(body_to_spatial(pose, twist_s), dt)
            log.write(k, t, loop, twist_s, pose, world.last_penetration)
            if joints is not None:
                state = arm_state() if arm_state is not None else ()
                log.write_joints(k, joints(), *state)
                if state:
                    write_joints_held(state[0])  # what the tree sees of the arm next cycle
            for watcher in watchers:
                watcher.cycle(k, t, loop, log)
            if progress is not None and k % progress_every == 0:
                progress(t, duration)
            outcome = supervisor.outcome or root_outcome(tree.root)
            if outcome is not None:
                status, reason = outcome
                break
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            status, reason = "interrupted", f"interrupted at {log.n * dt:.2f} s of mission time"
        else:
            status, reason = "error", f"{type(exc).__name__}: {exc}"
        result = finish_mission(tree, log, contacts, status, reason, wall_start, log.n * dt, scene=scene,
                                seed=seed, scan=scan, supervision=supervisor.summary())
        if out is not None:
            result.save(out)
        finish_watchers(watchers, result)
        if out is not None and isinstance(exc, KeyboardInterrupt):
            raise MissionInterrupted(out, written=present_outputs(out), sim_time_s=log.n * dt) from None
        raise
    finally:
        supervisor.stop()  # the mount's last command is a zero twist, however the mission ends
        tree.interrupt()
        stack.close()
    result = finish_mission(tree, log, contacts, status, reason, wall_start, log.n * dt, scene=scene, seed=seed,
                            scan=scan, supervision=supervisor.summary())
    if out is not None:
        result.save(out)
    finish_watchers(watchers, result)
    return result


def scene_table_height(scene) -> float:
    """The height of the scene's table top (m, world z; NaN when it has none): the part of the
    robot's set-up a tree may know. Never the object."""
    table = scene.table
    return math.nan if table is None else float((table.pose @ (0.0, 0.0, table.height, 1.0))[2])


def _write_setup(scene) -> float:
    """The robot's known set-up on the blackboard, for the tree: the height of the scene's
    table (``/setup/table_z_m``). Returns the height written."""
    from tactile_bt.tree.behaviours.table import write_table_height

    height = scene_table_height(scene)
    write_table_height(height)
    return height


#: Largest mission the preallocated log holds (cycles): 10 min at 1.9 kHz, 76 min at 250 Hz.
MAX_CYCLES = 1_140_000


def _import_output_modules() -> None:
    """Import the plotting the outputs need (:func:`tactile_bt.mission.outputs.plot_errors`)."""
    import matplotlib.pyplot  # noqa: F401


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


