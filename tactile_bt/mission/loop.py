"""One control cycle without the robot, shared by missions, replays and the bench.

sense → calibrate → extract → smooth → blackboard → tree tick → summed sensor-frame twist
(docs/architecture.md); the caller applies the twist through ``Ad(T_gs)`` to its mount, or to nothing.

Layer: mission.
"""

from __future__ import annotations

import time

import numpy as np
import py_trees
from py_trees.common import Status

from tactile_bt import defaults
from tactile_bt.contacts.cloud import ContactCloud
from tactile_bt.control.servo import ServoCommand
from tactile_bt.mission.node_status import tree_nodes
from tactile_bt.perception.features import extract
from tactile_bt.perception.smoothing import FeatureSmoother
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.tree.behaviours import TactileBehaviour
from tactile_bt.tree.blackboard import cycle_writer, write_cycle
from tactile_bt.tree.ticking import debug_logging, tick_node

__all__ = ["ControlLoop", "tick", "root_outcome", "failure_reason", "success_reason"]


class ControlLoop:
    """One control cycle of docs/architecture.md, without the robot: raw frame → sensor-frame twist.

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
    pad : PadGeometry, optional
        The pad the frames come from: feature extraction converts with it and the leaves find
        it on the blackboard (``/tactile/pad``). Default: the paper's 5 mm pitch, the
        calibration's shape. Its shape must be the calibration's (ValueError otherwise).
    """

    def __init__(self, tree, calibration, dt: float, orientation_method: str = "moments",
                 threshold: float = defaults.CONTACT_THRESHOLD_N, profile: bool = False,
                 pad: PadGeometry | None = None) -> None:
        self.tree = tree
        shape = tuple(calibration.shape)
        self.pad = PadGeometry(*shape) if pad is None else pad
        if self.pad.shape != shape:
            raise ValueError(f"the calibration covers {shape[0]}x{shape[1]} tactels, the pad "
                             f"{self.pad.rows}x{self.pad.cols}")
        self.calibration = calibration
        self.dt = float(dt)
        self.orientation_method = orientation_method
        self.threshold = float(threshold)
        self.command = ServoCommand(defaults.TWIST_LINEAR_LIMIT_MPS, defaults.TWIST_ANGULAR_LIMIT_RPS)
        self.contacts = ContactCloud()
        self.smoother = FeatureSmoother(defaults.SMOOTHING_SAMPLES)
        self.writer = cycle_writer("mission", self.command, self.contacts, self.dt, pad=self.pad)
        tree.setup()
        leaves = [b for b in tree.root.iterate() if isinstance(b, TactileBehaviour)]
        self._orientation_leaves = tuple(b for b in leaves if "orientation" in b.uses)
        #: Leaves that choose the contact region extraction keeps (``region_hint``, e.g. the
        #: followed line of ``cable_end``); without a running one, the largest region.
        self._region_leaves = tuple(b for b in leaves if callable(getattr(b, "region_hint", None)))
        #: The last cycle's force image (N per tactel), raw and smoothed features, for watchers.
        self.image = None
        self.features_raw = None
        self.features = None
        #: With ``profile=True``: accumulated seconds in perception (calibrate, extract,
        #: smooth) and in the tree tick plus controller, over ``stage_cycles`` cycles.
        self.stage_times = [0.0, 0.0] if profile else None
        self.stage_cycles = 0

    def cycle(self, raw: np.ndarray, pose: np.ndarray, t: float) -> np.ndarray:
        """Run one cycle on a raw frame taken at mission time ``t`` (s) with the pad at ``pose``
        (``T_gs``); returns the sensor-frame twist ``V_s`` to apply."""
        clock = time.perf_counter if self.stage_times is not None else None
        if clock:
            t0 = clock()
        image = self.calibration.force_from_raw(raw)
        # Orientation only when a running leaf uses it (a leaf starting this tick sees NaN once).
        method = None
        for b in self._orientation_leaves:
            if b.status == Status.RUNNING:
                method = self.orientation_method
                break
        near = window = None
        for b in self._region_leaves:
            if b.status == Status.RUNNING:
                near, window = b.region_hint()
                break
        f_raw = extract(image, self.threshold, method, pad=self.pad, near_px=near, window_px=window)
        f = self.smoother(f_raw)
        if clock:
            t1 = clock()
        write_cycle(t, pose, f_raw, f)  # the keys ``writer`` registered, through the adapter's fast path
        self.image, self.features_raw, self.features = image, f_raw, f
        command = self.command
        command.clear()
        tick(self.tree)
        twist = command.twist()
        if clock:
            self.stage_times[0] += t1 - t0
            self.stage_times[1] += clock() - t1
            self.stage_cycles += 1
        return twist


def tick(tree: py_trees.trees.BehaviourTree) -> None:
    """``tree.tick()``; without visitors or tick handlers, the root's tick alone (``tick()`` walks
    the whole tree once more per tick to show it to its visitors, even when it has none), and
    with py_trees' debug log off a direct one (:mod:`tactile_bt.tree.ticking`)."""
    if tree.visitors or tree.pre_tick_handlers or tree.post_tick_handlers:
        tree.tick()
        return
    if debug_logging():
        for _ in tree.root.tick():
            pass
    else:
        tick_node(tree.root)
    tree.count += 1


def failure_reason(root: py_trees.behaviour.Behaviour) -> str:
    """Name and message of the deepest failed node that says why (a leaf, or a decorator such
    as a timed-out mission_timeout whose child was merely stopped)."""
    failed = [b for b in root.iterate() if b.status == Status.FAILURE and b.feedback_message]
    if failed:
        node = failed[0]  # iterate() yields children before their parents
        return f"{node.name}: {node.feedback_message}"
    return root.feedback_message


def success_reason(root: py_trees.behaviour.Behaviour) -> str:
    """Name and message of the deepest succeeded node that ends a task and says why: a node
    whose class sets ``reports_success = True`` (e.g. ``frontier_guidance``: "no reachable
    frontier left", ``coverage_stalled``); "" when none did."""
    for node in root.iterate():  # children before their parents
        if node.status == Status.SUCCESS and getattr(node, "reports_success", False) and node.feedback_message:
            return f"{node.name}: {node.feedback_message}"
    return ""


def running_reason(root: py_trees.behaviour.Behaviour, duration_s: float) -> str:
    """Why a mission whose time ran out had not ended, for a tree that ends its task by itself
    (one of its nodes ``reports_success``, :func:`success_reason`): its duration and what the
    deepest running node that says anything was doing (``"600 s of mission time ran out while
    frontier_guidance was running: sliding to the frontier"``), and what each task had achieved
    so far (its ``standing()``, e.g. the scan's estimated coverage). "" for a tree that runs for
    the mission's time (a servo experiment): running out of it is its end."""
    nodes = tree_nodes(root)
    tasks = [node for node, _, _ in nodes if getattr(node, "reports_success", False)]
    if not tasks:
        return ""
    # what each task had achieved (the scan's estimate, ...), whatever step was running
    so_far = "".join(f"; {said}" for said in (getattr(node, "standing", lambda: "")() for node in tasks) if said)
    running = [(depth, node) for node, _, depth in nodes if node.status == Status.RUNNING and node.feedback_message]
    if not running:
        return f"{duration_s:g} s of mission time ran out{so_far}"
    # the first of the deepest: the task's own step, not a guard beside it
    _, node = max(running, key=lambda entry: entry[0])
    return f"{duration_s:g} s of mission time ran out while {node.name} was running: {node.feedback_message}{so_far}"


def root_outcome(root: py_trees.behaviour.Behaviour) -> tuple[str, str] | None:
    """``(status, reason)`` once the tree's root has ended (``success`` with the reason of
    :func:`success_reason`, ``failure`` with that of :func:`failure_reason`), else None: the one
    stop rule of missions and replays."""
    if root.status == Status.SUCCESS:
        return "success", success_reason(root)
    if root.status == Status.FAILURE:
        return "failure", failure_reason(root)
    return None
