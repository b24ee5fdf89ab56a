"""The spec of a sweep (``tactile-bt sweep SPEC.yaml``): its fields, checked like a tree or a
scene (errors with file:line:column), and the combinations it asks for, checked before any run.
See :mod:`tactile_bt.experiments.sweep` for the format.

Layer: experiments.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tactile_bt import shipped
from tactile_bt.errors import TactileBtError, YamlError
from tactile_bt.units import to_si
from tactile_bt.yamlutil import Located, load_located, plain

__all__ = ["SweepSpec", "load_spec", "split_assignments", "si_value", "SPEC_FIELDS", "TREE_PREFIX"]

#: Top-level fields of a spec.
SPEC_FIELDS = ("name", "description", "tree", "scene", "scenes", "duration", "seeds", "grid", "set", "timeout_s")
#: Grid keys that start with this set tree parameters (``tree.NODE.PARAM``).
TREE_PREFIX = "tree."


# --------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep spec (see the module's docstring)."""

    file: str
    tree: str                                    # absolute path
    tree_label: str                              # as the spec writes it
    scenes: tuple[tuple[str, str], ...]          # (label, absolute path)
    seeds: tuple[int, ...]
    duration: float | None = None
    grid: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    fixed: tuple[tuple[str, Any], ...] = ()
    timeout_s: float | None = None
    name: str = ""

    @property
    def grid_keys(self) -> list[str]:
        return [k for k, _ in self.grid]

    def combinations(self) -> list[tuple[tuple[str, Any], ...]]:
        """Every combination of the grid's values (one empty one without a grid)."""
        keys = self.grid_keys
        return [tuple(zip(keys, values)) for values in itertools.product(*(v for _, v in self.grid))]


def _resolve(loc: Located, spec_dir: Path, what: str) -> tuple[str, str]:
    """(label, absolute path) of a file named in the spec: relative to the spec's folder, else
    to the current directory, else a file that ships with tactile_bt (``trees/...``, ``sim/...``)."""
    if not isinstance(loc.value, str) or not loc.value.strip():
        raise loc.error(f"{what}: expected a file name, got {plain(loc.value)!r}")
    label = loc.value.strip()
    candidates = [Path(label)] if Path(label).is_absolute() else [spec_dir / label, Path.cwd() / label,
                                                                         shipped.resolve(label)]
    for path in candidates:
        if path.is_file():
            return label, str(path.resolve())
    looked = " or ".join(str(p.parent) for p in candidates[:2]) + " or among the files tactile_bt ships"
    raise loc.error(f"{what}: file {label!r} not found (looked in {looked})")


def _number(loc: Located, what: str, positive: bool = True) -> float:
    v = loc.value
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
        raise loc.error(f"{what}: expected a finite number > 0, got {plain(v)!r}")
    return float(v)


def _seeds(loc: Located) -> tuple[int, ...]:
    from tactile_bt.sim.scene import check_seed

    v = loc.value
    if isinstance(v, dict):
        unknown = [k for k in v if k not in ("first", "count")]
        if unknown:
            raise loc.keys[unknown[0]].error(f"seeds: unknown field {unknown[0]!r}; valid fields: count, first")
        if "count" not in v:
            raise loc.error("seeds: expected a list of seeds, or {first: 0, count: N}")
        count, first = v["count"], v.get("first")
        if isinstance(count.value, bool) or not isinstance(count.value, int) or count.value < 1:
            raise count.error(f"seeds.count: expected an integer >= 1, got {plain(count.value)!r}")
        start = 0
        if first is not None:
            try:
                start = check_seed(first.value)
            except ValueError as exc:
                raise first.error(f"seeds.first: {exc}") from None
        return tuple(range(start, start + count.value))
    if not isinstance(v, list) or not v:
        raise loc.error(f"seeds: expected a non-empty list of seeds (integers >= 0), or {{first: 0, count: N}}, "
                        f"got {plain(v)!r}")
    out = []
    for i, item in enumerate(v):
        try:
            seed = check_seed(item.value)
        except ValueError as exc:
            raise item.error(f"seeds[{i}]: {exc}") from None
        if seed in out:
            raise item.error(f"seeds[{i}]: seed {seed} is listed twice")
        out.append(seed)
    return tuple(out)


def _check_key(key_loc: Located, section: str) -> str:
    key = key_loc.value
    parts = key.split(".")
    if not key or any(not p.strip() for p in parts) or key != key.strip():
        raise key_loc.error(f"{section}: {key!r} is not a key path such as objects.0.stiffness or "
                            "tree.force_hold.target_pa")
    if key == "seed":
        raise key_loc.error(f"{section}: seed: the seeds come from 'seeds:'")
    if key.startswith(TREE_PREFIX) and len(parts) < 3:
        raise key_loc.error(f"{section}: {key!r}: a tree parameter is tree.NODE.PARAM (NODE: a node's name as "
                            "'tactile-bt tree' shows it, or its type)")
    return key


def load_spec(path: str | Path, text: str | None = None) -> SweepSpec:
    """Read and check a sweep spec; every problem is a :class:`~tactile_bt.errors.YamlError`
    naming the file, line and column (or the tree's or scene's own error, for those files).

    Every scene with every combination of the grid's scene overrides is loaded, and the tree
    with every combination of its parameters, before anything runs."""
    root = load_located(path, text)
    if not isinstance(root.value, dict):
        raise root.error("a sweep spec must be a mapping with tree, scene, seeds and grid")
    fields_ = root.value
    for key in fields_:
        if key not in SPEC_FIELDS:
            from difflib import get_close_matches

            hint = get_close_matches(key, SPEC_FIELDS, n=1)
            raise root.keys[key].error(f"unknown field {key!r}" + (f" (did you mean {hint[0]!r}?)" if hint else "")
                                       + f"; valid fields: {', '.join(SPEC_FIELDS)}")
    for required in ("tree", "seeds"):
        if required not in fields_:
            raise root.error(f"a sweep spec needs '{required}'")
    if ("scene" in fields_) == ("scenes" in fields_):
        raise root.error("a sweep spec needs 'scene' (one file or a list) or 'scenes', not both" if "scene" in fields_
                         else "a sweep spec needs 'scene' (one file or a list) or 'scenes'")
    spec_dir = Path(str(path)).resolve().parent
    tree_label, tree = _resolve(fields_["tree"], spec_dir, "tree")
    scenes_loc = fields_.get("scene") or fields_["scenes"]
    scene_field = "scene" if "scene" in fields_ else "scenes"
    items = scenes_loc.value if isinstance(scenes_loc.value, list) else [scenes_loc]
    if not items:
        raise scenes_loc.error(f"{scene_field}: expected a scene file or a non-empty list of them")
    scenes = []
    for i, item in enumerate(items):
        label, file = _resolve(item, spec_dir, scene_field if item is scenes_loc else f"{scene_field}[{i}]")
        if any(label == s[0] for s in scenes):
            raise item.error(f"{scene_field}[{i}]: {label!r} is listed twice")
        scenes.append((label, file))
    seeds = _seeds(fields_["seeds"])
    duration = _number(fields_["duration"], "duration") if "duration" in fields_ else None
    timeout_s = _number(fields_["timeout_s"], "timeout_s") if "timeout_s" in fields_ else None
    name = fields_.get("name")
    if name is not None and not isinstance(name.value, str):
        raise name.error(f"name: expected a string, got {plain(name.value)!r}")
    desc = fields_.get("description")
    if desc is not None and not isinstance(desc.value, str):
        raise desc.error(f"description: expected a string, got {plain(desc.value)!r}")

    grid_locs: dict[str, Located] = {}
    grid: list[tuple[str, tuple]] = []
    if "grid" in fields_:
        g = fields_["grid"]
        if not isinstance(g.value, dict):
            raise g.error("grid: expected a mapping of key paths to lists of values")
        for key, values in g.value.items():
            _check_key(g.keys[key], "grid")
            if not isinstance(values.value, list) or not values.value:
                raise values.error(f"grid: {key}: expected a non-empty list of values (use 'set:' for one value), "
                                   f"got {plain(values.value)!r}")
            seen = []
            for i, v in enumerate(values.value):
                value = plain(v)
                if value is None:
                    raise v.error(f"grid: {key}[{i}]: expected a value, got nothing")
                if value in seen:
                    raise v.error(f"grid: {key}[{i}]: {value!r} is listed twice")
                seen.append(value)
            grid.append((key, tuple(seen)))
            grid_locs[key] = values
    fixed: list[tuple[str, Any]] = []
    fixed_locs: dict[str, Located] = {}
    if "set" in fields_:
        s = fields_["set"]
        if not isinstance(s.value, dict):
            raise s.error("set: expected a mapping of key paths to values")
        for key, value in s.value.items():
            _check_key(s.keys[key], "set")
            if key in grid_locs:
                raise s.keys[key].error(f"set: {key} is also in the grid")
            if plain(value) is None:
                raise value.error(f"set: {key}: expected a value, got nothing")
            fixed.append((key, plain(value)))
            fixed_locs[key] = value
    spec = SweepSpec(file=str(path), tree=tree, tree_label=tree_label, scenes=tuple(scenes), seeds=seeds,
                     duration=duration, grid=tuple(grid), fixed=tuple(fixed), timeout_s=timeout_s,
                     name=(name.value if name is not None else Path(str(path)).stem))
    _check_combinations(spec, grid_locs, fixed_locs, fields_.get("duration"), root)
    return spec


def _bare(exc: TactileBtError) -> str:
    """The message of a scene's or tree's error, without the location of an override (which names
    no file: the spec's location replaces it)."""
    if isinstance(exc, YamlError) and (exc.file or "").startswith(("--set ", "--param ")):
        from tactile_bt.tree.diagnostics import message_of

        return message_of(exc)
    return str(exc)


def split_assignments(assignments) -> tuple[list[str], dict[str, Any]]:
    """Scene overrides (``key=value`` strings) and tree parameters (``{NODE.PARAM: value}``)."""
    overrides, params = [], {}
    for key, value in assignments:
        if key.startswith(TREE_PREFIX):
            params[key[len(TREE_PREFIX):]] = value
        else:
            overrides.append(f"{key}={json.dumps(value)}")
    return overrides, params


def _check_combinations(spec: SweepSpec, grid_locs: dict, fixed_locs: dict, duration_loc, root: Located) -> None:
    """Load every scene and the tree with each value alone (errors at that value), then with every
    combination (errors at the grid)."""
    from tactile_bt.mission.run import MAX_CYCLES
    from tactile_bt.sim.scene import load_scene
    from tactile_bt.tree.loader import load_tree

    def located_at(loc: Located, what: str, call):
        try:
            return call()
        except TactileBtError as exc:
            raise loc.error(f"{what}: {_bare(exc)}") from None

    scene_cache: dict = {}
    tree_cache: dict = {}

    def scene(file: str, overrides: list[str]):
        key = (file, tuple(overrides))
        if key not in scene_cache:
            scene_cache[key] = load_scene(file, overrides)
        return scene_cache[key]

    def tree(params: dict):
        key = json.dumps(params, sort_keys=True)
        if key not in tree_cache:
            load_tree(spec.tree, params=params or None)
            tree_cache[key] = True

    tree({})  # the tree file itself: its own errors name its file and line
    for _label, file in spec.scenes:
        scene(file, [])
    fixed_over, fixed_params = split_assignments(spec.fixed)
    for key, value in spec.fixed:
        over, params = split_assignments([(key, value)])
        if params:
            located_at(fixed_locs[key], f"set: {key}", lambda: tree(params))
        for label, file in spec.scenes:
            if over:
                located_at(fixed_locs[key], f"set: {key} on {label}", lambda: scene(file, over))
    for key, values in spec.grid:
        for i, value in enumerate(values):
            over, params = split_assignments([(key, value)])
            loc = grid_locs[key].value[i]
            if params:
                located_at(loc, f"grid: {key}={value!r}", lambda: tree({**fixed_params, **params}))
            for label, file in spec.scenes:
                if over:
                    located_at(loc, f"grid: {key}={value!r} on {label}", lambda: scene(file, fixed_over + over))
    grid_loc = grid_locs[spec.grid_keys[0]] if spec.grid else root
    for combo in spec.combinations():
        over, params = split_assignments(spec.fixed + combo)
        shown = ", ".join(f"{k}={v!r}" for k, v in combo)
        if params:
            located_at(grid_loc, f"grid: the combination {shown}", lambda: tree(params))
        for label, file in spec.scenes:
            s = located_at(grid_loc, f"grid: the combination {shown} on {label}", lambda: scene(file, over))
            duration = spec.duration if spec.duration is not None else s.duration_s
            cycles = int(round(duration * s.rate_hz))
            if not 1 <= cycles <= MAX_CYCLES:
                loc = duration_loc if duration_loc is not None else grid_loc
                raise loc.error(f"duration: {duration:g} s at {s.rate_hz:g} Hz is {cycles} cycles on {label}"
                                f"{' with ' + shown if shown else ''}; a mission runs 1 to {MAX_CYCLES} cycles")


def si_value(key: str, value: Any) -> Any:
    """A grid value as its SI number (``"2.5 kPa"`` → 2500.0; degrees for the scene's ``*_deg``
    keys), for the table and the plots; :func:`tactile_bt.units.to_si`."""
    return to_si(value, degrees=key.endswith("_deg"))
