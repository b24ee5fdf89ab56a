"""The ``tactile-bt`` argument parser: every command, its options and their checks.

Layer: the entry point (:mod:`tactile_bt.cli`).
"""

from __future__ import annotations

import argparse


from tactile_bt.arguments import (OneLineParser, nonnegative_int, positive_float, positive_int)
from tactile_bt.errors import TactileBtError
from tactile_bt.cli.missions import cmd_live, cmd_replay, cmd_run, cmd_twin
from tactile_bt.cli.studies import cmd_accuracy, cmd_paper, cmd_stability, cmd_sweep
from tactile_bt.cli.tools import cmd_bench, cmd_compare, cmd_examples, cmd_tree, cmd_view


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
    run.set_defaults(func=cmd_run)

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
    live.set_defaults(func=cmd_live)

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
    twin.set_defaults(func=cmd_twin)

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
    replay.set_defaults(func=cmd_replay)

    tree = sub.add_parser("tree", help="validate and print a YAML tree")
    tree.add_argument("tree", help="YAML tree file")
    tree.add_argument("--dot", default=None, metavar="FILE", help="also write a Graphviz dot file")
    tree.add_argument("--params", action="store_true",
                      help="also print every node's parameters: values in SI units, units and where they come from")
    tree.add_argument("--param", action="append", default=[], metavar="NODE.PARAM=VALUE",
                      help="set a parameter as 'run --param' does, to check it (repeatable)")
    _plugin_option(tree)
    tree.set_defaults(func=cmd_tree)

    view = sub.add_parser("view", help="show a mission's contacts, path and scene in 3-D")
    view.add_argument("dir", help="output directory of 'tactile-bt run'")
    view.add_argument("--png", default=None, help="render off screen into this PNG instead of a window")
    view.add_argument("--color-by", default=None, choices=("time", "pressure"), help="colour of the contacts (default: time for scans, pressure otherwise)")
    view.set_defaults(func=cmd_view)

    bench = sub.add_parser("bench", help="speed figures, as ratios measured in one run")
    bench.add_argument("--json", action="store_true", help="print JSON instead of a table")
    bench.add_argument("--quick", action="store_true", help="fewer repetitions (noisier figures)")
    bench.set_defaults(func=cmd_bench)

    paper = sub.add_parser("paper", help="reproduce the paper's Tables I-III and Figs. 8-11 (20 trials each)")
    paper.add_argument("--trials", type=positive_int, default=20, help="seeded trials per experiment (default: 20)")
    paper.add_argument("--duration", type=positive_float, default=22.0,
                       help="mission time per trial in s (default: 22)")
    _executor_options(paper)
    paper.add_argument("--out", default="out/paper", help="output directory (default: out/paper)")
    paper.set_defaults(func=cmd_paper)

    stab = sub.add_parser("stability", help="stiffness sweep, extreme cases and control rates")
    stab.add_argument("--out", default="out/stability", help="output directory (default: out/stability)")
    stab.add_argument("--no-rates", action="store_true", help="skip the cable mission at 100-1900 Hz")
    _executor_options(stab)
    stab.set_defaults(func=cmd_stability)

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
    sweep.set_defaults(func=cmd_sweep)

    compare = sub.add_parser("compare", help="runs side by side: their reports (compare.md) and errors (compare.png)")
    compare.add_argument("dirs", nargs="+", metavar="DIR",
                         help="output directories of 'run' or 'replay'; a sweep's (with --keep-runs) counts as all "
                              "its runs")
    compare.add_argument("--out", required=True, metavar="DIR", help="where compare.md and compare.png go")
    compare.set_defaults(func=cmd_compare)

    acc = sub.add_parser("accuracy", help="feature accuracy on synthetic contacts (paper Fig. 4)")
    acc.add_argument("--trials", type=positive_int, default=20, help="synthetic contacts per angle (default: 20)")
    acc.add_argument("--seed", type=nonnegative_int, default=0, help="random seed, >= 0 (default: 0)")
    acc.add_argument("--json", action="store_true", help="print JSON instead of tables")
    acc.add_argument("--png", default=None, help="also draw the comparison like the paper's Fig. 4")
    acc.set_defaults(func=cmd_accuracy)

    examples = sub.add_parser("examples", help="list the trees, scenes and studies that ship with tactile_bt, "
                                                "or copy them to edit")
    examples.add_argument("--copy", default=None, metavar="DIR", help="copy every shipped file into DIR "
                                                                      "(DIR/trees, DIR/sim, DIR/studies)")
    examples.add_argument("--force", action="store_true", help="with --copy: overwrite files that exist in DIR")
    examples.set_defaults(func=cmd_examples)

    try:
        from tactile_bt.sense.hardware.cli import add_sensor_subcommands
    except ImportError:
        pass
    else:
        add_sensor_subcommands(sub)
    return parser

