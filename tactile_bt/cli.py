"""The ``tactile-bt`` command line."""

from __future__ import annotations

import argparse
import atexit
import json
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

from tactile_bt.arguments import (OneLineParser, check_output, check_output_dir, nonnegative_int, one_line_warnings,
                                  positive_float, positive_int)
from tactile_bt.errors import MissionInterrupted, TactileBtError

__all__ = ["main", "console"]


def _load_plugins(args) -> tuple[str, ...]:
    """Import the ``--plugin`` modules (before any tree is read); return them as a worker imports
    them (files as absolute paths)."""
    from tactile_bt.tree.registry import import_plugin, load_entry_points

    load_entry_points()
    return tuple(import_plugin(spec) for spec in getattr(args, "plugin", None) or ())


def _shipped(given: str) -> str:
    """``given``, or the shipped file it names where no such file is here (with a note)."""
    from tactile_bt import shipped

    found = shipped.resolve(given)
    if str(found) != str(given):
        _note(f"{given}: using the file that ships with tactile_bt, {found} "
              "('tactile-bt examples --copy DIR' makes copies to edit)")
    return str(found)


def _cmd_run(args) -> int:
    from tactile_bt.sim import warmup

    warmup.start()  # first, so a cold kernel cache compiles while the rest is imported
    from tactile_bt.mission.run import calibration_path, run_mission

    _load_plugins(args)

    if args.record is not None:  # before the mission: never overwrite a file unasked
        check_output(args.record, args.force)
        check_output(calibration_path(args.record), args.force)
    from tactile_bt.progress import Progress

    watchers = _watchers(args)
    progress = Progress(args.duration or 0.0, unit="s", label="mission time")
    try:
        result = run_mission(_shipped(args.tree), _shipped(args.scene), duration=args.duration, seed=args.seed,
                             overrides=args.set, out=args.out, progress=progress,
                             orientation_method=args.orientation, via_emulator=args.via_emulator,
                             recording=args.record, reconstruct=args.reconstruct,
                             params=args.param, blackboard=args.blackboard, watchers=watchers)
    finally:
        progress.close()
    r = result.summary
    print(f"{r.status}{': ' + r.reason if r.reason else ''} after {r.sim_time_s:.2f} s "
          f"({r.ticks} ticks, {r.real_time_factor:.1f}x real time)")
    print("\n".join(r.summary_lines()))
    for warning in r.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    print(f"  outputs in {args.out}")
    _watched(args)
    return 0 if r.ok else 1


def _terminate_as_interrupt() -> None:
    """SIGTERM ends the command the way Ctrl-C does (outputs written, the robot's last twist zero)."""
    import signal

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupt)


def _cmd_live(args) -> int:
    from tactile_bt.mission.live import run_live
    from tactile_bt.progress import Progress

    _load_plugins(args)
    if args.record is not None:
        from tactile_bt.mission.run import calibration_path

        check_output(args.record, args.force)
        check_output(calibration_path(args.record), args.force)
    watchers = _watchers(args)
    _terminate_as_interrupt()
    progress = Progress(args.duration or 0.0, unit="s", label="mission time")
    try:
        result = run_live(_shipped(args.tree), args.sensor, args.robot, duration=args.duration, out=args.out,
                          truth=_shipped(args.truth) if args.truth else None, record=args.record,
                          module=args.module, orientation_method=args.orientation, progress=progress,
                          watchers=watchers)
    finally:
        progress.close()
    r = result.summary
    print(f"{r.status}{': ' + r.reason if r.reason else ''} after {r.sim_time_s:.2f} s ({r.ticks} cycles)")
    print("\n".join(r.summary_lines()))
    for warning in r.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    print(f"  outputs in {args.out}")
    _watched(args)
    return 0 if r.ok else 1


def _cmd_twin(args) -> int:
    import signal
    import threading

    from tactile_bt.mission.twin import serve_twin, twin_summary

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    out = check_output_dir(args.out)
    result = serve_twin(_shipped(args.scene), out, seed=args.seed, duration=args.duration, module=args.module,
                        stall_after_s=args.stall_after, stop=stop, network=args.network,
                        announce=lambda port: print(port, flush=True))
    print(twin_summary(result), file=sys.stderr)
    return 0


def _cmd_replay(args) -> int:
    from tactile_bt.mission.replay import replay_mission

    _load_plugins(args)
    watchers = _watchers(args)
    try:
        with one_line_warnings():
            result = replay_mission(_shipped(args.tree), args.recording, calibration=args.calibration, speed=args.speed,
                                    orientation_method=args.orientation, out=args.out, watchers=watchers)
    except OSError as exc:  # an unreadable recording or calibration file
        print(f"error: {exc}", file=sys.stderr)
        return 2
    r = result.summary
    print(f"{r.status}{': ' + r.reason if r.reason else ''} after {r.ticks} frames "
          f"({r.real_time_factor:.1f}x the recorded pace)")
    print("\n".join(r.summary_lines()))
    if args.out:
        print(f"  outputs in {args.out}")
    _watched(args)
    return 0 if r.ok else 1


def _watch_options(parser: argparse.ArgumentParser) -> None:
    """``--rerun FILE.rrd``, ``--rerun-spawn``, ``--rerun-rate HZ``: the options of every command
    that runs a mission (``run``, ``replay``; ``live`` takes the same)."""
    parser.add_argument("--rerun", default=None, metavar="FILE.rrd",
                        help="log the force image, features, pad, contacts and node status to a rerun recording "
                             "(needs the [viewer] extra; see docs/watching.md)")
    parser.add_argument("--rerun-spawn", action="store_true",
                        help="also open the rerun viewer and stream to it (run 'rerun analytics disable' once first)")
    parser.add_argument("--rerun-rate", type=positive_float, default=None, metavar="HZ",
                        help="rate of the logged images, features and pad pose in Hz of mission time (default: 50)")


def _watchers(args) -> list:
    """The watchers the ``--rerun`` options ask for, made before the mission (a missing rerun-sdk
    or an unwritable file is an error before any work)."""
    if args.rerun is None and not args.rerun_spawn:
        return []
    from tactile_bt import defaults
    from tactile_bt.mission.recording_rerun import RerunRecorder

    if args.rerun is not None:
        check_output(args.rerun, force=True, option="--rerun", create_parent=True)
    rate = args.rerun_rate if args.rerun_rate is not None else defaults.RERUN_RATE_HZ
    return [RerunRecorder(args.rerun, spawn=args.rerun_spawn, rate_hz=rate)]


def _watched(args) -> None:
    if args.rerun is not None:
        print(f"  rerun recording in {args.rerun}")


def _cmd_tree(args) -> int:
    import py_trees

    from tactile_bt.tree.loader import format_parameters, load_tree

    if args.dot:  # before any work
        check_output(args.dot, force=True, option="--dot", create_parent=True)
    _load_plugins(args)
    tree = load_tree(_shipped(args.tree), params=args.param)
    print(py_trees.display.unicode_tree(tree.root))
    if args.params:
        print(format_parameters(tree))
    if args.dot:
        dot = py_trees.display.dot_tree(tree.root)
        Path(args.dot).write_text(dot.to_string())
        print(f"dot graph written to {args.dot}")
    return 0


def _cmd_view(args) -> int:
    from tactile_bt.mission.view import render_mission

    if args.png:  # before any work
        check_output(args.png, force=True, option="--png", create_parent=True)
    png = render_mission(Path(args.dir), args.png, color_by=args.color_by)
    if png is not None:
        print(f"rendered {png}")
    return 0


def _cmd_bench(args) -> int:
    from tactile_bt.experiments.bench import run_bench

    figures = run_bench(quick=args.quick)
    if args.json:
        print(json.dumps(figures, indent=2))
    else:
        from tactile_bt.experiments.bench import format_bench

        print(format_bench(figures))
    return 0


def _cmd_examples(args) -> int:
    from tactile_bt import shipped

    if args.copy:
        try:
            written = shipped.copy_to(args.copy, force=args.force)
        except FileExistsError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        print(f"copied {len(written)} files to {args.copy}: " + ", ".join(
            f"{args.copy}/{folder}/" for folder in shipped.FOLDERS if (Path(args.copy) / folder).is_dir()))
        print(f"  e.g. tactile-bt run {args.copy}/trees/cable_follow.yaml --scene {args.copy}/sim/cable.yaml --out out/cable")
        return 0
    files = shipped.listing()
    print(f"tactile_bt ships these files (in {shipped.root()}); a command given a relative path such as "
          "sim/cable.yaml uses them where no such file is in the current folder:")
    folder = None
    for f in files:
        top = f.relative.split("/", 1)[0]
        if top != folder:
            folder = top
            print(f"\n{folder}/  {shipped.FOLDERS[folder]}")
        print(f"  {f.relative:<40} {f.summary if len(f.summary) <= 90 else f.summary[:89] + '…'}")
    print("\n'tactile-bt examples --copy DIR' copies them all into DIR to edit.")
    return 0


def _cmd_compare(args) -> int:
    from tactile_bt.experiments.compare import write_compare

    md, png = write_compare(args.dirs, args.out)
    print(md.read_text().split("\n## ")[0].rstrip())
    print(f"written: {md}, {png}")
    return 0


def _note(message: str) -> None:
    print(f"note: {message}", file=sys.stderr)


def _executor(args):
    """A function that starts the executor of ``--workers`` / ``--scheduler``."""
    from tactile_bt.experiments.executors import make_executor

    return lambda: make_executor(args.workers, args.scheduler, note=_note)


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


def _cmd_paper(args) -> int:
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


def _cmd_stability(args) -> int:
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


def _cmd_sweep(args) -> int:
    from tactile_bt.experiments.sweep import RESULTS, format_summary, load_spec, run_sweep
    from tactile_bt.progress import Progress

    plugins = _load_plugins(args)
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
    for note in result.notes:
        print(f"note: {note}", file=sys.stderr)
    if result.other_rows:
        print(f"note: {result.table} also holds {result.other_rows} rows of runs this spec no longer has "
              "(the spec or its files changed); they are kept and left out of the summary", file=sys.stderr)
    written = [str(result.table)] + ([str(result.plot)] if result.plot else [])
    if args.keep_runs:
        written.append(f"{out / 'runs'}/")
    print(f"written: {', '.join(written)} in {result.wall_time_s:.0f} s")
    return 0 if not result.errors and not result.lost else 1


def _cmd_accuracy(args) -> int:
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


def _scheduler_address(text: str) -> str:
    from tactile_bt.experiments.executors import check_scheduler_address

    try:
        return check_scheduler_address(text)
    except TactileBtError as exc:
        raise argparse.ArgumentTypeError(str(exc).split(": ", 1)[1]) from None


def _executor_options(parser: argparse.ArgumentParser) -> None:
    """``--workers N`` | ``--scheduler ADDRESS`` of the studies."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=positive_int, default=None, metavar="N",
                       help="1: run in this process; N: a local Dask cluster of N processes (default: one per "
                            "core; in this process when Dask is not installed)")
    group.add_argument("--scheduler", type=_scheduler_address, default=None, metavar="ADDRESS",
                       help="run on a running Dask cluster, e.g. tcp://127.0.0.1:8786 ('dask scheduler' and "
                            "'dask worker ADDRESS --nthreads 1' on each machine; they need tactile_bt and the "
                            "same files at the same paths)")


def _orientation_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--orientation", choices=("moments", "hough"), default="moments",
                        help="edge orientation method (default: moments)")


def _record_options(parser: argparse.ArgumentParser) -> None:
    """``--record FILE`` (frames and poses for ``replay``) and ``--force``, of ``run`` and ``live``."""
    parser.add_argument("--record", default=None, metavar="FILE",
                        help="record frames and poses (chunked, crash-safe) and FILE.calibration.npz, for "
                             "'tactile-bt replay'")
    parser.add_argument("--force", action="store_true",
                        help="overwrite an existing --record FILE and its FILE.calibration.npz")


def _mission_options(parser: argparse.ArgumentParser) -> None:
    """The options ``run`` and ``live`` share: orientation method, recording, plugins, watching."""
    _orientation_option(parser)
    _record_options(parser)
    _plugin_option(parser)
    _watch_options(parser)


def _plugin_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import MODULE (a module name, or the path of a .py file) first, so that the node "
                             "types it registers can be used in the tree (repeatable; installed plugins declare "
                             "the entry-point group tactile_bt.behaviours and need no option)")


def build_parser() -> argparse.ArgumentParser:
    from tactile_bt import __version__

    parser = OneLineParser(prog="tactile-bt", description="Tactile servoing with behaviour trees.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a tree against a simulated scene")
    run.add_argument("tree", help="YAML tree file")
    run.add_argument("--scene", required=True, help="YAML scene file")
    run.add_argument("--duration", type=positive_float, default=None,
                     help="mission time budget in s, > 0 (default: the scene's duration_s)")
    run.add_argument("--seed", type=nonnegative_int, default=None, help="random seed, >= 0 (default: the scene's)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. objects.1.stiffness=1e5 (repeatable)")
    run.add_argument("--via-emulator", action="store_true",
                     help="carry every frame through the device emulator, a pty and the serial driver")
    run.add_argument("--reconstruct", default=None, choices=("auto", "delaunay", "surface", "hull", "none"),
                     help="reconstruct a surface from the contacts, or 'none' (default: as the tree's "
                          "record_contacts says)")
    run.add_argument("--param", action="append", default=[], metavar="NODE.PARAM=VALUE",
                     help="set a tree parameter, e.g. force_hold.target_pa='1.5 kPa' (NODE: a node's name as "
                          "'tactile-bt tree' shows it, or its type; repeatable)")
    run.add_argument("--blackboard", action="append", default=[], metavar="KEY=VALUE",
                     help="set a blackboard key the tree reads before it starts, e.g. /goal/pressure=1800 (repeatable)")
    run.add_argument("--out", required=True,
                     help="output directory; the outputs of an earlier run there are replaced")
    _mission_options(run)
    run.set_defaults(func=_cmd_run)

    live = sub.add_parser("live", help="run a tree on a real sensor and arm (or on 'tactile-bt twin'), paced by "
                                       "the sensor's frames")
    live.add_argument("tree", help="YAML tree file")
    live.add_argument("--sensor", required=True, metavar="PORT", help="the sensor's serial port (or the port the twin prints)")
    live.add_argument("--robot", required=True, metavar="ROBOT.yaml",
                      help="the robot file: backend and topics, sensor module and calibration, set-up, limits "
                           "(docs/live.md)")
    live.add_argument("--duration", type=positive_float, default=None,
                      help="mission time budget in s (default: until the tree ends, or Ctrl-C)")
    live.add_argument("--truth", default=None, metavar="SCENE",
                      help="score the contacts against this scene's ground truth (runs against the twin)")
    live.add_argument("--module", default=None, help="the sensor module (its cell order), overriding the robot file's")
    live.add_argument("--out", required=True, help="output directory")
    _mission_options(live)
    live.set_defaults(func=_cmd_live)

    twin = sub.add_parser("twin", help="serve a scene's simulator in real time as hardware: a ROS 2 arm and a "
                                       "serial pad on a pty")
    twin.add_argument("scene", help="YAML scene file")
    twin.add_argument("--out", required=True, help="where robot.yaml, calibration.npz and (at the end) twin.npz go")
    twin.add_argument("--seed", type=nonnegative_int, default=None, help="seed of the simulated sensor")
    twin.add_argument("--duration", type=positive_float, default=None, help="end after this long in s (default: "
                                                                            "at SIGINT or SIGTERM)")
    twin.add_argument("--module", default=None, help="the tactile module to emulate (its cell order)")
    twin.add_argument("--stall-after", type=positive_float, default=None, metavar="S",
                      help="fault injection: the sensor falls silent after S seconds")
    twin.add_argument("--network", action="store_true", help="let ROS 2 discover peers on the network "
                                                            "(default: this host only)")
    twin.set_defaults(func=_cmd_twin)

    replay = sub.add_parser("replay", help="run a tree on a recording's frames and poses "
                                           "('sensor replay' only prints the frames)")
    replay.add_argument("recording", metavar="RECORDING", help="a recording made by 'run --record' or 'sensor record'")
    replay.add_argument("--tree", required=True, help="YAML tree file")
    replay.add_argument("--calibration", default=None, metavar="FILE",
                        help="calibration .npz (default: RECORDING.calibration.npz, else the nominal one, with a warning)")
    replay.add_argument("--speed", type=positive_float, default=None,
                        help="1 = the recorded pace, 2 = twice as fast (default: as fast as possible)")
    replay.add_argument("--out", default=None, help="output directory")
    _orientation_option(replay)
    _plugin_option(replay)
    _watch_options(replay)
    replay.set_defaults(func=_cmd_replay)

    tree = sub.add_parser("tree", help="validate and print a YAML tree")
    tree.add_argument("tree", help="YAML tree file")
    tree.add_argument("--dot", default=None, metavar="FILE", help="also write a Graphviz dot file")
    tree.add_argument("--params", action="store_true",
                      help="also print every node's parameters: values in SI units, units and where they come from")
    tree.add_argument("--param", action="append", default=[], metavar="NODE.PARAM=VALUE",
                      help="set a parameter as 'run --param' does, to check it (repeatable)")
    _plugin_option(tree)
    tree.set_defaults(func=_cmd_tree)

    view = sub.add_parser("view", help="show a mission's contacts, path and scene in 3-D")
    view.add_argument("dir", help="output directory of 'tactile-bt run'")
    view.add_argument("--png", default=None, help="render off screen into this PNG instead of a window")
    view.add_argument("--color-by", default=None, choices=("time", "pressure"), help="colour of the contacts (default: time for scans, pressure otherwise)")
    view.set_defaults(func=_cmd_view)

    bench = sub.add_parser("bench", help="speed figures, as ratios measured in one run")
    bench.add_argument("--json", action="store_true", help="print JSON instead of a table")
    bench.add_argument("--quick", action="store_true", help="fewer repetitions (noisier figures)")
    bench.set_defaults(func=_cmd_bench)

    paper = sub.add_parser("paper", help="reproduce the paper's Tables I-III and Figs. 8-11 (20 trials each)")
    paper.add_argument("--trials", type=positive_int, default=20, help="seeded trials per experiment (default: 20)")
    paper.add_argument("--duration", type=positive_float, default=22.0,
                       help="mission time per trial in s (default: 22)")
    _executor_options(paper)
    paper.add_argument("--out", default="out/paper", help="output directory (default: out/paper)")
    paper.set_defaults(func=_cmd_paper)

    stab = sub.add_parser("stability", help="stiffness sweep, extreme cases and control rates")
    stab.add_argument("--out", default="out/stability", help="output directory (default: out/stability)")
    stab.add_argument("--no-rates", action="store_true", help="skip the cable mission at 100-1900 Hz")
    _executor_options(stab)
    stab.set_defaults(func=_cmd_stability)

    sweep = sub.add_parser("sweep", help="run a tree over scenes, seeds and a grid of overrides, here or on a "
                                         "Dask cluster")
    sweep.add_argument("spec", metavar="SPEC.yaml", help="the sweep: tree, scene(s), seeds, duration, grid "
                                                        "(see docs/studies.md)")
    sweep.add_argument("--out", required=True, metavar="DIR",
                       help="output directory: results.csv (one row per run), summary.png; a rerun skips "
                            "the runs already in DIR/results.csv")
    _executor_options(sweep)
    sweep.add_argument("--keep-runs", action="store_true",
                       help="also write each run's outputs (report.json, log.npz, errors.png) to DIR/runs/RUN_ID/")
    sweep.add_argument("--retry-errors", action="store_true",
                       help="run the runs whose row in DIR/results.csv is an error again")
    _plugin_option(sweep)
    sweep.set_defaults(func=_cmd_sweep)

    compare = sub.add_parser("compare", help="runs side by side: their reports (compare.md) and errors (compare.png)")
    compare.add_argument("dirs", nargs="+", metavar="DIR",
                         help="output directories of 'run' or 'replay'; a sweep's (with --keep-runs) counts as all "
                              "its runs")
    compare.add_argument("--out", required=True, metavar="DIR", help="where compare.md and compare.png go")
    compare.set_defaults(func=_cmd_compare)

    acc = sub.add_parser("accuracy", help="feature accuracy on synthetic contacts (paper Fig. 4)")
    acc.add_argument("--trials", type=positive_int, default=20, help="synthetic contacts per angle (default: 20)")
    acc.add_argument("--seed", type=nonnegative_int, default=0, help="random seed, >= 0 (default: 0)")
    acc.add_argument("--json", action="store_true", help="print JSON instead of tables")
    acc.add_argument("--png", default=None, help="also draw the comparison like the paper's Fig. 4")
    acc.set_defaults(func=_cmd_accuracy)

    examples = sub.add_parser("examples", help="list the trees, scenes and studies that ship with tactile_bt, "
                                                "or copy them to edit")
    examples.add_argument("--copy", default=None, metavar="DIR", help="copy every shipped file into DIR "
                                                                      "(DIR/trees, DIR/sim, DIR/studies)")
    examples.add_argument("--force", action="store_true", help="with --copy: overwrite files that exist in DIR")
    examples.set_defaults(func=_cmd_examples)

    try:
        from tactile_bt.sense.hardware.cli import add_sensor_subcommands
    except ImportError:
        pass
    else:
        add_sensor_subcommands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except TactileBtError as exc:  # bad input or set-up: one line, no traceback
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        where = f" {exc.describe()}" if isinstance(exc, MissionInterrupted) else ""  # what DIR holds now
        lead = "\n" if sys.stderr.isatty() else ""  # below a progress bar
        print(f"{lead}interrupted{where}", file=sys.stderr)
        return 130


def console() -> None:
    """The ``tactile-bt`` command: :func:`main`, then the process ends with its status.

    When nothing is left to finish (no thread but daemons, the exit handlers run, standard
    output and error flushed), the process ends without the interpreter's teardown, which
    finalises numba, VTK and matplotlib object by object: about 0.3 s of every command.
    Every output file is closed by then."""
    status = main()
    if all(thread.daemon or thread is threading.main_thread() for thread in threading.enumerate()):
        try:
            atexit._run_exitfuncs()  # what a normal exit runs first (progress bars, logging, ...)
            sys.stdout.flush()
            sys.stderr.flush()
        except Exception:  # e.g. a closed pipe: the normal exit reports it
            pass
        else:
            os._exit(status)
    sys.exit(status)


if __name__ == "__main__":
    console()
