"""Scene files: YAML → validated :class:`Scene` → :class:`~tactile_bt.sim.world.World`.

A scene lists the pad's sensor parameters, its mount and the objects; every key is checked
against the schema below, and errors name the file, the line and the field. ``--set`` style
overrides (``objects.1.stiffness=1e5``) go through the same checks. The schema, with units and
defaults, is documented in ``sim/README.md``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tactile_bt import defaults
from tactile_bt.sim.events import EventSchedule, ObjectEvent
from tactile_bt.sim.objects import Cable, Table, object_pose, polyline_from_segments
from tactile_bt.sim.shapes import Box, Cylinder, Sphere
from tactile_bt.sim.sensor import SensorModel, SensorParams
from tactile_bt.sim.mounts import MOUNT_FIELDS, MountSpec
from tactile_bt.sim.world import World
from tactile_bt.yamlutil import Located, YamlError, load_located, parse_value, plain

__all__ = ["Scene", "load_scene", "apply_overrides", "SceneError"]

SceneError = YamlError

_NUMBER = "number"
_POSITIVE = "positive number"
_NONNEGATIVE = "non-negative number"
_INT = "integer"
_STR = "string"


def _vec(n: int) -> str:
    return f"list of {n} numbers"


#: Top-level keys of a scene and their types.
TOP_LEVEL = {
    "name": _STR,
    "description": _STR,
    "rate_hz": _POSITIVE,
    "duration_s": _POSITIVE,
    "seed": _INT,
    "sensor": "mapping",
    "mount": "mapping",
    "objects": "list",
    "events": "list",
    "scan_region": "mapping",
}
SENSOR = {f.name: (_INT if f.type in ("int", int) else _NONNEGATIVE) for f in dataclasses.fields(SensorParams)}
SENSOR.update(pitch=_POSITIVE, foam_stiffness=_POSITIVE)
MOUNT = MOUNT_FIELDS
#: Fields every object has: its type, pose in the world and contact properties.
_COMMON = {"type": _STR, "position": _vec(3), "rpy_deg": _vec(3), "stiffness": _POSITIVE,
           "friction": _NONNEGATIVE}
OBJECTS = {
    "table": {**_COMMON, "height": _NUMBER},
    "cable": {
        **_COMMON,
        "radius": _POSITIVE,
        "table_height": _NUMBER,
        "start": _vec(2),
        "heading_deg": _NUMBER,
        "path": "list",
        "points": "list",
    },
    "box": {**_COMMON, "size": "list of 3 positive numbers"},
    "sphere": {**_COMMON, "radius": _POSITIVE},
    "cylinder": {**_COMMON, "radius": _POSITIVE, "length": _POSITIVE},
    "mesh": {**_COMMON, "path": _STR, "scale": _POSITIVE, "resolution": _POSITIVE},
}
#: Fields an object type cannot do without.
REQUIRED = {"box": ("size",), "sphere": ("radius",), "cylinder": ("radius", "length"), "mesh": ("path",)}
EVENT = {"at_s": _NONNEGATIVE, "object": _INT, "translate": _vec(3), "rotate_deg": _vec(3)}


def _check(value: Located, kind: str, field_name: str) -> Any:
    v = value.value
    if kind == _NUMBER:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise value.error(f"{field_name}: expected a number, got {plain(v)!r}")
        if not np.isfinite(v):
            raise value.error(f"{field_name}: expected a finite number, got {v!r}")
        return float(v)
    if kind in (_POSITIVE, _NONNEGATIVE):
        x = _check(value, _NUMBER, field_name)
        if x < 0 or (kind == _POSITIVE and x == 0):
            raise value.error(f"{field_name}: expected a {kind}, got {x!r}")
        return x
    if kind == _INT:
        if isinstance(v, bool) or not isinstance(v, int):
            raise value.error(f"{field_name}: expected an integer, got {plain(v)!r}")
        return v
    if kind == _STR:
        if not isinstance(v, str):
            raise value.error(f"{field_name}: expected a string, got {plain(v)!r}")
        return v
    if kind == "mapping":
        if not isinstance(v, dict):
            raise value.error(f"{field_name}: expected a mapping")
        return v
    if kind == "list":
        if not isinstance(v, list):
            raise value.error(f"{field_name}: expected a list")
        return v
    if kind.startswith("list of "):
        n = int(kind.split()[2])
        if not isinstance(v, list) or len(v) != n:
            raise value.error(f"{field_name}: expected {kind}, got {plain(v)!r}")
        # "list of 3 numbers" → number, "list of 3 positive numbers" → positive number
        item_kind = " ".join(kind.split()[3:])[:-1]
        return [_check(x, item_kind, f"{field_name}[{i}]") for i, x in enumerate(v)]
    raise AssertionError(kind)


def _fields(section: Located, schema: dict, where_: str) -> dict:
    from difflib import get_close_matches

    out = {}
    for key, value in section.value.items():
        if key not in schema:
            hint = get_close_matches(key, list(schema), n=1)
            loc = section.keys[key]
            raise loc.error(f"unknown field {where_}{key!r}" + (f" (did you mean {hint[0]!r}?)" if hint else "")
                            + f"; valid fields: {', '.join(sorted(schema))}")
        out[key] = _check(value, schema[key], where_ + key)
    return out


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

    def build_world(self, rng: np.random.Generator) -> World:
        """A fresh world (sensor characteristics drawn from ``rng``) with its own event schedule
        (``World.update`` applies it to the world's list of objects, not to the scene's)."""
        world = World(self.objects, SensorModel(self.sensor, rng), self.mount.build())
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


def _build_object(item: Located, index: int, scene_file: str = "") -> Any:
    where_ = f"objects.{index}."
    if not isinstance(item.value, dict) or "type" not in item.value:
        raise item.error(f"objects.{index}: an object needs a 'type' ({', '.join(OBJECTS)})")
    kind = _check(item.value["type"], _STR, where_ + "type")
    if kind not in OBJECTS:
        from difflib import get_close_matches

        hint = get_close_matches(kind, list(OBJECTS), n=1)
        raise item.value["type"].error(f"{where_}type: unknown object type {kind!r}"
                                       + (f" (did you mean {hint[0]!r}?)" if hint else "")
                                       + f"; valid: {', '.join(OBJECTS)}")
    f = _fields(item, OBJECTS[kind], where_)
    f.pop("type")
    for name in REQUIRED.get(kind, ()):
        if name not in f:
            raise item.error(f"{where_}{name}: a {kind} needs '{name}'")
    f["pose"] = object_pose(f.pop("position", (0.0, 0.0, 0.0)), f.pop("rpy_deg", (0.0, 0.0, 0.0)))
    if kind == "table":
        return Table(**f)
    if kind == "box":
        return Box(**{**f, "size": tuple(f["size"])})
    if kind == "sphere":
        return Sphere(**f)
    if kind == "cylinder":
        return Cylinder(**f)
    if kind == "mesh":
        return _build_mesh(item, f, where_, scene_file)
    if "points" in f:
        pts = np.array([_check(p, _vec(2), f"{where_}points[{i}]") for i, p in enumerate(f.pop("points"))])
        f.pop("path", None)
    else:
        if "path" not in f:
            raise item.error(f"{where_}: a cable needs 'path' (segments) or 'points'")
        segments = []
        for i, seg in enumerate(f.pop("path")):
            s = plain(seg)
            ok = isinstance(s, dict) and len(s) == 1 and (
                ("straight" in s and isinstance(s["straight"], (int, float)))
                or ("arc" in s and isinstance(s["arc"], dict) and set(s["arc"]) == {"radius", "angle_deg"})
            )
            if not ok:
                raise seg.error(f"{where_}path[{i}]: expected {{straight: length_m}} or "
                                f"{{arc: {{radius: m, angle_deg: deg}}}}, got {s!r}")
            segments.append(s)
        pts = polyline_from_segments(f.pop("start", (0.0, 0.0)), f.pop("heading_deg", 0.0), segments)
    f.pop("start", None)
    f.pop("heading_deg", None)
    return Cable(path=pts, **f)


def _build_mesh(item: Located, f: dict, where_: str, scene_file: str):
    """A mesh object; its file is relative to the scene file's directory. Imports trimesh."""
    from tactile_bt.sim.mesh_object import MeshError, MeshObject

    located = item.value["path"]
    path = Path(f.pop("path")).expanduser()
    if not path.is_absolute():
        path = Path(scene_file).resolve().parent / path
    if not path.is_file():
        raise located.error(f"{where_}path: mesh file not found: {path}")
    try:
        return MeshObject(path=str(path), **f)
    except MeshError as exc:
        # a grid too large is the resolution's fault (or the scale's); anything else the file's
        culprit = "resolution" if "grid is too large" in str(exc) and "resolution" in item.value else "path"
        raise item.value[culprit].error(f"{where_}{culprit}: {exc}") from None


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
        raise item.value["object"].error(f"{where_}object: no object {f['object']} in this scene "
                                         f"(valid: 0 to {n_objects - 1})")
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
    if scene.rate_hz <= 0 or scene.duration_s <= 0:
        raise root.error("rate_hz and duration_s must be positive")
    if "sensor" in top:
        scene.sensor = SensorParams(**_fields(root.value["sensor"], SENSOR, "sensor."))
    if "mount" in top:
        section = root.value["mount"]
        try:
            scene.mount = MountSpec(**_fields(section, MOUNT, "mount."))
        except ValueError as exc:
            where_ = section.value.get("type", section)
            raise where_.error(str(exc)) from None
    scene.objects = [_build_object(item, i, root.file) for i, item in enumerate(top.get("objects", []))]
    if "scan_region" in top:  # what a surface scan sets out to cover (tactile_bt.scan_metrics)
        from tactile_bt.scan_metrics import check_region

        try:
            check_region(plain(root.value["scan_region"]))
        except ValueError as exc:
            raise root.value["scan_region"].error(str(exc)) from None
    scene.events = [_build_event(item, i, len(scene.objects)) for i, item in enumerate(top.get("events", []))]
    return scene


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
    """Read, override and validate a scene file."""
    root = load_located(path)
    if overrides:
        apply_overrides(root, overrides)
    return build_scene(root)
