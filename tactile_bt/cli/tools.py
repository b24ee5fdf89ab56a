"""The commands around missions: ``tree``, ``view``, ``bench``, ``examples``, ``compare``.

Layer: the entry point (:mod:`tactile_bt.cli`).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


from tactile_bt.arguments import (check_output)
from tactile_bt.cli.common import load_plugins, shipped_file


def cmd_tree(args) -> int:
    import py_trees

    from tactile_bt.tree.loader import format_parameters, load_tree

    if args.dot:  # before any work
        check_output(args.dot, force=True, option="--dot", create_parent=True)
    load_plugins(args)
    tree = load_tree(shipped_file(args.tree), params=args.param)
    print(py_trees.display.unicode_tree(tree.root))
    if args.params:
        print(format_parameters(tree))
    if args.dot:
        dot = py_trees.display.dot_tree(tree.root)
        Path(args.dot).write_text(dot.to_string())
        print(f"dot graph written to {args.dot}")
    return 0


def cmd_view(args) -> int:
    from tactile_bt.mission.view import render_mission

    if args.png:  # before any work
        check_output(args.png, force=True, option="--png", create_parent=True)
    png = render_mission(Path(args.dir), args.png, color_by=args.color_by)
    if png is not None:
        print(f"rendered {png}")
    return 0


def cmd_bench(args) -> int:
    from tactile_bt.experiments.bench import run_bench

    figures = run_bench(quick=args.quick)
    if args.json:
        print(json.dumps(figures, indent=2))
    else:
        from tactile_bt.experiments.bench import format_bench

        print(format_bench(figures))
    return 0


def cmd_examples(args) -> int:
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


def cmd_compare(args) -> int:
    from tactile_bt.experiments.compare import write_compare

    md, png = write_compare(args.dirs, args.out)
    print(md.read_text().split("\n## ")[0].rstrip())
    print(f"written: {md}, {png}")
    return 0

