"""Border sweeps in the simulator: a level pad sweeps the foot of a pyramid's face up to the
frontier left above it, and a tilted pad the side of a groove it bridges, with its border row:
the surface a flat pad cannot lie on is touched, no deeper than a flat contact presses, and the
pad goes back to where it came from."""

import math
from pathlib import Path

import numpy as np
import py_trees
from py_trees.common import Status

from tactile_bt import run_mission
from scipy.spatial import cKDTree

from tactile_bt.contacts.frontier_map import FrontierMap
from tactile_bt.contacts.sweep_plan import foot_runs, valley_sides
from tactile_bt.mission import accuracy as A
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


def test_the_level_pad_sweeps_the_band_below_the_frontier_in_passes_up_the_face_and_goes_home():
    job, out, normal = _face_job(2)  # the face away from the arm; its frontier 4–14 mm up
    sweep = BorderSweep()
    root = py_trees.composites.Sequence("sweep_the_foot", memory=True, children=[_Ask(job), sweep])
    scene = load_scene(ROOT / "sim" / "scan_pyramid.yaml")
    result = run_mission(py_trees.trees.BehaviourTree(root), scene, duration=90.0)
    assert result.summary.status == "success", result.summary.reason
    assert job["result"] == "swept"
    points = result.contact_data[:, :3]
    assert len(points) > 500
    # from the first pass 2 mm above the table (the pad settles there within its first second)
    # up to the frontier's height, never higher
    assert np.all((points[:, 2] > 0.0015) & (points[:, 2] < job["sweep"]["band_top_z"]))
    assert np.min(points[:, 2]) < 0.0021
    # on the face's plane: never pressed in deeper than a flat contact presses, and outside it
    # by no more than the border row's tactels lie inside the pad's edge
    foot = np.array([*(out * HALF), 0.0])
    off_plane = (points - foot) @ normal
    assert np.all((off_plane > -0.001) & (off_plane < 0.002))
    # the band between the first pass and the frontier is touched along the run (within the
    # coverage radius), so the surface the pad lying on the face left there is scanned
    along = np.array([-out[1], out[0]])
    heights, s = np.meshgrid(np.linspace(0.0025, 0.012, 12), np.linspace(-0.04, 0.04, 17))
    band = foot + np.column_stack((-out * (heights.ravel() / math.tan(SLOPE))[:, None]
                                   + along * s.ravel()[:, None], heights.ravel()))
    distance, _ = cKDTree(points).query(band)
    assert np.all(distance < 0.002)
    # never below the table guard's limit, never pressed above twice the sweep's target
    log = result.log
    pad = PadGeometry()
    poses = np.zeros((len(log["t"]), 4, 4))
    poses[:, :3, :3], poses[:, :3, 3], poses[:, 3, 3] = log["rotation"], log["position_m"], 1.0
    assert min(pad_clearance(T, pad, 0.0) for T in poses[::25]) > 0.0015
    assert np.max(log["pressure_pa"]) < 2 * sweep.sweep_pressure_pa
    # going home, it moves back along the foot to the run's middle before it rises: a sweep that
    # ended out by a corner may be where the arm cannot rise that high
    last = int(np.searchsorted(log["t"], result.contact_data[:, 7].max()))  # the border's last sample
    rising = last + np.flatnonzero(log["position_m"][last:, 2] > 0.03)[0]
    assert abs(float((log["position_m"][rising, :2] - job["sweep"]["centre"]) @ along)) < 0.005


def _groove_map(scene):
    """A frontier map of the grooved block's top touched everywhere but a strip 20–40 mm up one
    side of the groove (its local +x), 110 mm long; and the strip's true points."""
    _, obj = A.scan_object(scene, None)
    points, normals, _ = A.sample_surface(A.true_surface(obj), 0.001)
    top = normals[:, 2] > 0.5
    points, normals = points[top], normals[top]
    local = (points - obj.pose[:3, 3]) @ obj.pose[:3, :3]
    strip = (local[:, 0] > 0.02) & (local[:, 0] < 0.04) & (np.abs(local[:, 1]) < 0.055)
    m = FrontierMap(points[0, :2], 0.002, 0.3)
    m.add(points[~strip], normals[~strip])
    return m, points[strip], obj


def test_a_tilted_pad_sweeps_the_side_of_a_groove_it_bridges_with_its_border():
    scene = load_scene(ROOT / "sim" / "scan_groove.yaml")
    m, strip, obj = _groove_map(scene)
    sides = valley_sides(m, m.valleys(0.08))
    assert len(sides) == 2  # the strip's two long sides
    plus_x = obj.pose[:3, 0][:2]
    side = max(sides, key=lambda s: s["out"] @ plus_x)  # from the rim side, the pad's body over it
    job = {"sweep": side, "foot_z": 0.002, "top_z": float(np.nanmax(m.z_max)),
           "home": (np.array([0.0, 0.0, 0.0401]), np.array([0.0, 0.0, 1.0]))}
    sweep = BorderSweep()
    root = py_trees.composites.Sequence("sweep_the_side", memory=True, children=[_Ask(job), sweep])
    result = run_mission(py_trees.trees.BehaviourTree(root), scene, duration=90.0)
    assert result.summary.status == "success", result.summary.reason
    assert job["result"] == "swept"
    samples = result.contact_data[:, :3]
    # on the surface: within what the border's pressure presses the foam and the rubber
    true_points, true_normals, _ = A.sample_surface(A.true_surface(obj), 0.0008)
    distance, _ = A.surface_distance(samples, true_points, true_normals, 0.0008)
    assert np.percentile(distance, 99) < 0.001
    # and they cover the half of the strip on this side, up to its middle, that the flat pad could
    # not reach (the sweep from the other side covers the rest)
    local_x = (strip - obj.pose[:3, 3]) @ obj.pose[:3, 0]
    near, _ = cKDTree(samples).query(strip[local_x > 0.03])
    assert np.mean(near <= 0.002) > 0.9
    assert np.max(result.log["pressure_pa"]) < 2 * sweep.sweep_pressure_pa


def test_a_scan_tree_with_contact_bridged_on_the_groove_marks_the_hollow_it_bridges_and_never_presses_hard():
    # the scan tree with contact_bridged beside the planner's other ends and the common centre
    # of pressure servoed while the pad bridges; the pad starts over the middle of the shipped
    # groove, which it bridges from its first touch. Within 20 s the tree ends attempts as
    # bridging, the map marks the strip between the rims as a hollow (a valley), and the pad
    # settles across the rims: no supervisor retreat
    from tactile_bt import load_tree

    text = (ROOT / "trees/scan_object.yaml").read_text()
    stalled = "                                      - contact_stalled:"
    assert stalled in text
    text = text.replace(stalled, "                                      - contact_bridged: {window_s: 0.5, "
                                 "end_key: /scan/attempt_end}\n" + stalled, 1)
    text = text.replace("kp: 1.0}", "kp: 1.0, all_regions: true}", 1)
    text = text.replace("output_limit: 60 mm/s}", "output_limit: 60 mm/s, all_regions: true}", 1)
    assert text.count("all_regions: true") == 2
    scene = load_scene(ROOT / "sim/scan_groove.yaml")
    tree = load_tree(str(ROOT / "trees/scan_bridged.yaml"), text=text, pad=scene.sensor.geometry)
    planner = next(n for n in tree.root.iterate() if n.name == "frontier_guidance")
    result = run_mission(tree, scene, duration=20.0, seed=0)
    assert planner.ends["bridge"] >= 1
    assert planner.map.hollow.any()
    assert np.any(planner.map.valleys(min(scene.sensor.geometry.size_m)) & planner.map.hollow)
    assert result.summary.supervisor["interventions"] == 0
    touching = result.log["in_contact"].astype(bool) & (result.log["t"] > 2.0)
    assert np.max(result.log["pressure_pa"][touching]) < 4000.0
