"""Closed-loop missions on the simulator: cable following, outputs, determinism, lean imports."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import py_trees
import pytest
from numpy.testing import assert_array_equal

from tactile_bt import load_tree, run_mission
from tactile_bt.tree.behaviours import Approach, ForceHold, TactileBehaviour
from tactile_bt.contacts.ply import read_ply_points

ROOT = Path(__file__).resolve().parents[2]
CABLE_TREE = ROOT / "trees" / "cable_follow.yaml"
CABLE_SCENE = ROOT / "sim" / "cable.yaml"


@pytest.fixture(scope="module")
def cable_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("cable")
    result = run_mission(CABLE_TREE, CABLE_SCENE, duration=5.0, seed=0, out=out)
    return result, out


def test_cable_mission_tracks_the_cable_at_the_target_pressure(cable_run):
    result, _ = cable_run
    r = result.report
    assert r["status"] == "completed"
    log = result.log
    t = log["t"]
    # The approach ends within the first second and contact is never lost afterwards.
    started = np.flatnonzero(np.isfinite(log["error_pressure_pa"]))
    assert t[started[0]] < 1.0
    assert np.all(log["in_contact"][started[0]:] == 1)
    # Pressure settles at 2 kPa: the last two seconds stay within 5 % on average.
    late = t > 3.0
    assert abs(np.mean(log["pressure_pa"][late]) - 2000.0) < 100.0
    # The pad turns to the cable (20° off at the start) and keeps it centred.
    assert np.max(np.abs(log["error_orientation_rad"][late])) < np.deg2rad(5.0)
    assert np.max(np.abs(log["error_cop_x_px"][late])) < 0.5
    # Contacts lie on the true cable.
    assert r["contacts"] > 500
    assert r["path_error_m"]["max"] < 0.002
    assert r["path_error_m"]["followed_m"] > 0.07


def test_report_and_files(cable_run):
    result, out = cable_run
    report = json.loads((out / "report.json").read_text())
    for key in ("tree", "scene", "seed", "status", "sim_time_s", "wall_time_s", "real_time_factor", "ticks"):
        assert key in report
    for feature in ("pressure_pa", "cop_x_px", "cop_y_px", "orientation_rad"):
        assert set(report["metrics"][feature]) >= {"steady_state_error", "std", "response_time_s"}
    assert set(report["path_error_m"]) >= {"mean", "max"}
    assert report["ticks"] == 5 * 250
    log = np.load(out / "log.npz")
    assert len(log["t"]) == report["ticks"]
    per_node = {"node_names", "node_depth"}  # one entry per node of the tree
    assert all(len(log[k]) == len(log["t"]) for k in log.files if k not in per_node)
    assert log["node_status"].shape == (len(log["t"]), len(log["node_names"]))
    names, points = read_ply_points(out / "contacts.ply")
    assert names[:6] == ["x", "y", "z", "nx", "ny", "nz"]
    assert len(points) == report["contacts"]
    # The pad presses down on the table: outward normals of the touched surface point up.
    assert np.all(points[:, 5] > 0.99)
    assert (out / "errors.png").stat().st_size > 20_000


def test_same_seed_same_run_bit_for_bit():
    a = run_mission(CABLE_TREE, CABLE_SCENE, duration=1.0, seed=3)
    b = run_mission(CABLE_TREE, CABLE_SCENE, duration=1.0, seed=3)
    c = run_mission(CABLE_TREE, CABLE_SCENE, duration=1.0, seed=4)
    for key in ("pressure_raw_pa", "position_m", "twist_s"):
        assert_array_equal(a.log[key], b.log[key])
    assert not np.array_equal(a.log["pressure_raw_pa"], c.log["pressure_raw_pa"], equal_nan=True)


FORCE_ONLY = """
root:
  sequence:
    children:
      - approach: {}
      - force_hold: {}
"""


def test_orientation_is_computed_only_while_a_leaf_uses_it(tmp_path):
    tree = load_tree("force_only.yaml", text=FORCE_ONLY)
    result = run_mission(tree, CABLE_SCENE, duration=1.5)
    assert result.report["metrics"].keys() == {"pressure_pa"}
    assert np.all(np.isnan(result.log["orientation_raw_rad"]))
    follow = run_mission(CABLE_TREE, CABLE_SCENE, duration=1.5)
    started = np.isfinite(follow.log["error_orientation_rad"])
    assert np.isnan(follow.log["orientation_raw_rad"][~started][:-1]).all()  # approach: not computed
    assert np.isfinite(follow.log["orientation_raw_rad"][started][2:]).all()


def test_the_cable_mission_does_not_import_rendering_or_meshes():
    code = (
        "import sys; from tactile_bt import run_mission;"
        f"run_mission({str(CABLE_TREE)!r}, {str(CABLE_SCENE)!r}, duration=0.5);"
        "print(sorted(m for m in ('pyvista', 'vtk', 'vtkmodules', 'trimesh') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


class Explode(TactileBehaviour):
    """Raises after ``at_s`` seconds of mission time."""

    def __init__(self, at_s: float) -> None:
        super().__init__("explode")
        self.at_s = at_s

    def update(self):
        if self.now >= self.at_s:
            self.crashed_at = self.now
            raise RuntimeError("boom")
        return py_trees.common.Status.RUNNING


def test_a_crash_mid_mission_keeps_every_cycle_up_to_it(tmp_path):
    root = py_trees.composites.Parallel("p", policy=py_trees.common.ParallelPolicy.SuccessOnAll(),
                                        children=[ForceHold(), Explode(at_s=0.5)])
    tree = py_trees.trees.BehaviourTree(py_trees.composites.Sequence("s", memory=True, children=[Approach(), root]))
    explode = root.children[1]
    with pytest.raises(RuntimeError, match="boom"):
        run_mission(tree, CABLE_SCENE, duration=2.0, out=tmp_path)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["status"] == "error" and "boom" in report["reason"]
    log = np.load(tmp_path / "log.npz")
    # Every cycle before the one that crashed is in the log.
    assert log["t"][-1] == pytest.approx(explode.crashed_at - 0.004)
    assert len(log["t"]) == round(explode.crashed_at / 0.004)
    assert np.all(np.isfinite(log["position_m"]))


TIMED = """
root:
  sequence:
    children:
      - approach: {}
      - mission_timeout:
          duration_s: 0.5
          child: {force_hold: {}}
"""


def test_a_failed_mission_says_which_node_failed_and_why():
    result = run_mission(load_tree("timed.yaml", text=TIMED), CABLE_SCENE, duration=3.0)
    assert result.report["status"] == "failure"
    assert result.report["reason"].startswith("mission_timeout: timed out after 0.5 s")
    assert result.report["sim_time_s"] < 1.5


def test_roll_brings_a_displaced_contact_back_by_rotating_while_holding_the_force():
    """Paper Sec. V-B / Fig. 11: the ball is pushed at 4 s; the pad rolls back the other way."""
    from scipy.spatial.transform import Rotation

    result = run_mission(ROOT / "trees" / "roll.yaml", ROOT / "sim" / "roll_ball.yaml", duration=6.0, seed=0)
    log = result.log
    t = log["t"]
    R0 = log["rotation"][0]
    roll_x = Rotation.from_matrix(np.einsum("ji,njk->nik", R0, log["rotation"])).as_rotvec(degrees=True)[:, 0]
    before, after = roll_x[np.searchsorted(t, 3.9)], roll_x[-1]
    assert before < -2.0  # the initial offset was removed by rolling about x ...
    assert after - before > 1.5  # ... and the displacement by rolling back the other way
    late = t > 5.0
    assert np.max(np.abs(log["error_cop_y_px"][late])) < 0.25  # the COP is back at the centre
    held = t > 1.0
    assert np.max(np.abs(log["error_pressure_pa"][held])) < 0.25 * 2000.0  # force stays controlled
