"""The objects docs/unseen_scans.py builds are valid scenes: each loads, lies on the table and has
the pad start just above its top, as the shipped scan scenes do."""


import pytest

from tactile_bt.sim.scene import load_scene
from docs_scripts import load_docs_script

UNSEEN = load_docs_script("unseen_scans")


@pytest.mark.parametrize("name", sorted(UNSEEN.OBJECTS))
def test_each_unseen_object_is_a_scene_with_the_pad_just_above_its_top(name, tmp_path):
    scene = load_scene(UNSEEN.write_scene(name, tmp_path))
    assert scene.name == f"unseen_{name}"
    assert scene.data["scan_region"]["max_angle_deg"] in (10, 60)
    objects = [obj for obj in scene.objects if obj is not scene.table]
    assert len(objects) == 1 and scene.table is not None and scene.table.height == 0.0
    bottom, top = objects[0].bounds()[0][2], objects[0].bounds()[1][2]
    assert bottom == pytest.approx(0.0, abs=1e-3)  # lying on the table
    assert 0.002 <= scene.mount.position[2] - top <= 0.004  # the pad 3 mm above its top
