"""The studies on many runs: ``paper``, ``stability``, ``sweep``, ``accuracy``.

Layer: the entry point (:mod:`tactile_bt.cli`).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from tactile_bt.arguments import (check_output, check_output_dir)
from tactile_bt.cli.common import load_plugins, note


def _executor(args):
    """A function that starts the executor of ``--workers`` / ``--scheduler``."""
    from tactile_bt.experiments.executors import make_executor

    return lambda: make_executor(args.workers, args.scheduler, note=note)


def _interrupted(what: str) -> int:
    lead = "\n" if sys.stderr.isatty() else ""  # below a progress bar
    print(f"{lead}interrupted: {what}", file=sys.stderr)
    return 130


def _study(args, label: str, run):
    """``run(executor, progress)`` on the executor that ``--workers``/``--scheduler`` choose, with
    a progress bar of its runs; returns what ``run`` returns."""
    from tactile_bt.progress import Progress

    start = _executor(args)
    progress = Progress(0, unit="runs", label=label)
    try:
        with start() as executor:
            return run(executor, lambda done, total: progress(done, total))
    finally:
        progress.close()


def cmd_paper(args) -> int:
    from tactile_bt.experiments.paper import EXPERIMENTS, format_tables, plot_roll, run_paper, run_roll, write_paper

    out = check_output_dir(args.out)  # before the runs: a path that cannot be written loses nothing

    def run(executor, progress):
        print(f"{len(EXPERIMENTS) * args.trials} runs on {executor.label}", file=sys.stderr)
        return run_paper(trials=args.trials, duration=args.duration, executor=executor, progress=progress)

    try:
        results = _study(args, "paper runs", run)
    except KeyboardInterrupt:
        return _interrupted("nothing was written")
    files = write_paper(results, out)
    files.append(plot_roll(run_roll(), out))
    print(format_tables(results))
    print("written: " + ", ".join(str(f) for f in files))
    return 0


def cmd_stability(args) -> int:
    from tactile_bt.experiments.stability import format_table, run_stability

    out = check_output_dir(args.out)  # before the runs: a path that cannot be written loses nothing
    started = time.perf_counter()

    def run(executor, progress):
        print(f"running on {executor.label}", file=sys.stderr)
        return run_stability(out, rates=not args.no_rates, executor=executor, progress=progress)

    try:
        results = _study(args, "stability runs", run)
    except KeyboardInterrupt:
        return _interrupted("nothing was written")
    print(format_table(results["cases"], results["rates"]))
    print(f"written to {args.out} in {time.perf_counter() - started:.0f} s")
    return 0 if all(r["ok"] for r in results["cases"]) else 1


def cmd_sweep(args) -> int:
    from tactile_bt.experiments.sweep import RESULTS, format_summary, load_spec, run_sweep
    from tactile_bt.progress import Progress

    plugins = load_plugins(args)
    spec = load_spec(args.spec)  # before anything runs: errors with file:line:column
    start = _executor(args)
    out = check_output_dir(args.out)
    progress = Progress(0, unit="runs", label="sweep")
    n_runs = len(spec.scenes) * len(spec.combinations()) * len(spec.seeds)

    def on_start(todo: int, skipped: int, label: str) -> None:
        if skipped:
            print(f"skipped {skipped} of {n_runs} runs: already in {out / RESULTS}"
                  + (" (--retry-errors runs the errors again)" if not args.retry_errors else ""), file=sys.stderr)
        if todo:
            print(f"{spec.name}: {todo} run{'s' if todo != 1 else ''} on {label}", file=sys.stderr)
        progress.total = float(todo)

    try:
        result = run_sweep(spec, out, executor=start, keep_runs=args.keep_runs, retry_errors=args.retry_errors,
                           progress=progress, on_start=on_start, plugins=plugins)
    except KeyboardInterrupt:
        progress.close()
        return _interrupted(f"the finished runs are in {out / RESULTS}; the same command goes on from there")
    finally:
        progress.close()
    print(format_summary(result))
    print(f"{len(result.runs)} runs: {result.ran} ran now, {result.skipped} skipped (already in {result.table}), "
          f"{result.errors} with errors" + (f", {result.lost} lost by the cluster (run again)" if result.lost else ""))
    for message in result.notes:
        print(f"note: {message}", file=sys.stderr)
    if result.other_rows:
        print(f"note: {result.table} also holds {result.other_rows} rows of runs this spec no longer has "
              "(the spec or its files changed); they are kept and left out of the summary", file=sys.stderr)
    written = [str(result.table)] + ([str(result.plot)] if result.plot else [])
    if args.keep_runs:
        written.append(f"{out / 'runs'}/")
    print(f"written: {', '.join(written)} in {result.wall_time_s:.0f} s")
    return 0 if not result.errors and not result.lost else 1


def cmd_accuracy(args) -> int:
    from tactile_bt.experiments.accuracy import cop_accuracy, orientation_comparison

    if args.png:  # before any work
        check_output(args.png, force=True, option="--png", create_parent=True)
    orientation = orientation_comparison(trials=args.trials, seed=args.seed)
    cop = cop_accuracy(trials=args.trials, seed=args.seed)
    if args.json:
        print(json.dumps({"orientation": orientation, "cop": cop}, indent=2, default=float))
    else:
        angles = orientation["angles_deg"]
        print(f"Orientation, mean absolute error (deg) over {orientation['trials']} line contacts per angle "
              f"(seed {args.seed}):\n")
        print("| method | " + " | ".join(f"{a:g}°" for a in angles) + " | worst frame |")
        print("|---" * (len(angles) + 2) + "|")
        for method in ("moments", "hough"):
            row = " | ".join(f"{e:.2f}" for e in orientation[method])
            print(f"| {method} | {row} | {orientation[method + '_max']:.2f} |")
        print(f"\nCentre of pressure, RMS error (tactels): lines {cop['line_rms_px']:.3f} "
              f"(max {cop['line_max_px']:.3f}), blobs {cop['blob_rms_px']:.3f} (max {cop['blob_max_px']:.3f})")
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        angles = np.asarray(orientation["angles_deg"])
        x = np.arange(len(angles))
        fig, ax = plt.subplots(figsize=(7, 3.5), constrained_layout=True)
        ax.bar(x - 0.2, orientation["hough"], 0.4, label="Hough", color="C2")
        ax.bar(x + 0.2, orientation["moments"], 0.4, label="image moments", color="C3")
        ax.set_xticks(x, [f"{a:g}" for a in angles])
        ax.set_xlabel("line angle (deg)")
        ax.set_ylabel("abs. error (deg)")
        ax.set_title("Orientation error on simulated line contacts (cf. paper Fig. 4)", fontsize=10)
        ax.legend()
        fig.savefig(args.png, dpi=110)
        print(f"figure written to {args.png}")
    return 0

