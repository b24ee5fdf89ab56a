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
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from tactile_bt.errors import OutputPathError, TactileBtError
from tactile_bt.experiments.sweep_spec import SPEC_FIELDS, SweepSpec, load_spec, si_value, split_assignments
from tactile_bt.experiments.sweep_summary import SECTIONS, SUMMARY_PNG, format_summary, metric_columns, plot_summary

__all__ = ["SweepSpec", "Run", "SweepResult", "load_spec", "plan", "execute", "error_row", "flatten_report",
           "ResultsTable", "run_sweep", "plot_summary", "format_summary", "metric_columns", "RunTimeout",
           "SPEC_FIELDS"]

#: Columns every row has, before the grid keys' (``run_id``, ``scene``) and after them.
LEAD = ("run_id", "scene")
RUN_COLUMNS = ("seed", "status", "reason", "sim_time_s", "wall_time_s", "real_time_factor", "ticks", "contacts",
               "rate_hz", "warnings")
#: Sections of the report flattened into ``section.key`` columns.
RESULTS = "results.csv"


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
            overrides, params = split_assignments(spec.fixed + combo)
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


