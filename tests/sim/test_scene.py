"""Scene files: sim/cable.yaml, --set overrides, and validation errors with file, line, field."""

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt.sim.objects import Cable, Table
from tactile_bt.sim.scene import load_scene
from tactile_bt.errors import SceneError
from tactile_bt.sim.pad import SensorParams

REPO = Path(__file__).resolve().parents[2]
CABLE_SCENE = REPO / "sim" / "cable.yaml"


@pytest.fixture(scope="module")
def cable_scene():
    return load_scene(CABLE_SCENE)


def write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def turning_and_min_radius(path):
    """Total absolute turning (rad) and the smallest circumradius of consecutive point triples (m)."""
    seg = np.diff(path, axis=0)
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    turning = np.sum(np.abs(np.diff(heading)))
    a, b, c = path[:-2], path[1:-1], path[2:]
    ab, bc, ca = (np.linalg.norm(x, axis=1) for x in (b - a, c - b, a - c))
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])  # 2 × triangle area
    with np.errstate(divide="ignore"):
        radius = np.where(cross > 1e-15, ab * bc * ca / (2.0 * cross), np.inf)
    return turning, radius.min()


# --------------------------------------------------------------------------------- cable.yaml


def test_cable_scene_loads(cable_scene):
    s = cable_scene
    assert s.name == "cable"
    assert s.rate_hz == 250.0 and s.duration_s == 40.0 and s.seed == 0
    assert [type(o) for o in s.objects] == [Table, Cable]
    assert s.cable is s.objects[1]
    assert s.cable.radius == pytest.approx(0.003)
    # the pad's normal (sensor z) points down to the table, its origin above the table
    assert s.mount_pose[2, 2] == pytest.approx(-1.0)
    assert s.mount_pose[2, 3] > 0.0


def test_cable_has_a_real_bend_and_length(cable_scene):
    path = cable_scene.cable.path
    turning, r_min = turning_and_min_radius(path)
    assert np.rad2deg(turning) >= 90.0
    assert r_min >= 0.060
    length = np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))
    assert length > 0.4
    assert cable_scene.cable.length == pytest.approx(length)


def test_cable_scene_builds_a_world(cable_scene):
    world = cable_scene.build_world(np.random.default_rng(0))
    assert_allclose(world.pose, cable_scene.mount_pose, atol=1e-6)  # the arm reaches the start by IK
    frame = world.sense()
    assert frame.dtype == np.uint16 and frame.shape == (16, 16)
    # the pad starts above the objects: nothing touches
    assert world.last_penetration == 0.0 and not world.last_force.any()


# --------------------------------------------------------------------------------- --set overrides


def test_set_changes_the_stiffness(cable_scene):
    s = load_scene(CABLE_SCENE, ["objects.1.stiffness=1e5"])
    assert s.objects[1].stiffness == 1e5
    assert isinstance(s.objects[1].stiffness, float)
    assert s.objects[0].stiffness == cable_scene.objects[0].stiffness
    assert cable_scene.objects[1].stiffness == 1e6  # the file is unchanged


def test_set_several_values_and_lists():
    s = load_scene(CABLE_SCENE, ["seed=7", "mount.position=[0.0, 0.0, 0.02]", "objects.0.height=-1.5e-3"])
    assert s.seed == 7
    assert_allclose(s.mount_pose[:3, 3], [0.0, 0.0, 0.02])
    assert s.objects[0].height == -1.5e-3


@pytest.mark.parametrize(
    "override,fragments",
    [
        ("objects.1.stifness=1e5", ["objects.1.stifness", "did you mean 'stiffness'"]),
        ("objects.5.stiffness=1e5", ["objects.5.stiffness", "'5'"]),
        ("objects.x.stiffness=1e5", ["objects.x.stiffness"]),
        ("objects.1.stiffness", ["objects.1.stiffness", "key.path=value"]),
        ("objects.1.stiffness=soft", ["objects.1.stiffness", "number", "soft"]),
        ("objects.1.stiffness=[1,", ["objects.1.stiffness"]),
        ("durration_s=3", ["durration_s", "did you mean 'duration_s'"]),
        ("seed=1.5", ["seed", "integer"]),
        ("seed.x=1", ["seed"]),
    ],
)
def test_bad_override_names_the_override(override, fragments):
    with pytest.raises(SceneError) as info:
        load_scene(CABLE_SCENE, [override])
    msg = str(info.value)
    assert "--set" in msg
    for fragment in fragments:
        assert fragment in msg


def test_override_with_a_malformed_index_is_a_scene_error():
    with pytest.raises(SceneError, match="--1"):
        load_scene(CABLE_SCENE, ["objects.--1.stiffness=1e5"])


def test_override_negative_index_counts_from_the_end():
    s = load_scene(CABLE_SCENE, ["objects.-1.stiffness=2e5"])
    assert s.objects[-1].stiffness == 2e5


# --------------------------------------------------------------------------------- scene files

SCENE = """\
name: test
rate_hz: 250
objects:
  - type: table
    height: 0.0
    stiffness: 1e5
  - type: cable
    radius: 0.003
    points: [[0.0, 0.0], [0.1, 0.0]]
"""


def test_scientific_floats_parse_as_numbers(tmp_path):
    s = load_scene(write(tmp_path, SCENE))
    assert s.objects[0].stiffness == 1e5 and isinstance(s.objects[0].stiffness, float)
    text = SCENE.replace("    height: 0.0", "    height: -2E-3").replace("stiffness: 1e5", "stiffness: +3e6")
    s = load_scene(write(tmp_path, text))
    assert s.objects[0].height == -2e-3 and s.objects[0].stiffness == 3e6


def test_cable_from_points(tmp_path):
    s = load_scene(write(tmp_path, SCENE))
    assert_allclose(s.cable.path, [[0.0, 0.0], [0.1, 0.0]])
    assert s.cable.length == pytest.approx(0.1)


def test_unknown_object_field_names_file_line_field_and_suggests(tmp_path):
    path = write(tmp_path, SCENE.replace("    height: 0.0", "    hieght: 0.0"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:5:")
    assert "hieght" in msg and "did you mean 'height'" in msg


def test_unknown_top_level_key_suggests(tmp_path):
    path = write(tmp_path, "name: x\nduraton_s: 3\n")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}:2:")
    assert "did you mean 'duration_s'" in str(info.value)


def test_unknown_sensor_field_suggests(tmp_path):
    path = write(tmp_path, "sensor:\n  pitch: 0.005\n  noise_count: 3\n")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}:3:")
    assert "did you mean 'noise_counts'" in str(info.value)


def test_sensor_section_sets_sensor_params(tmp_path):
    s = load_scene(write(tmp_path, "sensor:\n  noise_counts: 0\n  foam_spread: 0.1\n"))
    assert s.sensor == SensorParams(noise_counts=0.0, foam_spread=0.1)


@pytest.mark.parametrize(
    "old,new,line,field",
    [
        ("    stiffness: 1e5", "    stiffness: soft", 6, "objects.0.stiffness"),
        ("rate_hz: 250", "rate_hz: fast", 2, "rate_hz"),
        ("    points: [[0.0, 0.0], [0.1, 0.0]]", "    points: [[0.0, 0.0], [0.1]]", 9, "points[1]"),
        ("    radius: 0.003", "    radius: [0.003]", 8, "objects.1.radius"),
        ("  - type: table", "  - type: tabel", 4, "did you mean 'table'"),
    ],
)
def test_wrong_type_names_file_line_and_field(tmp_path, old, new, line, field):
    assert old in SCENE
    path = write(tmp_path, SCENE.replace(old, new))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:{line}:")
    assert field in msg


def test_bad_path_segment_names_its_index(tmp_path):
    text = "objects:\n  - type: cable\n    path:\n      - straight: 0.05\n      - arc: {radius: 0.1}\n"
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}:5:")
    assert "path[1]" in str(info.value)


def test_cable_without_a_path(tmp_path):
    path = write(tmp_path, "objects:\n  - type: cable\n    radius: 0.003\n")
    with pytest.raises(SceneError, match="path"):
        load_scene(path)


def test_yaml_syntax_error_names_the_line(tmp_path):
    path = write(tmp_path, "name: x\nobjects:\n  - type: table\n   height: 0\n")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}:4")


@pytest.mark.parametrize("override", ["objects.1.stiffness=-1e6", "objects.1.radius=-0.003"])
def test_physically_impossible_values_are_rejected(override):
    with pytest.raises(SceneError, match=override.split("=")[0]):
        load_scene(CABLE_SCENE, [override])


# --------------------------------------------------------------------------------- units


def test_scene_values_take_units_like_tree_values(tmp_path):
    """``radius: 3 mm`` is 0.003 m, in a file and in an override: the parser of tree values."""
    text = (SCENE.replace("    radius: 0.003", "    radius: 3 mm")
            .replace("    stiffness: 1e5", "    stiffness: 100 N/mm"))
    assert text != SCENE
    s = load_scene(write(tmp_path, text))
    assert s.cable.radius == pytest.approx(0.003)
    assert s.objects[0].stiffness == pytest.approx(1e5)
    s = load_scene(CABLE_SCENE, ["objects.1.radius=2.5 mm", "duration_s=1 min"])
    assert s.cable.radius == pytest.approx(0.0025) and s.duration_s == pytest.approx(60.0)


@pytest.mark.parametrize("value,needle", [("3 kPa", "unit 'kPa' does not fit a value in m"),
                                          ("3 px", "unit 'px' does not fit a value in m"),
                                          ("-3 mm", "expected a positive number up to 0.05 m, got '-3 mm'")])
def test_a_scene_value_with_a_wrong_unit_names_file_line_and_field(tmp_path, value, needle):
    path = write(tmp_path, SCENE.replace("    radius: 0.003", f"    radius: {value}"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}:8:") and "objects.1.radius" in str(info.value)
    assert needle in str(info.value)
