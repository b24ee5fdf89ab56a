"""Scene files: YAML → validated :class:`Scene` → :class:`~tactile_bt.sim.world.World`.

A scene lists the pad's sensor parameters, its mount and the objects; every key is checked
against the schema below (kinds from :mod:`tactile_bt.sim.schema`: finite numbers within
bounds, integers, fixed-length lists), and errors name the file, the line and the field.
``--set`` style overrides (``objects.1.stiffness=1e5``) go through the same checks. Loading
then checks the start: the arm reaches the start pose, and the pad starts at most
:data:`MAX_START_DEPTH_M` inside any object. Every error is a :class:`SceneError` (the
:class:`~tactile_bt.errors.YamlError` the command line reports in one line). The schema, with
units, bounds and defaults, is documented in ``sim/README.md``.

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tactile_bt import defaults, shipped
from tactile_bt.sim.events import EventSchedule, ObjectEvent
from tactile_bt.sim.objects import Cable, Table, object_pose
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt.robot.mounts import MountSpec
from tactile_bt.errors import MountError
from tactile_bt.sim.schema import (check_fields as _fields, check_value as _check,
                                   ANGLE_DEG, COORD, INT, LIST, MAPPING, NONNEGATIVE, STR, ListOf,
                                   Range)
from tactile_bt.sim.region import check_region
from tactile_bt.sim.registry import ObjectSource, ShapeValueError, shape_class, shape_names
from tactile_bt.sim.world import World
from tactile_bt.yamlutil import Located, load_located, parse_value, plain
from tactile_bt.errors import SceneError, YamlError

__all__ = ["Scene", "load_scene", "apply_overrides", "check_seed"]


#: Control rates (Hz) a scene may ask for: from a slow but stable loop up to the pad's frame
#: rate (``tactile-bt stability`` runs 100–1900 Hz).
MIN_RATE_HZ = 50.0
MAX_RATE_HZ = defaults.MAX_SENSOR_RATE_HZ
#: Seeds are non-negative and fit in 64-bit signed integers (numpy arrays, logs).
SEED = Range(0, 2**63 - 1, integer=True)
#: Largest tactel grid side: a raw frame of ``2 · rows · cols`` bytes must fit the serial
#: protocol's 16-bit length (``via_emulator`` missions).
MAX_TACTELS_PER_SIDE = 128
#: Deepest the pad may start inside an object (m), measured along its normal like the contact
#: depth. A few millimetres of initial contact settle (``tactile-bt stability`` starts the pad
#: 2 mm inside the rigid pen); more throws the pad out with tens of newtons on the first tick.
MAX_START_DEPTH_M = 3.0e-3

def check_seed(value: Any) -> int:
    """``value`` as a seed (a non-negative integer that fits in 64 bits), else ValueError."""
    if isinstance(value, np.integer):
        value = int(value)
    if not SEED.accepts(value):
        raise ValueError(f"expected a seed, {SEED}, got {value!r}")
    return value


#: Top-level keys of a scene and their kinds.
TOP_LEVEL = {
    "name": STR,
    "description": STR,
    "rate_hz": Range(MIN_RATE_HZ, MAX_RATE_HZ, unit="Hz"),
    "duration_s": Range(0.0, lo_open=True, unit="s"),
    "seed": SEED,
    "sensor": MAPPING,
    "mount": MAPPING,
    "objects": LIST,
    "events": LIST,
    "scan_region": MAPPING,
    "supervisor": MAPPING,
}
#: The ``sensor:`` section (one entry per :class:`SensorParams` field). Zero turns the spread
#: and noise terms off; the upper bounds keep the pad model's arrays and noise meaningful.
SENSOR = {
    "rows": Range(1, MAX_TACTELS_PER_SIDE, integer=True),
    "cols": Range(1, MAX_TACTELS_PER_SIDE, integer=True),
    "pitch": Range(1e-4, 0.05, unit="m"),
    "subsamples": Range(1, 10, integer=True),
    "foam_stiffness": Range(0.0, lo_open=True, unit="Pa/m"),
    "foam_spread": Range(0.0, 16.0, unit="tactels"),
    "calibration_spread": Range(0.0, 1.0),
    "noise_counts": Range(0.0, float(defaults.ADC_MAX), unit="counts"),
    "noise_relative": Range(0.0, 1.0),
    "noise_common": Range(0.0, 1.0),
}
#: The ``mount:`` section (:class:`tactile_bt.robot.mounts.MountSpec`). The joint stiffness and
#: damping bounds are far beyond the LWR 4's (a few thousand N m/rad); they only keep the arm's
#: contact solve away from overflows.
MOUNT = {
    "type": STR,
    "position": ListOf(3, COORD),
    "rpy_deg": ListOf(3, ANGLE_DEG),
    "base": ListOf(3, COORD),
    "stiffness": Range(0.0, 1e8, lo_open=True, unit="N m/rad"),
    "damping": Range(0.0, 1e6, unit="N m s/rad"),
}
#: The ``supervisor:`` section: limits of the supervisor between the controller and the mount
#: (:mod:`tactile_bt.mission.supervisor`), which a scene or a run (``--set supervisor.KEY=...``)
#: may set within these bounds; no tree can.
SUPERVISOR = {
    "pressure_limit_pa": Range(0.0, defaults.SUPERVISOR_PRESSURE_CAP_PA, lo_open=True, unit="Pa"),
    "force_limit_n": Range(0.0, defaults.SUPERVISOR_FORCE_CAP_N, lo_open=True, unit="N"),
    "grace_s": Range(0.0, defaults.SUPERVISOR_MAX_WAIT_S, lo_open=True, unit="s"),
    "clear_s": Range(0.0, defaults.SUPERVISOR_MAX_WAIT_S, lo_open=True, unit="s"),
    "retreat_speed_mps": Range(0.0, defaults.TWIST_LINEAR_LIMIT_MPS, lo_open=True, unit="m/s"),
    "sensor_silence_s": Range(0.0, defaults.SUPERVISOR_MAX_STALE_S, lo_open=True, unit="s"),
    "pose_stale_s": Range(0.0, defaults.SUPERVISOR_MAX_STALE_S, lo_open=True, unit="s"),
    "workspace_min_m": ListOf(3, COORD),
    "workspace_max_m": ListOf(3, COORD),
}
#: Fields every object has: its type, pose in the world and contact properties. Each shape adds
#: its own (:attr:`tactile_bt.sim.registry.Shape.schema`).
COMMON_OBJECT_FIELDS = {"type": STR, "position": ListOf(3, COORD), "rpy_deg": ListOf(3, ANGLE_DEG),
                        "stiffness": Range(0.0, lo_open=True, unit="N/m"), "friction": NONNEGATIVE}
EVENT = {"at_s": Range(0.0, unit="s"), "object": INT, "translate": ListOf(3, COORD),
         "rotate_deg": ListOf(3, ANGLE_DEG)}


@dataclass
class Scene:
    """A validated scene, ready to build a world."""

    name: str
    file: str
    rate_hz: float = defaults.RATE_HZ
    duration_s: float = 20.0
    seed: int = 0
    sensor: SensorParams = field(default_factory=SensorParams)
    mount: MountSpec = field(default_factory=MountSpec)
    objects: list = field(default_factory=list)
    events: list = field(default_factory=list)
    data: dict = field(default_factory=dict)
    #: The validated ``supervisor:`` section (field → value), empty when the scene has none.
    supervisor: dict = field(default_factory=dict)

    def build_world(self, rng: np.random.Generator) -> World:
        """A fresh world (sensor characteristics drawn from ``rng``) with its own event schedule
        (``World.update`` applies it to the world's list of objects, not to the scene's).

        Raises :class:`SceneError` naming the scene file when the arm cannot reach the start
        pose (a scene built in code rather than loaded, which checks it on load)."""
        try:
            mount = self.mount.build(self.sensor.geometry)
        except MountError as exc:
            raise SceneError(str(exc), self.file) from None
        world = World(self.objects, SensorModel(self.sensor, rng), mount)
        world.events = EventSchedule(self.events)
        return world

    @property
    def mount_pose(self) -> np.ndarray:
        """Start pose ``T_gs`` of the pad."""
        return self.mount.pose

    @property
    def cable(self) -> Cable | None:
        """The first cable of the scene (its centreline is the ground truth of path metrics)."""
        return next((o for o in self.objects if isinstance(o, Cable)), None)

    @property
    def table(self) -> Table | None:
        """The first table of the scene (the robot's known set-up: the plane objects lie on)."""
        return next((o for o in self.objects if isinstance(o, Table)), None)


def object_schema(kind: str) -> dict:
    """The scene keys of an object of ``type`` ``kind`` and their kinds."""
    return {**COMMON_OBJECT_FIELDS, **shape_class(kind).schema}


def _build_object(item: Located, index: int, scene_file: str = "") -> Any:
    where_ = f"objects.{index}."
    names = shape_names()
    if not isinstance(item.value, dict) or "type" not in item.value:
        raise item.error(f"objects.{index}: an object needs a 'type' ({', '.join(names)})")
    kind = _check(item.value["type"], STR, where_ + "type")
    if kind not in names:
        from difflib import get_close_matches

        hint = get_close_matches(kind, names, n=1)
        raise item.value["type"].error(f"{where_}type: unknown object type {kind!r}"
                                       + (f" (did you mean {hint[0]!r}?)" if hint else "")
                                       + f"; valid: {', '.join(names)}")
    shape = shape_class(kind)
    f = _fields(item, object_schema(kind), where_)
    f.pop("type")
    for name in shape.required:
        if name not in f:
            raise item.error(f"{where_}{name}: a {kind} needs '{name}'")
    f["pose"] = object_pose(f.pop("position", (0.0, 0.0, 0.0)), f.pop("rpy_deg", (0.0, 0.0, 0.0)))
    source = ObjectSource(item, where_, scene_file, _check)
    try:
        return shape.from_scene(f, source)
    except ShapeValueError as exc:
        raise source.error(exc.field, str(exc)) from None


def _build_event(item: Located, index: int, n_objects: int) -> ObjectEvent:
    where_ = f"events.{index}."
    if not isinstance(item.value, dict):
        raise item.error(f"events.{index}: expected a mapping {{at_s: s, object: index, translate: [x, y, z], "
                         f"rotate_deg: [rx, ry, rz]}}")
    f = _fields(item, EVENT, where_)
    for name in ("at_s", "object"):
        if name not in f:
            raise item.error(f"{where_}{name}: an event needs '{name}'")
    if not 0 <= f["object"] < n_objects:
        valid = f"valid: 0 to {n_objects - 1}" if n_objects else "it has no objects"
        raise item.value["object"].error(f"{where_}object: no object {f['object']} in this scene ({valid})")
    if "translate" not in f and "rotate_deg" not in f:
        raise item.error(f"{where_}: an event needs 'translate' or 'rotate_deg'")
    return ObjectEvent(at_s=f["at_s"], object=f["object"], translate=tuple(f.get("translate", (0.0, 0.0, 0.0))),
                       rotate_deg=tuple(f.get("rotate_deg", (0.0, 0.0, 0.0))))


def build_scene(root: Located) -> Scene:
    """Validate a located scene tree and build the :class:`Scene`."""
    if not isinstance(root.value, dict):
        raise root.error("a scene must be a mapping")
    top = _fields(root, TOP_LEVEL, "")
    scene = Scene(name=top.get("name", Path(root.file).stem), file=root.file, data=plain(root))
    scene.rate_hz = top.get("rate_hz", defaults.RATE_HZ)
    scene.duration_s = top.get("duration_s", 20.0)
    scene.seed = top.get("seed", 0)
    if "sensor" in top:
        scene.sensor = SensorParams(**_fields(root.value["sensor"], SENSOR, "sensor."))
    if "mount" in top:
        section = root.value["mount"]
        fields = _fields(section, MOUNT, "mount.")
        try:
            scene.mount = MountSpec(**fields)
        except ValueError as exc:
            where_ = section.value.get("type", section)
            raise where_.error(str(exc)) from None
    scene.objects = [_build_object(item, i, root.file) for i, item in enumerate(top.get("objects", []))]
    if "scan_region" in top:  # what a surface scan sets out to cover (tactile_bt.sim.region)
        try:
            check_region(plain(root.value["scan_region"]))
        except ValueError as exc:
            raise root.value["scan_region"].error(str(exc)) from None
    scene.events = [_build_event(item, i, len(scene.objects)) for i, item in enumerate(top.get("events", []))]
    if "supervisor" in top:
        scene.supervisor = _supervisor_limits(root.value["supervisor"])
    _check_start(root, scene)
    return scene


def _supervisor_limits(section: Located) -> dict:
    """The ``supervisor:`` section's fields; a workspace box needs both corners, min below max."""
    fields = _fields(section, SUPERVISOR, "supervisor.")
    corners = [k for k in ("workspace_min_m", "workspace_max_m") if k in fields]
    if len(corners) == 1:
        other = ({"workspace_min_m", "workspace_max_m"} - set(corners)).pop()
        raise section.keys[corners[0]].error(f"supervisor.{corners[0]}: a workspace box needs supervisor.{other} too")
    if corners and not all(lo < hi for lo, hi in zip(fields["workspace_min_m"], fields["workspace_max_m"])):
        raise section.keys["workspace_max_m"].error(
            f"supervisor.workspace_max_m: expected every coordinate above workspace_min_m "
            f"{fields['workspace_min_m']}, got {fields['workspace_max_m']}")
    return fields


def _check_start(root: Located, scene: Scene) -> None:
    """The pad's start: the arm reaches it, and it is not deep inside an object.

    Errors point at the ``mount`` field to change (or the object's position when the mount
    section leaves the pad's position at its default).
    """
    mount = root.value.get("mount")
    fields = mount.value if mount is not None and isinstance(mount.value, dict) else {}

    def located(*names: str) -> Located:
        for name in names:
            if name in fields:
                return fields[name]
        return mount if mount is not None else root

    def in_scene(loc: Located) -> str:  # an override's location does not name the scene file
        return "" if loc.file == root.file else f" (scene {root.file})"

    try:
        scene.mount.build(scene.sensor.geometry)
    except MountError as exc:
        loc = located(exc.field, "position")
        raise loc.error(f"{exc}{in_scene(loc)}") from None
    if not scene.objects:
        return
    # The nominal start pose: the arm's inverse kinematics reaches it to 0.1 µm.
    depths = SensorModel(scene.sensor, np.random.default_rng(0)).penetration_by_object(scene.mount_pose, scene.objects)
    index = int(np.argmax(depths))
    if depths[index] <= MAX_START_DEPTH_M:
        return
    obj = root.value["objects"].value[index]
    kind = obj.value["type"].value
    moves = scene.objects[index].move_hint
    if "position" in fields or "position" not in obj.value:
        loc, blame = located("position"), "mount.position"
    else:
        loc, blame = obj.value["position"], f"objects.{index}.position"
    raise loc.error(f"{blame}: the pad starts {depths[index] * 1e3:.3g} mm inside objects.{index} ({kind}){in_scene(loc)}, "
                    f"more than the {MAX_START_DEPTH_M * 1e3:g} mm allowed; start it a few millimetres above the "
                    f"object: move the pad (mount.position, mount.rpy_deg) or the object (objects.{index}.{moves})")


def apply_overrides(root: Located, overrides: list[str]) -> Located:
    """Apply ``key.path=value`` overrides (list indices as integers) to a located scene tree.

    The value is parsed as YAML (``1e5`` is a number, ``[0, 1]`` a list). Unknown paths are an
    error naming the override.
    """
    for item in overrides:
        if "=" not in item:
            raise YamlError(f"--set {item!r}: expected key.path=value")
        path, text = item.split("=", 1)
        try:
            value = parse_value(text)
        except yaml.YAMLError as exc:
            raise YamlError(f"--set {item!r}: invalid value ({exc})") from None
        node = root
        parts = path.split(".")
        for depth, part in enumerate(parts):
            last = depth == len(parts) - 1
            container = node.value
            if isinstance(container, list):
                try:
                    key: Any = int(part)
                except ValueError:
                    key = None
                if key is None or not -len(container) <= key < len(container):
                    raise YamlError(f"--set {path}: {'.'.join(parts[:depth]) or 'scene'} has no item {part!r} "
                                    f"(valid: 0 to {len(container) - 1}, or negative from the end)")
            elif isinstance(container, dict):
                key = part
                if key not in container and not last:
                    # A section the file leaves out (e.g. sensor:) is created; the schema check
                    # below still rejects names that do not exist.
                    container[key] = _wrap({}, f"--set {path}")
                    if hasattr(node, "keys"):
                        node.keys[key] = Located(key, f"--set {path}", 1, 1)
            else:
                raise YamlError(f"--set {path}: {'.'.join(parts[:depth])!r} is not a mapping or list")
            if last:
                wrapped = _wrap(value, f"--set {path}")
                container[key] = wrapped
                if isinstance(container, dict) and hasattr(node, "keys"):
                    node.keys[key] = Located(key, f"--set {path}", 1, 1)
            else:
                node = container[key]
    return root


def _wrap(value: Any, file: str) -> Located:
    if isinstance(value, dict):
        loc = Located({k: _wrap(v, file) for k, v in value.items()}, file, 1, 1)
        loc.keys = {k: Located(k, file, 1, 1) for k in value}  # type: ignore[attr-defined]
        return loc
    if isinstance(value, list):
        return Located([_wrap(v, file) for v in value], file, 1, 1)
    return Located(value, file, 1, 1)


def load_scene(path: str | Path, overrides: list[str] | None = None) -> Scene:
    """Read, override and validate a scene file (``sim/NAME.yaml`` names a shipped scene where no
    such file is here)."""
    root = load_located(shipped.resolve(path))
    if overrides:
        apply_overrides(root, overrides)
    return build_scene(root)
