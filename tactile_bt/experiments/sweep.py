"""Sweeps of missions (``tactile-bt sweep SPEC.yaml --out DIR``): one tree over scenes, seeds and a
grid of scene or tree overrides, on any executor of :mod:`tactile_bt.experiments.executors`.

The spec (YAML, checked like a tree or a scene, errors with file:line:column)::

    tree: trees/force_hold.yaml        # paths: relative to the spec's folder, else to the
    scene: sim/pen.yaml                #   current directory; or `scenes: [a.yaml, b.yaml]`
    duration: 3                        # s of mission time (default: each scene's duration_s)
    seeds: [0, 1]                      # or {first: 0, count: 20}
    grid:                              # every combination of these values is run
      objects.0.stiffness: [1.0e4, 1.0e6]       # a scene override, as `run --set`
      tree.force_hold.target_pa: [1500, 2000]   # tree.NODE.PARAM: a tree parameter, as `--param`
    set: {mount.damping: 0.5}          # optional: fixed overrides, same keys
    timeout_s: 120                     # optional: wall-time limit of one run
    name: pen_stiffness                # optional

Every run is one mission, described by a small picklable :class:`Run` and named by a stable
:attr:`Run.run_id` (a hash of the tree's and scene's content, the overrides, the seed and the
duration). :func:`execute` runs it and returns a flat row; :func:`run_sweep` appends each row to
``DIR/results.csv`` as it arrives (Ctrl-C or a lost worker loses only the runs in flight), skips
the runs already there when run again, and ends with the table in the spec's order and
``DIR/summary.png`` (every metric against the grid values). A run that raises or times out is a
row with ``status`` ``error`` and the message.

Layer: experiments.
"""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from tactile_bt import shipped
from tactile_bt.errors import OutputPathError, TactileBtError, YamlError
from tactile_bt.units import format_value, to_si
from tactile_bt.yamlutil import Located, load_located, plain

__all__ = ["SweepSpec", "Run", "SweepResult", "load_spec", "plan", "execute", "error_row", "flatten_report",
           "ResultsTable", "run_sweep", "plot_summary", "format_summary", "metric_columns", "RunTimeout",
           "SPEC_FIELDS"]

#: Top-level fields of a spec.
SPEC_FIELDS = ("name", "description", "tree", "scene", "scenes", "duration", "seeds", "grid", "set", "timeout_s")
#: Grid keys that start with this set tree parameters (``tree.NODE.PARAM``).
TREE_PREFIX = "tree."
#: Columns every row has, before the grid keys' (``run_id``, ``scene``) and after them.
LEAD = ("run_id", "scene")
RUN_COLUMNS = ("seed", "status", "reason", "sim_time_s", "wall_time_s", "real_time_factor", "ticks", "contacts",
               "rate_hz", "warnings")
#: Sections of the report flattened into ``section.key`` columns.
SECTIONS = ("metrics", "path_error_m", "path_error_cop_m", "reconstruction")
#: Report figures that are settings, not outcomes: in the table, not in the plot.
NOT_PLOTTED = (".band", ".window_s")
RESULTS = "results.csv"
SUMMARY_PNG = "summary.png"
MAX_PLOTTED = 24


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


def _split(assignments) -> tuple[list[str], dict[str, Any]]:
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
    fixed_over, fixed_params = _split(spec.fixed)
    for key, value in spec.fixed:
        over, params = _split([(key, value)])
        if params:
            located_at(fixed_locs[key], f"set: {key}", lambda: tree(params))
        for label, file in spec.scenes:
            if over:
                located_at(fixed_locs[key], f"set: {key} on {label}", lambda: scene(file, over))
    for key, values in spec.grid:
        for i, value in enumerate(values):
            over, params = _split([(key, value)])
            loc = grid_locs[key].value[i]
            if params:
                located_at(loc, f"grid: {key}={value!r}", lambda: tree({**fixed_params, **params}))
            for label, file in spec.scenes:
                if over:
                    located_at(loc, f"grid: {key}={value!r} on {label}", lambda: scene(file, fixed_over + over))
    grid_loc = grid_locs[spec.grid_keys[0]] if spec.grid else root
    for combo in spec.combinations():
        over, params = _split(spec.fixed + combo)
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


# --------------------------------------------------------------------------- runs
@dataclass(frozen=True)
class Run:
    """One mission of a sweep: small and picklable, for any executor."""

    run_id: str
    tree: str                                  # absolute path
    scene: str                                 # absolute path
    scene_label: str
    values: tuple[tuple[str, Any], ...]        # the grid's key → value of this run
    overrides: tuple[str, ...]                 # scene overrides, ``key=value`` (as --set)
    params: tuple[tuple[str, Any], ...]        # tree parameters, ``NODE.PARAM`` → value (as --param)
    seed: int
    duration: float | None
    timeout_s: float | None = None
    out: str | None = None                     # per-run outputs (``--keep-runs``)
    digests: tuple[str, str] = ("", "")        # sha256 of the tree's and the scene's file
    plugins: tuple[str, ...] = ()              # ``--plugin`` modules the worker imports first


def _digest(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def plan(spec: SweepSpec, out: str | Path | None = None, keep_runs: bool = False,
         plugins: tuple[str, ...] = ()) -> list[Run]:
    """Every run of the spec, scene by scene, grid combination by combination, seed by seed.

    The run id hashes what decides the run's outcome: the tree's and scene's content (and the
    labels the spec gives them), the overrides, the seed and the duration; not the timeout, the
    output folder or the executor. (A file the tree includes is not hashed: after editing one,
    use another ``--out``.)"""
    tree_digest = _digest(spec.tree)
    runs = []
    for label, file in spec.scenes:
        scene_digest = _digest(file)
        for combo in spec.combinations():
            overrides, params = _split(spec.fixed + combo)
            for seed in spec.seeds:
                ident = json.dumps({"tree": spec.tree_label, "tree_sha256": tree_digest, "scene": label,
                                    "scene_sha256": scene_digest, "set": overrides,
                                    "params": sorted(params.items()), "seed": seed, "duration": spec.duration},
                                   sort_keys=True, default=str)
                run_id = hashlib.sha256(ident.encode()).hexdigest()[:16]
                runs.append(Run(run_id=run_id, tree=spec.tree, scene=file, scene_label=label, values=combo,
                                overrides=tuple(overrides), params=tuple(params.items()), seed=seed,
                                duration=spec.duration, timeout_s=spec.timeout_s,
                                out=str(Path(out) / "runs" / run_id) if keep_runs and out is not None else None,
                                digests=(tree_digest, scene_digest), plugins=tuple(plugins)))
    return runs


class RunTimeout(Exception):
    """A run went past its spec's ``timeout_s`` of wall time."""


def _deadline(timeout_s: float) -> Callable[[float, float], None]:
    """A mission progress callback that raises :class:`RunTimeout` past ``timeout_s`` of wall time
    (it is called about 20 times per mission second, from inside the control loop)."""
    started = time.perf_counter()

    def check(t: float, duration: float) -> None:
        if time.perf_counter() - started > timeout_s:
            raise RunTimeout(f"timed out: more than timeout_s = {timeout_s:g} s of wall time "
                             f"(at {t:.2f} s of {duration:g} s of mission time)")

    return check


def _flat(prefix: str, value: Any, out: dict) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flat(f"{prefix}.{k}", v, out)
    elif isinstance(value, (list, tuple)):
        out[prefix] = json.dumps(list(value), default=float)
    else:
        out[prefix] = value


def flatten_report(report: dict) -> dict:
    """The report's outcome as flat columns: ``status``, ``reason``, times, ``ticks``, and every
    figure of ``metrics``, ``path_error_m``, ``path_error_cop_m`` and ``reconstruction`` as
    ``section.name[.field]`` (``metrics.pressure_pa.std``, ``path_error_m.mean``, ...)."""
    out = {k: report.get(k) for k in RUN_COLUMNS if k in report}
    out["warnings"] = "; ".join(report.get("warnings") or [])
    for section in SECTIONS:
        if report.get(section):
            _flat(section, report[section], out)
    return out


#: Suffix of the column that keeps a grid value as the spec wrote it, beside its SI number.
AS_WRITTEN = " (as written)"


def si_value(key: str, value: Any) -> Any:
    """A grid value as its SI number (``"2.5 kPa"`` → 2500.0; degrees for the scene's ``*_deg``
    keys), for the table and the plots; :func:`tactile_bt.units.to_si`."""
    return to_si(value, degrees=key.endswith("_deg"))


def written_columns(spec: SweepSpec) -> list[str]:
    """The ``KEY (as written)`` columns: one per grid key that has a value written with a unit."""
    return [f"{key}{AS_WRITTEN}" for key, values in spec.grid if any(si_value(key, v) != v for v in values)]


def _lead(run: Run) -> dict:
    values = {key: si_value(key, v) for key, v in run.values}
    written = {f"{key}{AS_WRITTEN}": v for key, v in run.values if values[key] != v}
    return {"run_id": run.run_id, "scene": run.scene_label, **values, **written, "seed": run.seed}


def execute(run: Run) -> dict:
    """Run one mission (in this process, or on a worker); its row. Every exception of the
    mission becomes a row with ``status`` ``error`` and the message (Ctrl-C still stops)."""
    from tactile_bt.mission.run import run_mission
    from tactile_bt.tree.registry import import_plugin

    row = _lead(run)
    started = time.perf_counter()
    try:
        for plugin in run.plugins:
            import_plugin(plugin)
        for path, digest, what in ((run.tree, run.digests[0], "tree"), (run.scene, run.digests[1], "scene")):
            if digest and _digest(path) != digest:
                raise TactileBtError(f"the {what} file {path} on this worker differs from the one the sweep was "
                                     "planned with (workers need the same files at the same paths)")
        result = run_mission(run.tree, run.scene, duration=run.duration, seed=run.seed,
                             overrides=list(run.overrides), params=dict(run.params) or None, out=run.out,
                             progress=_deadline(run.timeout_s) if run.timeout_s else None)
    except Exception as exc:
        message = str(exc) if isinstance(exc, (RunTimeout, TactileBtError)) else f"{type(exc).__name__}: {exc}"
        row.update(status="error", reason=message, wall_time_s=time.perf_counter() - started)
        return row
    row.update(flatten_report(result.summary.to_dict()))
    return row


def error_row(run: Run, exc: BaseException) -> dict:
    """The row of a run whose worker raised outside :func:`execute` (a worker that died twice, a
    worker that cannot unpickle the run)."""
    name = type(exc).__name__
    message = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return {**_lead(run), "status": "error", "reason": f"{name}: {message}" if message else name}


# --------------------------------------------------------------------------- the table
def _cell(value: Any) -> str:
    """A CSV cell: floats round-trip exactly (``repr``), NaN is ``nan``, nothing is empty."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (int, str)):
        return str(value)
    if hasattr(value, "item"):  # a numpy scalar
        return _cell(value.item())
    return json.dumps(value, default=float)


class ResultsTable:
    """``results.csv`` of a sweep: read back on a rerun, one line appended (and flushed to disk)
    per finished run, rewritten (atomically) only when a row brings new columns and at the end,
    in the spec's order. A last line torn by a crash is dropped when the table is read."""

    def __init__(self, path: str | Path, lead: list[str]) -> None:
        self.path = Path(path)
        self.columns: list[str] = list(dict.fromkeys([*lead, *RUN_COLUMNS]))
        self.rows: dict[str, dict[str, str]] = {}
        self.torn = False

    def load(self) -> dict[str, dict[str, str]]:
        """The rows already in the file (the last of any run id wins), by run id."""
        if not self.path.exists():
            return {}
        text = self.path.read_text(encoding="utf-8")
        if text and not text.endswith("\n"):  # a line torn by a crash
            text = text[: text.rfind("\n") + 1]
            self.torn = True
        reader = csv.DictReader(io.StringIO(text))
        header = reader.fieldnames or []
        if text and "run_id" not in header:
            raise OutputPathError(f"{self.path} is not the table of a sweep (it has no run_id column); "
                                  "choose another --out")
        self.columns = list(dict.fromkeys([*self.columns, *header]))
        for row in reader:
            if row.get("run_id"):
                self.rows[row["run_id"]] = {k: v for k, v in row.items() if k is not None and v is not None}
        if self.torn:
            self._rewrite(list(self.rows))
        return dict(self.rows)

    def add(self, row: dict) -> None:
        """Append one row (new columns rewrite the file with the wider header)."""
        cells = {k: _cell(v) for k, v in row.items()}
        self.rows[cells["run_id"]] = cells
        new = [k for k in cells if k not in self.columns]
        if new or not self.path.exists():
            self.columns += new
            self._rewrite(list(self.rows))
            return
        with open(self.path, "a", encoding="utf-8", newline="") as f:
            f.write(self._line(cells))
            f.flush()
            os.fsync(f.fileno())

    def _line(self, cells: dict) -> str:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow([cells.get(c, "") for c in self.columns])
        return buf.getvalue()

    def _rewrite(self, order: list[str]) -> None:
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", encoding="utf-8", newline="") as f:
            csv.writer(f, lineterminator="\n").writerow(self.columns)
            for run_id in order:
                f.write(self._line(self.rows[run_id]))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)

    def finish(self, order: list[str]) -> None:
        """Rewrite in ``order`` (the spec's), rows of other runs after them."""
        rest = [k for k in self.rows if k not in set(order)]
        self._rewrite([k for k in order if k in self.rows] + rest)


# --------------------------------------------------------------------------- the sweep
@dataclass
class SweepResult:
    """What :func:`run_sweep` did."""

    spec: SweepSpec
    runs: list[Run]
    rows: list[dict[str, str]]          # the spec's runs that have a row, in the spec's order
    ran: int = 0
    skipped: int = 0
    errors: int = 0                     # error rows among ``rows``
    lost: int = 0                       # runs the cluster lost without a result (not in the table)
    other_rows: int = 0                 # rows of runs no longer in the spec (kept in the table)
    table: Path | None = None
    plot: Path | None = None
    executor: str = ""
    wall_time_s: float = 0.0
    notes: list[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        return len(self.rows) == len(self.runs)


def _check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise OutputPathError(f"--out {out} is a file, not a directory")
    blocker = next((p for p in out.parents if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        raise OutputPathError(f"--out {out}: cannot create the folder, {blocker} is a file")
    out.mkdir(parents=True, exist_ok=True)
    if not os.access(out, os.W_OK | os.X_OK):
        raise OutputPathError(f"--out {out} is not writable")


def run_sweep(spec: SweepSpec | str | Path, out: str | Path, executor=None, keep_runs: bool = False,
              retry_errors: bool = False, progress: Callable[..., None] | None = None,
              on_start: Callable[[int, int, str], None] | None = None, plugins: tuple[str, ...] = ()) -> SweepResult:
    """Run every run of ``spec`` not yet in ``out/results.csv`` on ``executor`` (default: this
    process) and append its row as it finishes; then the table in the spec's order and the plot.

    ``executor`` is an :class:`~tactile_bt.experiments.executors.Executor`, or a function that
    makes one (called only when there is something to run, and closed at the end).

    ``retry_errors`` runs the error rows again. ``progress(done, total, note=...)`` is called as
    runs finish (a :class:`tactile_bt.progress.Progress` fits); ``on_start(to_run, skipped,
    executor_label)`` before the first run. ``plugins`` (``--plugin`` modules: names or absolute
    paths of ``.py`` files) are imported by every run before its tree is built. Ctrl-C
    (KeyboardInterrupt) propagates after the finished rows are on disk."""
    from tactile_bt.experiments.executors import Executor, InProcess

    started = time.perf_counter()
    if not isinstance(spec, SweepSpec):
        spec = load_spec(spec)
    out = Path(out)
    _check_out(out)
    runs = plan(spec, out, keep_runs, plugins)
    table = ResultsTable(out / RESULTS, [*LEAD, *spec.grid_keys, *written_columns(spec)])
    existing = table.load()
    done = {k for k, row in existing.items() if not (retry_errors and row.get("status") == "error")}
    todo = [r for r in runs if r.run_id not in done]
    result = SweepResult(spec=spec, runs=runs, rows=[], skipped=len(runs) - len(todo), table=table.path)
    if table.torn:
        result.notes.append(f"dropped a torn last line of {table.path} (a run cut short by a crash)")
    if todo:
        owned = executor is not None and not isinstance(executor, Executor)
        executor = executor() if owned else (executor or InProcess())
        try:
            result.executor = executor.label
            if on_start is not None:
                on_start(len(todo), result.skipped, executor.label)
            _collect(executor, todo, table, result, progress)
        finally:
            if owned:
                executor.close()
    elif on_start is not None:
        on_start(0, result.skipped, "")
    order = [r.run_id for r in runs]
    table.finish(order)
    mine = set(order)
    result.rows = [table.rows[k] for k in order if k in table.rows]
    result.other_rows = sum(k not in mine for k in table.rows)
    result.errors = sum(r.get("status") == "error" for r in result.rows)
    result.plot = plot_summary(spec, runs, result.rows, out / SUMMARY_PNG)
    result.wall_time_s = time.perf_counter() - started
    return result


def _collect(executor, todo: list[Run], table: ResultsTable, result: SweepResult, progress) -> None:
    """Append the row of every run of ``todo`` as it finishes on ``executor``."""
    from tactile_bt.experiments.executors import LostRunError

    failed = 0
    for n, (i, row, exc) in enumerate(executor.run(execute, todo), 1):
        run = todo[i]
        if isinstance(exc, LostRunError):
            result.lost += 1
        else:
            if exc is not None:
                row = error_row(run, exc)
            table.add(row)
            result.ran += 1
            failed += row.get("status") == "error"
        if progress is not None:
            lost = f", {result.lost} lost" if result.lost else ""
            progress(n, len(todo), note=f"{failed} failed{lost}, {len(todo) - n} to go")


# --------------------------------------------------------------------------- summary
def metric_columns(rows: list[dict[str, str]], plotted: bool = False) -> list[str]:
    """The columns of report figures (``metrics.*``, ``path_error_m.*``, ...) that hold a number
    in some row; ``plotted`` leaves out the settings (``band``, ``window_s``)."""
    columns: dict[str, None] = {}
    for row in rows:
        for k, v in row.items():
            if k.split(".", 1)[0] in SECTIONS and "." in k and _float(v) is not None:
                if not (plotted and k.endswith(NOT_PLOTTED)):
                    columns[k] = None
    return list(columns)


def _float(text: Any) -> float | None:
    if text is None or text == "":
        return None
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def _x_key(spec: SweepSpec) -> str | None:
    """The grid key along the plots' x axis: the numeric one with the most values."""
    numeric = [(len(v), k) for k, v in spec.grid
               if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (si_value(k, u) for u in v))]
    if numeric:
        return max(numeric, key=lambda p: p[0])[1]
    return spec.grid_keys[0] if spec.grid else None


def plot_summary(spec: SweepSpec, runs: list[Run], rows: list[dict[str, str]], path: str | Path) -> Path | None:
    """Every metric against the grid values: the seeds as dots, their mean as a line, one line per
    scene and combination of the other grid keys. None when no run has a metric."""
    columns = metric_columns(rows, plotted=True)[:MAX_PLOTTED]
    if not columns:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    by_id = {r.run_id: r for r in runs}
    x_key = _x_key(spec)
    x_values = [si_value(x_key, v) for v in dict(spec.grid)[x_key]] if x_key else [label for label, _ in spec.scenes]
    numeric_x = x_key is not None and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in x_values)
    log_x = numeric_x and min(x_values) > 0 and max(x_values) / min(x_values) >= 100

    def position(run: Run) -> float:
        x = si_value(x_key, dict(run.values)[x_key]) if x_key else run.scene_label
        return float(x) if numeric_x else float(x_values.index(x))

    def series(run: Run) -> str:
        parts = [] if x_key is None else [run.scene_label] * (len(spec.scenes) > 1)
        parts += [f"{k}={format_value(v)}" for k, v in run.values if k != x_key]
        return ", ".join(parts)

    groups: dict[str, list[tuple[Run, dict]]] = {}
    for row in rows:
        run = by_id.get(row["run_id"])
        if run is not None and row.get("status") != "error":
            groups.setdefault(series(run), []).append((run, row))
    ncols = min(3, len(columns))
    nrows = math.ceil(len(columns) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.0 * nrows), squeeze=False, constrained_layout=True)
    for ax, column in zip(axes.flat, columns):
        for colour, (name, members) in enumerate(groups.items()):
            xs = np.array([position(run) for run, _ in members])
            ys = np.array([_float(row.get(column)) if _float(row.get(column)) is not None else np.nan
                           for _, row in members])
            c = f"C{colour % 10}"
            ax.plot(xs, ys, "o", color=c, alpha=0.35, ms=4)
            ux = np.unique(xs)
            means = [np.nanmean(ys[xs == u]) if np.isfinite(ys[xs == u]).any() else np.nan for u in ux]
            ax.plot(ux, means, "-", color=c, lw=1.4, label=name or None)
        ax.set_title(column, fontsize=9)
        if log_x:
            ax.set_xscale("log")
        if not numeric_x:
            ax.set_xticks(range(len(x_values)), [format_value(x) for x in x_values], fontsize=8,
                          rotation=20 if len(x_values) > 3 else 0)
        ax.set_xlabel(x_key or "scene", fontsize=8)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(columns):]:
        ax.set_visible(False)
    if any(name for name in groups):
        axes.flat[0].legend(fontsize=7)
    seeds = len(spec.seeds)
    fig.suptitle(f"{spec.name}: {spec.tree_label}, {seeds} seed{'s' if seeds != 1 else ''} per point "
                 "(dots: seeds, line: mean)", fontsize=10)
    path = Path(path)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def format_summary(result: SweepResult, max_metrics: int = 4) -> str:
    """A table per scene and grid combination: runs, errors and the mean of a few metrics over the
    seeds (all of them are in ``results.csv``)."""
    spec = result.spec
    by_id = {r.run_id: r for r in result.runs}
    preferred = [c for c in metric_columns(result.rows, plotted=True)
                 if c.endswith((".steady_state_error", ".std", ".mean", ".coverage", ".chamfer_m"))]
    shown = preferred[:max_metrics]
    keys = spec.grid_keys
    head = ["scene", *keys, "runs", "errors", *shown]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    groups: dict[str, tuple[Run, list[dict]]] = {}
    for row in result.rows:
        run = by_id[row["run_id"]]
        key = json.dumps([run.scene_label, run.values], default=str)  # values may be lists
        groups.setdefault(key, (run, []))[1].append(row)
    for run, members in groups.values():
        cells = [run.scene_label, *(format_value(v) for _, v in run.values), str(len(members)),
                 str(sum(m.get("status") == "error" for m in members))]
        for column in shown:
            numbers = [_float(m.get(column)) for m in members]
            numbers = [x for x in numbers if x is not None and math.isfinite(x)]
            cells.append(f"{sum(numbers) / len(numbers):.4g}" if numbers else "–")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
