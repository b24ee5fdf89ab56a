"""The ``tactile-bt`` command line."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

__all__ = ["main"]


class _Progress:
    """A one-line progress bar on stderr for runs longer than a second (terminals only)."""

    def __init__(self) -> None:
        self.start = time.perf_counter()
        self.enabled = sys.stderr.isatty()
        self.shown = False

    def __call__(self, t: float, duration: float) -> None:
        if not self.enabled or time.perf_counter() - self.start < 1.0:
            return
        width = 30
        done = int(width * t / duration)
        sys.stderr.write(f"\r[{'#' * done}{'.' * (width - done)}] {t:5.1f}/{duration:.1f} s")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")


def _cmd_run(args) -> int:
    from tactile_bt.mission import run_mission

    progress = _Progress()
    try:
        result = run_mission(args.tree, args.scene, duration=args.duration, seed=args.seed,
                             overrides=args.set, out=args.out, progress=progress,
                             orientation_method=args.orientation)
    finally:
        progress.close()
    r = result.report
    print(f"{r['status']}{': ' + r['reason'] if r['reason'] else ''} after {r['sim_time_s']:.2f} s "
          f"({r['ticks']} ticks, {r['real_time_factor']:.1f}x real time)")
    for name, m in r["metrics"].items():
        print(f"  {name:16s} steady-state {m['steady_state_error']:+.4g}  std {m['std']:.4g}  "
              f"response {m['response_time_s']:.2f} s")
    if "path_error_m" in r:
        p = r["path_error_m"]
        print(f"  path error       mean {p['mean'] * 1e3:.2f} mm  max {p['max'] * 1e3:.2f} mm  "
              f"followed {p['followed_m'] * 1e3:.0f} of {p['cable_length_m'] * 1e3:.0f} mm")
    print(f"  outputs in {args.out}")
    return 0 if r["status"] in ("success", "completed") else 1


def _cmd_tree(args) -> int:
    import py_trees

    from tactile_bt.loader import load_tree

    tree = load_tree(args.tree)
    print(py_trees.display.unicode_tree(tree.root))
    if args.dot:
        dot = py_trees.display.dot_tree(tree.root)
        Path(args.dot).write_text(dot.to_string())
        print(f"dot graph written to {args.dot}")
    return 0


def _cmd_bench(args) -> int:
    from tactile_bt.bench import run_bench

    figures = run_bench(quick=args.quick)
    if args.json:
        print(json.dumps(figures, indent=2))
    else:
        from tactile_bt.bench import format_bench

        print(format_bench(figures))
    return 0


def _cmd_accuracy(args) -> int:
    from tactile_bt.synthetic import cop_accuracy, orientation_comparison

    result = {"orientation": orientation_comparison(trials=args.trials, seed=args.seed),
              "cop": cop_accuracy(trials=args.trials, seed=args.seed)}
    print(json.dumps(result, indent=2, default=float))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tactile-bt", description="Tactile servoing with behaviour trees.")
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a tree against a simulated scene")
    run.add_argument("tree", help="YAML tree file")
    run.add_argument("--scene", required=True, help="YAML scene file")
    run.add_argument("--duration", type=float, default=None, help="mission time in s (default: the scene's)")
    run.add_argument("--seed", type=int, default=None, help="random seed (default: the scene's)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. objects.1.stiffness=1e5 (repeatable)")
    run.add_argument("--orientation", choices=("moments", "hough"), default="moments",
                     help="edge orientation method (default: moments)")
    run.add_argument("--out", required=True, help="output directory")
    run.set_defaults(func=_cmd_run)

    tree = sub.add_parser("tree", help="validate and print a YAML tree")
    tree.add_argument("tree")
    tree.add_argument("--dot", default=None, help="also write a Graphviz dot file")
    tree.set_defaults(func=_cmd_tree)

    bench = sub.add_parser("bench", help="speed figures, as ratios measured in one run")
    bench.add_argument("--json", action="store_true")
    bench.add_argument("--quick", action="store_true", help="fewer repetitions")
    bench.set_defaults(func=_cmd_bench)

    acc = sub.add_parser("accuracy", help="feature accuracy on synthetic contacts (paper Fig. 4)")
    acc.add_argument("--trials", type=int, default=20)
    acc.add_argument("--seed", type=int, default=0)
    acc.set_defaults(func=_cmd_accuracy)

    try:
        from tactile_bt.hardware.cli import add_sensor_subcommands
    except ImportError:
        pass
    else:
        add_sensor_subcommands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from tactile_bt.yamlutil import YamlError

    try:
        return int(args.func(args) or 0)
    except YamlError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
