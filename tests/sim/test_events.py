"""Scene events: validation with file, line and field; the schedule; World.update moves the
object at the right time, once, and the pad feels it."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from tactile_bt.perception.features import extract, wrap_half_pi
from tactile_bt.sim.events import EventSchedule, ObjectEvent
from tactile_bt.sim.scene import load_scene
from tactile_bt.errors import SceneError
from tactile_bt.sim.shapes import Box

SCENE = """\
name: events
rate_hz: 250
sensor: {noise_counts: 0, noise_relative: 0, noise_common: 0, calibration_spread: 0}
mount:
  type: cartesian
  position: [0.0, 0.0, 0.0298]
  rpy_deg: [180, 0, 0]
objects:
  - type: box
    size: [0.1, 0.1, 0.06]
    position: [0.0, 0.0, 0.0]
    stiffness: 1e5
  - type: table
    height: -0.03
events:
  - at_s: 0.5
    object: 0
    translate: [0.06, 0.0, 0.0]
  - {at_s: 0.2, object: 1, translate: [0, 0, -0.001]}
"""


def write(tmp_path, text):
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return path


def features(world):
    force, _ = world.sensor.force_image(world.pose, world.objects)
    return force, extract(force)


# --------------------------------------------------------------------------------- schema


def test_events_load_in_file_order(tmp_path):
    scene = load_scene(write(tmp_path, SCENE))
    assert scene.events == [
        ObjectEvent(at_s=0.5, object=0, translate=(0.06, 0.0, 0.0), rotate_deg=(0.0, 0.0, 0.0)),
        ObjectEvent(at_s=0.2, object=1, translate=(0.0, 0.0, -0.001), rotate_deg=(0.0, 0.0, 0.0)),
    ]
    assert load_scene(write(tmp_path, SCENE.split("events:")[0])).events == []


@pytest.mark.parametrize(
    "old,new,line,fragments",
    [
        ("  - at_s: 0.5", "  - at: 0.5", 16, ["'events.0.at'", "did you mean 'at_s'"]),
        ("  - at_s: 0.5", "  - at_s: -0.5", 16, ["events.0.at_s", "non-negative"]),
        ("  - at_s: 0.5", "  - at_s: soon", 16, ["events.0.at_s", "number", "soon"]),
        ("    object: 0", "    object: 2", 17, ["events.0.object", "no object 2", "0 to 1"]),
        ("    object: 0", "    object: -1", 17, ["events.0.object", "no object -1"]),
        ("    object: 0", "    object: box", 17, ["events.0.object", "integer"]),
        ("    translate: [0.06, 0.0, 0.0]", "    translate: [0.06, 0.0]", 18, ["events.0.translate", "list of 3"]),
        ("    translate: [0.06, 0.0, 0.0]", "    rotate_deg: [0, 0, x]", 18, ["events.0.rotate_deg[2]", "number"]),
        ("    translate: [0.06, 0.0, 0.0]\n", "", 16, ["events.0", "'translate' or 'rotate_deg'"]),
        ("    object: 0\n", "", 16, ["events.0.object", "needs 'object'"]),
        ("  - {at_s: 0.2, object: 1, translate: [0, 0, -0.001]}", "  - 0.2", 19, ["events.1", "mapping"]),
    ],
)
def test_event_errors_name_file_line_and_field(tmp_path, old, new, line, fragments):
    assert old in SCENE
    path = write(tmp_path, SCENE.replace(old, new))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:{line}:"), msg
    for fragment in fragments:
        assert fragment in msg, msg


def test_events_must_be_a_list(tmp_path):
    path = write(tmp_path, SCENE.split("events:")[0] + "events: {at_s: 1, object: 0}\n")
    with pytest.raises(SceneError, match=r"scene\.yaml:15:.*events: expected a list"):
        load_scene(path)


@pytest.mark.parametrize(
    "override,fragments",
    [
        ("events.0.at_s=-1", ["events.0.at_s", "non-negative"]),
        ("events.0.object=7", ["events.0.object", "no object 7"]),
        ("events.1.rotate=[0, 0, 90]", ["events.1.rotate", "did you mean 'rotate_deg'"]),
        ("events.2.at_s=1", ["events", "no item '2'"]),
    ],
)
def test_event_overrides_go_through_the_checks(tmp_path, override, fragments):
    with pytest.raises(SceneError) as info:
        load_scene(write(tmp_path, SCENE), [override])
    msg = str(info.value)
    assert "--set" in msg
    for fragment in fragments:
        assert fragment in msg, msg


def test_event_override_changes_the_time(tmp_path):
    scene = load_scene(write(tmp_path, SCENE), ["events.0.at_s=1.25", "events.1.rotate_deg=[0, 0, 5]"])
    assert scene.events[0].at_s == 1.25 and scene.events[1].rotate_deg == (0.0, 0.0, 5.0)


# --------------------------------------------------------------------------------- schedule


def test_schedule_fires_each_event_once_in_time_order():
    a = ObjectEvent(at_s=1.0, object=0, translate=(1, 0, 0))
    b = ObjectEvent(at_s=0.5, object=0, translate=(2, 0, 0))
    c = ObjectEvent(at_s=1.0, object=1, translate=(3, 0, 0))
    schedule = EventSchedule([a, b, c])
    assert schedule.due(0.0) == []
    assert schedule.due(0.4999) == []
    assert schedule.due(0.5) == [b]
    assert schedule.due(0.7) == []
    assert schedule.due(3.0) == [a, c]  # equal times keep their order in the file
    assert schedule.due(5.0) == [] and schedule.pending == []
    # a mission time that is a multiple of the period, with rounding, still fires
    late = EventSchedule([ObjectEvent(at_s=0.3, object=0, translate=(0, 0, 0))])
    assert len(late.due(75 * 0.004)) == 1  # 0.30000000000000004 or 0.29999999999999999


def test_events_must_be_sane():
    with pytest.raises(ValueError):
        ObjectEvent(at_s=-1.0, object=0)
    with pytest.raises(ValueError):
        ObjectEvent(at_s=float("nan"), object=0)


# --------------------------------------------------------------------------------- world


def test_world_update_moves_the_object_at_its_time_and_the_pad_feels_it(tmp_path):
    scene = load_scene(write(tmp_path, SCENE))
    world = scene.build_world(np.random.default_rng(0))
    box_before = world.objects[0]
    force0, f0 = features(world)
    assert f0.area == 256  # the 100 mm box face covers the 80 mm pad
    dt = 1.0 / scene.rate_hz
    fired_at = []
    for k in range(int(round(1.0 / dt))):
        t = k * dt
        fired = world.update(t)
        if fired:
            fired_at.append((round(t, 6), [e.object for e in fired]))
        world.sense()
    assert fired_at == [(0.2, [1]), (0.5, [0])]
    # the box moved 60 mm along +x: its edge now at x = +10 mm, under the pad's right part
    assert_allclose(world.objects[0].pose[:3, 3], [0.06, 0.0, 0.0])
    assert_allclose(world.objects[1].pose[:3, 3], [0.0, 0.0, -0.001])
    force1, f1 = features(world)
    assert f1.in_contact and f1.area < 0.45 * 256
    # sensor x is world x for this pad: the contact is on the high columns now
    assert f1.cop_px[0] > 10.0 and abs(f1.cop_px[1] - 7.5) < 0.5
    assert not force1[:, :7].any() and force0[:, :7].all()
    # the scene's own objects stay where the file puts them; a new world starts afresh
    assert scene.objects[0] is box_before
    assert_allclose(scene.objects[0].pose[:3, 3], [0.0, 0.0, 0.0])
    again = scene.build_world(np.random.default_rng(0))
    assert features(again)[1].area == 256
    assert again.update(0.0) == [] and len(again.update(0.5)) == 2


def test_world_update_without_events_does_nothing(tmp_path):
    scene = load_scene(write(tmp_path, SCENE.split("events:")[0]))
    world = scene.build_world(np.random.default_rng(0))
    objects = list(world.objects)
    assert world.update(10.0) == []
    assert world.objects == objects


def test_a_rotation_event_turns_an_edge_on_the_pad(tmp_path):
    text = SCENE.replace("    size: [0.1, 0.1, 0.06]\n    position: [0.0, 0.0, 0.0]",
                         "    size: [0.3, 0.04, 0.04]\n    position: [0.0, 0.0, 0.00]\n    rpy_deg: [45, 0, 0]")
    text = text.replace("position: [0.0, 0.0, 0.0298]", f"position: [0.0, 0.0, {0.02 * np.sqrt(2) - 1e-3}]")
    text = text.split("events:")[0] + "events:\n  - {at_s: 1.0, object: 0, rotate_deg: [0, 0, 60]}\n"
    scene = load_scene(write(tmp_path, text))
    world = scene.build_world(np.random.default_rng(0))
    before = features(world)[1]
    world.update(1.0)
    after = features(world)[1]
    assert before.in_contact and after.in_contact
    # the edge runs along world x (sensor x) first, then 60° about the vertical: with the pad
    # upside down (sensor y = -world y) that is -60° in the sensor frame
    assert abs(wrap_half_pi(before.orientation)) < np.deg2rad(2)
    assert abs(wrap_half_pi(after.orientation - np.deg2rad(-60))) < np.deg2rad(2)
    assert isinstance(world.objects[0], Box)
    assert_allclose(world.objects[0].pose[:3, :3],
                    Rotation.from_euler("z", 60, degrees=True).as_matrix() @ Rotation.from_euler("x", 45, degrees=True).as_matrix(),
                    atol=1e-12)
