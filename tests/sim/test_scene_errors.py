"""Bad scenes: every numeric field is checked (finite, sign, bounds), the start pose is reachable
and the pad does not start inside an object; each error names the file, line and field, and the
command line turns it into one ``error:`` line."""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt.cli import main
from tactile_bt.robot.mounts import MountSpec
from tactile_bt.sim.objects import Cable
from tactile_bt.sim.scene import MAX_START_DEPTH_M, SENSOR, Scene, check_seed, load_scene
from tactile_bt.errors import SceneError
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt import shipped
from tactile_bt.experiments.stability import extreme_cases, stiffness_cases

ROOT = shipped.root()

SIM = ROOT / "sim"
PEN = (SIM / "pen.yaml").read_text()
CABLE = (SIM / "cable.yaml").read_text()
TREE = str(ROOT / "trees" / "force_hold.yaml")
SENSOR_SECTION = """sensor:
  rows: 16
  cols: 16
  pitch: 0.005
  subsamples: 3
  foam_stiffness: 2.0e7
  foam_spread: 0.7
  calibration_spread: 0.15
  noise_counts: 5
  noise_relative: 0.1
  noise_common: 0.03
"""
EVENTS_SECTION = """events:
  - at_s: 4.0
    object: 0
    translate: [0.0, -0.01, 0.0]
"""
#: pen.yaml with every optional section spelled out.
FULL_PEN = PEN + SENSOR_SECTION + EVENTS_SECTION


def write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def line_of(text, fragment):
    return text[: text.index(fragment)].count("\n") + 1


def bad_scene(tmp_path, base, old, new, at=None):
    """``base`` with ``old`` replaced by ``new``, and the line of ``at`` in it (default: the last
    line of ``new``, where the bad value usually is)."""
    assert old in base, old
    text = base.replace(old, new, 1)
    return write(tmp_path, text), line_of(text, at or new.strip().splitlines()[-1])


MOUNT_POSITION = "  position: [0.0, 0.0, 0.011]"
# (base text, old, new, fragments of the message besides file:line[, text of the line named])
BAD = [
    # top level: control rate, duration, seed
    (PEN, "rate_hz: 250", "rate_hz: 1.0e6", ["rate_hz", "from 50 to 1900 Hz", "1000000"]),
    (PEN, "rate_hz: 250", "rate_hz: 1", ["rate_hz", "from 50 to 1900 Hz"]),
    (PEN, "rate_hz: 250", "rate_hz: 0", ["rate_hz"]),
    (PEN, "rate_hz: 250", "rate_hz: .nan", ["rate_hz", "finite"]),
    (PEN, "duration_s: 20", "duration_s: 0", ["duration_s", "positive"]),
    (PEN, "duration_s: 20", "duration_s: -3", ["duration_s", "positive"]),
    (PEN, "duration_s: 20", "duration_s: .inf", ["duration_s", "finite"]),
    (PEN, "seed: 0", "seed: -1", ["seed", "integer from 0", "-1"]),
    (PEN, "seed: 0", "seed: 1.5", ["seed", "integer"]),
    (PEN, "seed: 0", "seed: yes", ["seed", "integer"]),
    (PEN, "seed: 0", "seed: 9223372036854775808", ["seed", "integer from 0 to 9223372036854775807"]),
    # the sensor: grid, pitch, sub-samples, foam, calibration spread, noise
    (FULL_PEN, "  rows: 16", "  rows: 0", ["sensor.rows", "integer from 1 to 128"]),
    (FULL_PEN, "  rows: 16", "  rows: 100000", ["sensor.rows", "integer from 1 to 128"]),
    (FULL_PEN, "  rows: 16", "  rows: 16.5", ["sensor.rows", "integer"]),
    (FULL_PEN, "  cols: 16", "  cols: -16", ["sensor.cols", "integer from 1 to 128"]),
    (FULL_PEN, "  subsamples: 3", "  subsamples: 0", ["sensor.subsamples", "integer from 1 to 10"]),
    (FULL_PEN, "  subsamples: 3", "  subsamples: 64", ["sensor.subsamples", "integer from 1 to 10"]),
    (FULL_PEN, "  pitch: 0.005", "  pitch: 0", ["sensor.pitch", "from 0.0001 to 0.05 m"]),
    (FULL_PEN, "  pitch: 0.005", "  pitch: -0.005", ["sensor.pitch"]),
    (FULL_PEN, "  foam_stiffness: 2.0e7", "  foam_stiffness: 0", ["sensor.foam_stiffness", "positive"]),
    (FULL_PEN, "  foam_stiffness: 2.0e7", "  foam_stiffness: .inf", ["sensor.foam_stiffness", "finite"]),
    (FULL_PEN, "  foam_spread: 0.7", "  foam_spread: -0.7", ["sensor.foam_spread", "non-negative"]),
    (FULL_PEN, "  foam_spread: 0.7", "  foam_spread: 1000", ["sensor.foam_spread", "up to 16"]),
    (FULL_PEN, "  calibration_spread: 0.15", "  calibration_spread: -0.1", ["sensor.calibration_spread"]),
    (FULL_PEN, "  calibration_spread: 0.15", "  calibration_spread: 5", ["sensor.calibration_spread", "up to 1"]),
    (FULL_PEN, "  noise_counts: 5", "  noise_counts: -5", ["sensor.noise_counts", "non-negative"]),
    (FULL_PEN, "  noise_counts: 5", "  noise_counts: 1.0e5", ["sensor.noise_counts", "up to 4095"]),
    (FULL_PEN, "  noise_relative: 0.1", "  noise_relative: .nan", ["sensor.noise_relative", "finite"]),
    (FULL_PEN, "  noise_common: 0.03", "  noise_common: 2", ["sensor.noise_common", "up to 1"]),
    # the mount
    (PEN, "  position: [0.0, 0.0, 0.011]", "  position: [0.0, .nan, 0.011]", ["mount.position[1]", "finite"]),
    (PEN, "  position: [0.0, 0.0, 0.011]", "  position: [1.0e300, 0.0, 0.011]", ["mount.position[0]", "-100 to 100"]),
    (PEN, "  rpy_deg: [180, 0, 0]", "  rpy_deg: [180, 0, .inf]", ["mount.rpy_deg[2]", "finite"]),
    (PEN, "  type: lwr4", "  type: lwr4\n  stiffness: -200", ["mount.stiffness", "positive"]),
    (PEN, "  type: lwr4", "  type: lwr4\n  stiffness: 0", ["mount.stiffness", "positive"]),
    (PEN, "  type: lwr4", "  type: lwr4\n  damping: -0.2", ["mount.damping", "non-negative"]),
    (PEN, "  type: lwr4", "  type: lwr4\n  base: [2.0, 0.0, 0.0]",
     ["mount.base", "cannot reach the start pose", "[0, 0, 0.011]", "mount.position"]),
    (PEN, "  rpy_deg: [180, 0, 0]", "  rpy_deg: [0, 0, 0]",
     ["mount.rpy_deg", "cannot reach the start pose", "[180, 0, yaw]"]),
    # the pad starts inside an object
    (PEN, "  position: [0.0, 0.0, 0.011]", "  position: [0.0, 0.0, -0.022]",
     ["mount.position", "30 mm inside objects.0 (cylinder)", "3 mm allowed", "objects.0.position"]),
    (PEN, "    position: [0.0, 0.0, 0.004]", "    position: [0.0, 0.0, 0.04]",
     ["mount.position", "inside objects.0 (cylinder)"], MOUNT_POSITION),
    (PEN, "    height: 0.0", "    height: 0.02", ["mount.position", "9 mm inside objects.1 (table)", "objects.1.height"],
     MOUNT_POSITION),
    # objects: stiffness, friction, sizes, poses
    (PEN, "    stiffness: 1.0e7", "    stiffness: 0", ["objects.0.stiffness", "positive"]),
    (PEN, "    stiffness: 1.0e7", "    stiffness: -1.0e7", ["objects.0.stiffness", "positive"]),
    (PEN, "    stiffness: 1.0e7", "    stiffness: .inf", ["objects.0.stiffness", "finite"]),
    (PEN, "    friction: 0.3", "    friction: -0.3", ["objects.0.friction", "non-negative"]),
    (PEN, "    radius: 0.004", "    radius: 0", ["objects.0.radius", "positive"]),
    (PEN, "    length: 0.14", "    length: .inf", ["objects.0.length", "finite"]),
    (PEN, "    length: 0.14", "    length: 1.0e6", ["objects.0.length", "up to 100 m"]),
    (PEN, "    position: [0.0, 0.0, 0.004]", "    position: [.nan, 0.0, 0.004]", ["objects.0.position[0]", "finite"]),
    (PEN, "    rpy_deg: [0, 0, 30]", "    rpy_deg: [0, 0, -.inf]", ["objects.0.rpy_deg[2]", "finite"]),
    (PEN, "    height: 0.0", "    height: .inf", ["objects.1.height", "finite"]),
    (PEN, "  - type: cylinder               # axis along its own x\n    radius: 0.004\n    length: 0.14",
     "  - type: box\n    size: [0.1, 0.0, 0.1]", ["objects.0.size[1]", "positive"]),
    (PEN, "  - type: cylinder               # axis along its own x\n    radius: 0.004\n    length: 0.14",
     "  - type: sphere\n    radius: -0.01", ["objects.0.radius", "positive"]),
    # the cable's shape
    (CABLE, "    radius: 0.003", "    radius: 0.2", ["objects.1.radius", "up to 0.05 m"]),
    (CABLE, "    start: [0.0, 0.0]", "    start: [0.0, .nan]", ["objects.1.start[1]", "finite"]),
    (CABLE, "    start: [0.0, 0.0]", "    start: [0.0, 0.0]\n    table_height: .inf", ["objects.1.table_height", "finite"]),
    (CABLE, "    heading_deg: 90", "    heading_deg: .inf", ["objects.1.heading_deg", "finite"]),
    (CABLE, "      - straight: 0.07", "      - straight: -0.07", ["objects.1.path[0].straight", "positive"]),
    (CABLE, "      - straight: 0.07", "      - straight: 0", ["objects.1.path[0].straight", "positive"]),
    (CABLE, "      - straight: 0.07", "      - straight: .inf", ["objects.1.path[0].straight", "finite"]),
    (CABLE, "      - straight: 0.07", "      - straight: 50", ["objects.1.path", "50.4 m long", "10 m allowed"],
     "      - straight: 50"),
    (CABLE, "      - arc: {radius: 0.10, angle_deg: -90}", "      - arc: {radius: 0, angle_deg: -90}",
     ["objects.1.path[1].arc.radius", "positive"]),
    (CABLE, "      - arc: {radius: 0.10, angle_deg: -90}", "      - arc: {radius: 0.10, angle_deg: .nan}",
     ["objects.1.path[1].arc.angle_deg", "finite"]),
    (CABLE, "      - straight: 0.025", "      - straight: 2.0", ["objects.1.path", "spans 2.02 m", "1 m allowed"],
     "      - straight: 0.07"),
    # events
    (FULL_PEN, "  - at_s: 4.0", "  - at_s: -4.0", ["events.0.at_s", "non-negative"]),
    (FULL_PEN, "  - at_s: 4.0", "  - at_s: .nan", ["events.0.at_s", "finite"]),
    (FULL_PEN, "    translate: [0.0, -0.01, 0.0]", "    translate: [0.0, .inf, 0.0]", ["events.0.translate[1]", "finite"]),
    (FULL_PEN, "    translate: [0.0, -0.01, 0.0]", "    rotate_deg: [0.0, .nan, 0.0]", ["events.0.rotate_deg[1]", "finite"]),
]


@pytest.mark.parametrize("case", BAD, ids=[c[2].strip().replace("\n", " ") for c in BAD])
def test_bad_value_names_file_line_and_field(tmp_path, case):
    base, old, new, fragments, *at = case
    path, line = bad_scene(tmp_path, base, old, new, *at)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:{line}:"), msg
    for fragment in fragments:
        assert fragment in msg, msg


def test_the_full_pen_scene_is_valid(tmp_path):
    scene = load_scene(write(tmp_path, FULL_PEN))
    assert scene.sensor == SensorParams()
    assert len(scene.events) == 1


@pytest.mark.parametrize(
    "override,fragments",
    [
        ("seed=-1", ["seed", "integer from 0"]),
        ("rate_hz=1e6", ["rate_hz", "50 to 1900 Hz"]),
        ("duration_s=0", ["duration_s", "positive"]),
        ("sensor.rows=100000", ["sensor.rows", "1 to 128"]),
        ("sensor.subsamples=0", ["sensor.subsamples", "1 to 10"]),
        ("mount.stiffness=-1", ["mount.stiffness", "positive"]),
        ("objects.0.friction=-1", ["objects.0.friction", "non-negative"]),
        ("objects.0.radius=.nan", ["objects.0.radius", "finite"]),
        ("events=[{at_s: 1, object: 0, translate: [.nan, 0, 0]}]", ["events.0.translate[0]", "finite"]),
        ("mount.base=[2.0, 0.0, 0.0]", ["mount.base", "cannot reach", "(scene ", "pen.yaml)"]),
        ("mount.position=[0.0, 0.0, -0.022]", ["mount.position", "30 mm inside objects.0 (cylinder)", "pen.yaml"]),
    ],
)
def test_overrides_go_through_the_same_checks(override, fragments):
    with pytest.raises(SceneError) as info:
        load_scene(SIM / "pen.yaml", [override])
    msg = str(info.value)
    assert msg.startswith("--set " + override.split("=")[0] + ":"), msg
    for fragment in fragments:
        assert fragment in msg, msg


# ------------------------------------------------------------------ what must keep loading


@pytest.mark.parametrize("path", sorted(SIM.glob("*.yaml")), ids=lambda p: p.name)
def test_every_shipped_scene_loads(path):
    scene = load_scene(path)
    assert 50 <= scene.rate_hz <= 1900


@pytest.mark.parametrize("case", stiffness_cases() + extreme_cases(), ids=lambda c: c.name)
def test_every_stability_scene_loads(case):
    load_scene(ROOT / case.scene, list(case.overrides))


@pytest.mark.parametrize("rate", [50, 100, 250, 500, 1000, 1900])
def test_control_rates_of_the_stability_sweep_are_allowed(rate):
    assert load_scene(SIM / "cable.yaml", [f"rate_hz={rate}"]).rate_hz == rate


def test_zero_turns_spread_and_noise_off():
    zero = ["sensor.foam_spread=0", "sensor.calibration_spread=0", "sensor.noise_counts=0",
            "sensor.noise_relative=0", "sensor.noise_common=0"]
    s = load_scene(SIM / "pen.yaml", zero)
    assert s.sensor.foam_spread == 0.0 and s.sensor.noise_common == 0.0


def test_every_sensor_parameter_has_a_checked_kind():
    assert set(SENSOR) == {f.name for f in dataclasses.fields(SensorParams)}


# ------------------------------------------------------------------ seeds


@pytest.mark.parametrize("seed", [0, 7, 2**63 - 1, np.int64(3)])
def test_check_seed_accepts_non_negative_integers(seed):
    assert check_seed(seed) == int(seed)
    assert type(check_seed(seed)) is int


@pytest.mark.parametrize("seed", [-1, 1.5, 2.0, True, "3", None, 2**63, float("nan")])
def test_check_seed_rejects_the_rest(seed):
    with pytest.raises(ValueError, match="expected a seed"):
        check_seed(seed)


# ------------------------------------------------------------------ the start of the pad


def test_penetration_by_object_measures_the_contact_depth():
    scene = load_scene(SIM / "pen.yaml")
    model = SensorModel(scene.sensor, np.random.default_rng(0))
    T = scene.mount_pose.copy()
    assert_allclose(model.penetration_by_object(T, scene.objects), [0.0, 0.0])
    T[2, 3] = 0.006  # the pen's top is at 8 mm
    assert_allclose(model.penetration_by_object(T, scene.objects), [0.002, 0.0], atol=1e-6)
    T[2, 3] = -0.001
    assert_allclose(model.penetration_by_object(T, scene.objects), [0.009, 0.001], atol=1e-6)
    # the same depth as the pad model's force image reports
    _, deepest = model.force_image(T, scene.objects)
    assert_allclose(deepest, model.penetration_by_object(T, scene.objects).max(), atol=1e-12)


def test_start_depth_tolerance():
    z_top = 0.008
    load_scene(SIM / "pen.yaml", [f"mount.position=[0.0, 0.0, {z_top - MAX_START_DEPTH_M + 1e-4}]"])
    with pytest.raises(SceneError, match=r"inside objects\.0 \(cylinder\)"):
        load_scene(SIM / "pen.yaml", [f"mount.position=[0.0, 0.0, {z_top - MAX_START_DEPTH_M - 1e-4}]"])


def test_object_placed_over_a_default_pad_is_blamed_on_its_position(tmp_path):
    text = "objects:\n  - type: sphere\n    radius: 0.05\n    position: [0.0, 0.0, 0.05]\n"
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:4:") and "objects.0.position" in msg and "50 mm inside objects.0 (sphere)" in msg


def test_build_world_names_the_scene_when_the_arm_cannot_reach_the_start():
    scene = Scene(name="far", file="far.yaml", mount=MountSpec(type="lwr4", base=(2.0, 0.0, 0.0)))
    with pytest.raises(SceneError) as info:
        scene.build_world(np.random.default_rng(0))
    msg = str(info.value)
    assert msg.startswith("far.yaml: mount.base: the arm cannot reach the start pose"), msg


def test_a_thick_cable_has_no_contact_beyond_its_grid():
    cable = Cable(path=np.array([[0.0, 0.0], [0.1, 0.0]]), radius=0.04)
    lateral = [0.03, 0.045, 0.1, 0.5]
    pts = np.array([[0.05, y, 0.04] for y in lateral])
    sdf = cable.sdf(pts)
    assert_allclose(sdf[:2], np.array(lateral[:2]) - 0.04, atol=1e-6)
    # beyond the grid the distance is a lower bound, but still outside the cable
    assert np.all(sdf[2:] > 0.0) and np.all(sdf[2:] <= np.array(lateral[2:]) - 0.04)
    assert np.all(cable.depth(pts, np.array([0.0, 0.0, -1.0]))[1:] == 0.0)


# ------------------------------------------------------------------ the command line


CLI_CASES = [
    (PEN, "rate_hz: 250", "rate_hz: 1.0e6", "rate_hz"),
    (PEN, "seed: 0", "seed: -1", "seed"),
    (FULL_PEN, "  rows: 16", "  rows: 100000", "sensor.rows"),
    (PEN, "  type: lwr4", "  type: lwr4\n  base: [2.0, 0.0, 0.0]", "mount.base"),
    (PEN, "  position: [0.0, 0.0, 0.011]", "  position: [0.0, 0.0, -0.022]", "mount.position"),
    (PEN, "    stiffness: 1.0e7", "    stiffness: -1", "objects.0.stiffness"),
]


@pytest.mark.parametrize("base,old,new,field", CLI_CASES, ids=[c[3] for c in CLI_CASES])
def test_run_reports_a_bad_scene_in_one_line(tmp_path, capsys, base, old, new, field):
    path, line = bad_scene(tmp_path, base, old, new)
    out = tmp_path / "out"
    code = main(["run", TREE, "--scene", str(path), "--out", str(out)])
    assert code != 0
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}:{line}:"), err
    assert field in lines[0] and "Traceback" not in err
    assert not (out / "report.json").exists()


def test_run_reports_a_bad_override_in_one_line(tmp_path, capsys):
    code = main(["run", TREE, "--scene", str(SIM / "pen.yaml"), "--set", "mount.base=[2.0, 0.0, 0.0]",
                 "--out", str(tmp_path / "out")])
    assert code != 0
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --set mount.base:"), err
    assert "pen.yaml" in lines[0] and "cannot reach" in lines[0] and "Traceback" not in err
