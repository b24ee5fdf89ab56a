"""A flat pad resting on the two rims of a groove narrower than its diagonal: rolled towards
whichever rim bears more, it rocks from one to the other, pressing each narrow contact in turn.
``roll_to`` can hold the tilt while that lasts (closed loop, simulated arm). The scan tree holds
it once the supervisor has pulled the pad back (``tests/mission/test_scan_object.py``); here,
``rocking_pulled_back_s: .inf``, whenever the pad rocks."""

import numpy as np
import pytest

from tactile_bt import load_tree, run_mission
from tactile_bt.sim.scene import load_scene

TARGET_PA = 2000.0

SCENE = """
name: bridge_groove
description: a flat pad lowered over a groove 90 mm wide, turned 45° to it, so that it bridges it on two corners
rate_hz: 250
duration_s: 6
seed: 0
mount:
  type: lwr4
  position: [0.0, 0.0, 0.043]
  rpy_deg: [180, 0, 180]
  base: [-0.392, 0.0, 0.171]
objects:
  - {type: grooved_block, size: [0.14, 0.16, 0.04], groove_width: 0.09, groove_depth: 0.008, position: [0, 0, 0.02],
     rpy_deg: [0, 0, 45], stiffness: 1.0e5, friction: 0.5}
  - {type: table, height: 0.0, stiffness: 1.0e6}
"""

TREE = f"""
name: hold_over_groove
root:
  sequence:
    name: hold_over_groove
    children:
      - approach: {{pressure_pa: 800, timeout_s: 5}}
      - parallel:
          name: hold
          policy: success_on_one
          children:
            - force_hold: {{target_pa: {TARGET_PA}, kp: 3.0e-5}}
            - roll_to: {{target_key: /scan/cop_target, kp: 6.0, output_limit: 60 mm/s}}
"""


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Roll rates (rad/s) and smoothed pressures (Pa) from 2 s on, with the tilt held while the
    pad rocks (``rocking_hold_s: 0.3``) and without (``0``, the default)."""
    folder = tmp_path_factory.mktemp("rocking")
    (folder / "scene.yaml").write_text(SCENE)
    (folder / "tree.yaml").write_text(TREE)
    scene = load_scene(folder / "scene.yaml")
    out = {}
    for hold in ("0.3", "0"):
        params = [f"roll_to.rocking_hold_s={hold}", "roll_to.rocking_pulled_back_s=.inf"]
        tree = load_tree(folder / "tree.yaml", params=params, pad=scene.sensor.geometry)
        log = run_mission(tree, scene, duration=6.0).log
        late = log["t"] > 2.0
        assert log["in_contact"][late].all()
        out[hold] = (np.linalg.norm(log["twist_s"][late, 3:5], axis=1), log["pressure_pa"][late])
    return out


def test_the_pad_on_two_rims_stops_rocking(runs):
    held, rocking = runs["0.3"][0], runs["0"][0]
    assert np.mean(rocking) > 0.03                   # without the hold, it keeps rolling to and fro
    assert np.mean(held) < 0.4 * np.mean(rocking)


def test_the_rims_pressure_stays_near_its_target_while_the_tilt_is_held(runs):
    held, rocking = runs["0.3"][1], runs["0"][1]
    assert np.max(held) < 1.25 * TARGET_PA < np.max(rocking)
    assert abs(np.mean(held) - TARGET_PA) < 0.1 * TARGET_PA
