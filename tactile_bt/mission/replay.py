"""Feed a recording back through perception and a tree: the same control loop and the same
finish as a mission, on recorded frames and poses instead of a simulator or a live sensor.

A recording made by ``run_mission(..., recording=FILE)`` or ``tactile-bt sensor record`` replays
deterministically: the same recording and tree give the same features and twists, at any speed.

Layer: mission.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import numpy as np
import py_trees

from tactile_bt.errors import RecordingError, ReplayError
from tactile_bt import defaults
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.sense.geometry import PadGeometry

__all__ = ["replay_mission"]


def replay_mission(tree, recording: str | Path, calibration: TactelCalibration | str | Path | None = None,
                   speed: float | None = None, orientation_method: str = "moments", out: str | Path | None = None,
                   watchers=()):
    """Run ``tree`` on the frames of ``recording``; returns a :class:`~tactile_bt.mission.result.MissionResult`.

    Parameters
    ----------
    tree : BehaviourTree or path to a YAML tree
    recording : path
        A chunked recording (:mod:`tactile_bt.sense.hardware.recording`).
    calibration : TactelCalibration or path, optional
        Raw counts → newtons. Default: ``<recording>.calibration.npz`` when it exists (written by
        mission recordings), else the nominal characteristic, with a
        :class:`~tactile_bt.sense.hardware.recording.RecordingWarning`.
    speed : float, optional
        ``None`` as fast as possible, ``1.0`` at the recorded pace, ``2.0`` twice as fast.
        The results do not depend on it.
    watchers : sequence of MissionWatcher
        Shown every cycle, as in :func:`~tactile_bt.mission.run.run_mission` (e.g. the rerun
        recording).

    The tree finds the set-up the mission had on the blackboard: the table height a mission
    recording holds (``/setup/table_z_m``; NaN for a recording of the sensor alone).
    A torn last chunk is left out with a ``RecordingWarning``; ``report["warnings"]`` lists
    every warning of the replay.  Raises :class:`~tactile_bt.sense.hardware.recording.RecordingError`
    for an unreadable or empty recording and :class:`ReplayError` for an unusable calibration
    or speed.
    """
    from tactile_bt.sense.hardware.recording import read_recording, torn_tail_message
    from tactile_bt.errors import RecordingError, RecordingWarning
    from tactile_bt.tree.loader import LoadedTree, load_tree
    from tactile_bt.mission.log import MissionLog
    from tactile_bt.mission.loop import ControlLoop, root_outcome
    from tactile_bt.mission.result import finish_mission
    from tactile_bt.mission.run import calibration_path
    from tactile_bt.mission.watch import finish_watchers, start_watchers
    from tactile_bt.tree.behaviours.table import write_table_height

    if speed is not None and not (math.isfinite(speed) and speed > 0):
        raise ReplayError(f"speed must be a finite number > 0 or None, got {speed}")
    if out is not None:  # before the replay: a path that cannot be written loses nothing
        from tactile_bt.mission.outputs import prepare_output_dir

        prepare_output_dir(out)
    rec = read_recording(recording)
    n = len(rec.timestamps)
    if n == 0:
        torn = "" if rec.torn_tail_offset is None else f" (the chunk at byte {rec.torn_tail_offset} is torn)"
        raise RecordingError(f"{recording}: the recording holds no complete chunk{torn}")
    # The pad: its shape from the frames, its pitch from a mission recording (else the default).
    pitch = rec.metadata.get("pitch_m")
    try:
        pad = PadGeometry(rec.rows, rec.cols) if pitch is None else PadGeometry(rec.rows, rec.cols, float(pitch))
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{recording}: metadata pitch_m {pitch!r} does not describe a pad: {exc}") from None
    if not isinstance(tree, py_trees.trees.BehaviourTree):
        tree = load_tree(tree, pad=pad)  # lengths in tactels: of the recorded pad
    elif isinstance(tree, LoadedTree):
        tree.check_pad(pad, f"the pad of recording {recording}")
    notes = []
    if rec.torn_tail_offset is not None:
        notes.append(torn_tail_message(recording, rec.torn_tail_offset, n))
    source = calibration
    if calibration is None:
        source = calibration_path(recording)
        if not source.exists():
            notes.append(f"{source} is missing: using the nominal tactel characteristic "
                         f"(--calibration FILE chooses one)")
            calibration = TactelCalibration.nominal(pad=pad)
    if not isinstance(calibration, TactelCalibration):
        try:
            calibration = TactelCalibration.load(source)
        except ValueError as exc:
            raise ReplayError(str(exc)) from exc
    if calibration.offset.shape != rec.values.shape[1:]:
        name = "the calibration" if isinstance(source, TactelCalibration) else f"calibration {source}"
        raise ReplayError(f"{name} holds {'x'.join(map(str, calibration.offset.shape))} tactels, "
                          f"the recording {recording} {rec.rows}x{rec.cols}")
    for note in notes:
        warnings.warn(RecordingWarning(note), stacklevel=2)
    t = rec.timestamps - rec.timestamps[0]
    if "rate_hz" in rec.metadata:  # a mission recording: its exact control period
        dt = 1.0 / float(rec.metadata["rate_hz"])
    else:
        dt = float(np.median(np.diff(t))) if n > 1 else 1.0 / defaults.RATE_HZ
    write_table_height(_table_height(rec.metadata, recording))  # the set-up the mission had
    loop = ControlLoop(tree, calibration, dt, orientation_method, pad=pad)
    log = MissionLog(n)
    log.track_nodes(tree.root)
    watchers = start_watchers(watchers, loop, log)
    status, reason, wall_start = "completed", "", time.perf_counter()
    try:
        for k in range(n):
            if speed is not None:
                delay = wall_start + t[k] / speed - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
            pose = rec.poses[k] if np.all(np.isfinite(rec.poses[k])) else np.eye(4)
            twist = loop.cycle(rec.values[k], pose, float(t[k]))
            log.write(k, float(t[k]), loop, twist, pose)
            for watcher in watchers:
                watcher.cycle(k, float(t[k]), loop, log)
            outcome = root_outcome(tree.root)
            if outcome is not None:
                status, reason = outcome
                break
    except BaseException:
        finish_watchers(watchers, None)
        raise
    finally:
        tree.interrupt()
    result = finish_mission(tree, log, loop.contacts, status, reason, wall_start, float(t[log.n - 1]) + dt,
                            scene=rec.metadata.get("scene", ""), seed=rec.metadata.get("seed"),
                            recording=str(recording), warnings=notes)
    if out is not None:
        result.save(out)
    finish_watchers(watchers, result)
    return result


def _table_height(metadata: dict, recording) -> float:
    """The table height a mission recording holds (``table_z_m``, m, world z), NaN when it holds
    none (a recording of the sensor alone, or a scene without a table)."""
    value = metadata.get("table_z_m")
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RecordingError(f"{recording}: metadata table_z_m {value!r} is not a finite height in m")
    return float(value)
