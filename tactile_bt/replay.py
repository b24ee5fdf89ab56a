"""Feed a recording back through perception and a tree: the same control loop as a mission, on
recorded frames and poses instead of a simulator or a live sensor.

A recording made by ``run_mission(..., record=FILE)`` or ``tactile-bt sensor record`` replays
deterministically: the same recording and tree give the same features and twists, at any speed.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import py_trees
from py_trees.common import Status

from tactile_bt import defaults
from tactile_bt.calibration import TactelCalibration

__all__ = ["replay_mission"]


def replay_mission(tree, recording: str | Path, calibration: TactelCalibration | str | Path | None = None,
                   speed: float | None = None, orientation_method: str = "moments", out: str | Path | None = None):
    """Run ``tree`` on the frames of ``recording``; returns a :class:`~tactile_bt.mission.MissionResult`.

    Parameters
    ----------
    tree : BehaviourTree or path to a YAML tree
    recording : path
        A chunked recording (:mod:`tactile_bt.hardware.recording`).
    calibration : TactelCalibration or path, optional
        Raw counts → newtons. Default: ``<recording>.calibration.npz`` when it exists (written by
        mission recordings), else the nominal characteristic.
    speed : float, optional
        ``None`` as fast as possible, ``1.0`` at the recorded pace, ``2.0`` twice as fast.
        The results do not depend on it.
    """
    from tactile_bt.hardware.recording import read_recording
    from tactile_bt.loader import load_tree
    from tactile_bt.mission import ControlLoop, MissionLog, MissionResult, calibration_path
    from tactile_bt.metrics import controlled_feature_metrics

    if not isinstance(tree, py_trees.trees.BehaviourTree):
        tree = load_tree(tree)
    rec = read_recording(recording)
    n = len(rec.timestamps)
    if n == 0:
        raise ValueError(f"{recording}: the recording holds no complete chunk")
    if calibration is None:
        side = calibration_path(recording)
        calibration = TactelCalibration.load(side) if side.exists() else TactelCalibration.nominal(*rec.values.shape[1:])
    elif not isinstance(calibration, TactelCalibration):
        calibration = TactelCalibration.load(calibration)
    t = rec.timestamps - rec.timestamps[0]
    if "rate_hz" in rec.metadata:  # a mission recording: its exact control period
        dt = 1.0 / float(rec.metadata["rate_hz"])
    else:
        dt = float(np.median(np.diff(t))) if n > 1 else 1.0 / defaults.RATE_HZ
    loop = ControlLoop(tree, calibration, dt, orientation_method)
    log = MissionLog(n)
    status, wall_start = "completed", time.perf_counter()
    try:
        for k in range(n):
            if speed is not None:
                delay = wall_start + t[k] / speed - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
            pose = rec.poses[k] if np.all(np.isfinite(rec.poses[k])) else np.eye(4)
            twist = loop.cycle(rec.values[k], pose, float(t[k]))
            log.record(k, float(t[k]), loop, twist, pose)
            if tree.root.status in (Status.SUCCESS, Status.FAILURE):
                status = tree.root.status.value.lower()
                break
    finally:
        tree.interrupt()
    wall = time.perf_counter() - wall_start
    arrays = log.arrays()
    metrics = controlled_feature_metrics(arrays)
    report = {
        "tree": getattr(tree, "source", tree.root.name),
        "recording": str(recording),
        "scene": rec.metadata.get("scene", ""),
        "seed": rec.metadata.get("seed"),
        "status": status,
        "reason": "",
        "sim_time_s": float(t[log.n - 1]) + dt,
        "wall_time_s": wall,
        "real_time_factor": (float(t[log.n - 1]) + dt) / wall if wall > 0 else float("inf"),
        "ticks": log.n,
        "metrics": metrics,
        "contacts": len(loop.contacts),
    }
    result = MissionResult(report=report, log=arrays, contact_data=loop.contacts.data.copy())
    if out is not None:
        result.save(out)
    return result
