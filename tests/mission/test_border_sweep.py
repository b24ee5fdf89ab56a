"""A level pad sweeps the foot of a pyramid's face with its border, in the simulator: the band a
pad lying on the face leaves above the table is touched, no deeper than a flat contact presses,
and the pad goes back to where it came from."""

import math
from pathlib import Path

import numpy as np
import py_trees
from py_trees.common import Status

from tactile_bt import run_mission
from tactile_bt.contacts.sweep_plan import foot_runs
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.sim.scene import load_scene
from tactile_bt.tree.behaviours import BorderSweep
from tactile_bt.tree.behaviours.reapproach import REAPPROACH_KEY
from tactile_bt.tree.behaviours.table import pad_clearance

ROOT = Path(__file__).resolve().parents[2]
SLOPE = math.radians(40)
YAW = math.radians(25)  # sim/scan_pyramid.yaml: 160 mm base, faces at 40°, turned 25°
HALF = 0.08


class _Ask(py_trees.behaviour.Behaviour):
    """Writes the sweep job, as frontier_guidance does, and succeeds."""

    def __init__(self, job):
        super().__init__("ask")
        self.job = job
        self.bb = self.attach_blackboard_client("ask")
        self.bb.register_key(REAPPROACH_KEY, access=py_trees.common.Access.WRITE)

    def update(self):
        self.bb.set(REAPPROACH_KEY, self.job)
        return Status.SUCCESS


def _face_job(k):
    """A sweep of face ``k`` (0–3) of the pyramid, from frontier cells 4–14 mm up it."""
    yaw = YAW + k * math.pi / 2
    out = np.array([math.cos(yaw), math.sin(yaw)])
    along = np.array([-out[1], out[0]])
    z = np.linspace(0.004, 0.014, 30)
    s = np.linspace(-0.05, 0.05, 30)
    xy = out * (HALF - z[:, None] / math.tan(SLOPE)) + along * s[:, None]
    n = np.tile([out[0] * math.sin(SLOPE), out[1] * math.sin(SLOPE), math.cos(SLOPE)], (30, 1))
    (run,) = foot_runs(xy, z, n, foot_z=0.002)
    return {"sweep": run, "foot_z": 0.002, "top_z": 0.067,
            "home": (np.array([0.0, 0.0, 0.0671]), np.array([0.0, 0.0, 1.0]))}, out, n[0]


def test_the_level_pad_touches_the_face_low_along_its_foot_and_goes_home():
    job, out, normal = _face_job(2)  # the face away from the arm
    sweep = BorderSweep()
    root = py_trees.composites.Sequence("sweep_the_foot", memory=True, children=[_Ask(job), sweep])
    scene = load_scene(ROOT / "sim" / "scan_pyramid.yaml")
    result = run_mission(py_trees.trees.BehaviourTree(root), scene, duration=60.0)
    assert result.summary.status == "success", result.summary.reason
    assert job["result"] == "swept"
    points = result.contact_data[:, :3]
    assert len(points) > 100
    # every sample low on the face (the pad settles to 2 mm within its first second), on the
    # face's plane within what a flat contact presses
    assert np.all((points[:, 2] > 0.0015) & (points[:, 2] < 0.003))
    assert np.median(points[:, 2]) < 0.0021
    foot = np.array([*(out * HALF), 0.0])
    off_plane = (points - foot) @ normal
    assert np.all(np.abs(off_plane) < 0.0015)
    # along the foot they cover the run: 100 mm of the frontier's 100 mm
    s = points[:, :2] @ np.array([-out[1], out[0]])
    assert s.max() - s.min() > 0.09
    # never below the table guard's limit, never pressed above twice the sweep's target
    log = result.log
    pad = PadGeometry()
    poses = np.zeros((len(log["t"]), 4, 4))
    poses[:, :3, :3], poses[:, :3, 3], poses[:, 3, 3] = log["rotation"], log["position_m"], 1.0
    assert min(pad_clearance(T, pad, 0.0) for T in poses[::25]) > 0.0015
    assert np.max(log["pressure_pa"]) < 2 * sweep.sweep_pressure_pa
