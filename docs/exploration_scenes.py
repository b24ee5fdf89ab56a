"""Exploration on every shipped cable and scan scene, with several seeds: is every `success` true,
is every force bounded? Prints the table the README shows (Markdown).

    python docs/exploration_scenes.py --seeds 0 1 2                 # every scene, three seeds
    python docs/exploration_scenes.py --only cable_bend30 scan_groove --seeds 0
    python docs/exploration_scenes.py --seeds 0 --figures docs/figures   # also the scans' renders
    python docs/exploration_scenes.py --kind scan --param "frontier_guidance.speed_mps=30 mm/s"

Cables run `trees/cable_follow.yaml` with twice the scene's budget, scans `trees/scan_object.yaml`
with 600 s; ``--param NODE.PARAM=VALUE`` (repeatable) changes a parameter of the scan tree, as
``tactile-bt run --param`` does, to see how the table holds up when the tree is changed. A row's
verdict:

* **true success**: `success` and the goals met: for a cable, path error mean <= 1 mm and max <= 3
  mm, >= 85 % of the cable followed, p99 |COP x error| <= 1 px (after the approach, the last 2 s
  left out); for a scan, coverage of the scan region >= 0.95 (>= 0.90 on a concave groove) and
  chamfer <= 1 mm;
* **honest failure**: `failure` with its reason;
* **FALSE SUCCESS**: `success` with a goal missed.

Whatever the status, a row also fails on force: after the approach (from the first cycle a
`force_hold` holds a target), the smoothed pressure may exceed twice its target for at most
0.1 s at a stretch, and the contact force never 20 N. The exit status is 1 when any row is a
false success or fails on force.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import shutil
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path


ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))  # docs/cable_scenes.py
CABLE_TREE = ROOT / "trees" / "cable_follow.yaml"
SCAN_TREE = ROOT / "trees" / "scan_object.yaml"
SCAN_BUDGET_S = 600.0

#: The goals a scan is judged by (SI units); a cable's are docs/cable_scenes.py's GOALS.
SCAN_GOALS = {"coverage": 0.95, "chamfer_m": 1e-3}
#: Scenes with a goal of their own: a flat pad cannot lie in a concave groove everywhere.
SCAN_COVERAGE_OF = {"scan_groove": 0.90}
FORCE_GOALS = {"pressure_ratio": 2.0, "over_s": 0.1, "force_n": 20.0}


def scenes() -> dict[str, list[Path]]:
    """The shipped cable and scan scenes (sim/cable*.yaml; sim/object.yaml and sim/scan_*.yaml)."""
    sim = ROOT / "sim"
    return {"cable": sorted(sim.glob("cable*.yaml")),
            "scan": [sim / "object.yaml", *sorted(sim.glob("scan_*.yaml"))]}


def force_figures(log: dict) -> dict:
    """The force figures of a mission's log (:func:`tactile_bt.mission.metrics.force_figures`)."""
    from tactile_bt.mission.metrics import force_figures as figures

    return figures(log, factor=FORCE_GOALS["pressure_ratio"], max_over_s=FORCE_GOALS["over_s"],
                   force_cap_n=FORCE_GOALS["force_n"])


def run_cable(scene_file: Path, seed: int) -> dict:
    from cable_scenes import judge  # the cable goals, next to this script

    from tactile_bt import run_mission
    from tactile_bt.sim.scene import load_scene

    scene = load_scene(scene_file)
    budget = 2.0 * scene.duration_s
    result = run_mission(CABLE_TREE, scene, duration=budget, seed=seed)
    figures = judge(result)
    p = figures["path_error_m"]
    goals = {name: name not in figures["missed"] for name in ("path error mean", "path error max", "followed", "COP x")}
    measures = (f"{p['mean'] * 1e3:.2f} / {p['max'] * 1e3:.2f} mm, {figures['followed']:.0%} followed, "
                f"p99 COP x {figures['p99_cop_x_px']:.2f} px")
    return _row("cable", scene_file, seed, result.summary, goals, measures, force_figures(result.log), budget)


def run_scan(scene_file: Path, seed: int, figures: Path | None, params: tuple[str, ...] = ()) -> dict:
    """One scan of ``scene_file`` with ``seed`` (and the scan tree's ``params``, ``NODE.PARAM=VALUE``),
    judged; its render (seed 0) copied to ``figures``."""
    from tactile_bt import run_mission

    out = Path(tempfile.mkdtemp(prefix="exploration_"))
    try:
        result = run_mission(SCAN_TREE, scene_file, duration=SCAN_BUDGET_S, seed=seed, out=out, params=list(params))
        r = result.summary
        rec = r.reconstruction or {}
        coverage, chamfer = rec.get("coverage", math.nan), rec.get("chamfer_m", math.nan)
        need = SCAN_COVERAGE_OF.get(scene_file.stem, SCAN_GOALS["coverage"])
        goals = {"coverage": coverage >= need, "chamfer": chamfer <= SCAN_GOALS["chamfer_m"]}
        measures = f"coverage {coverage:.3f} (goal {need:.2f}), chamfer {chamfer * 1e3:.2f} mm"
        if figures is not None and seed == 0 and (out / "render.png").exists():
            figures.mkdir(parents=True, exist_ok=True)
            shutil.copy(out / "render.png", figures / f"exploration_{scene_file.stem}.png")
        return _row("scan", scene_file, seed, r, goals, measures, force_figures(result.log), SCAN_BUDGET_S)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def _row(kind: str, scene_file: Path, seed: int, report, goals: dict, measures: str, force: dict, budget: float) -> dict:
    force_ok = bool(force["ok"])
    missed = [name for name, ok in goals.items() if not ok]
    if report.status == "success":
        verdict = "true success" if not missed else "**FALSE SUCCESS** (" + ", ".join(missed) + ")"
    else:
        verdict = "honest failure"
    return {"kind": kind, "scene": scene_file.stem, "seed": seed, "status": report.status, "reason": report.reason,
            "sim_time_s": report.sim_time_s, "budget_s": budget, "measures": measures, "goals_met": not missed,
            "force": force, "force_ok": force_ok, "verdict": verdict,
            "false_success": report.status == "success" and bool(missed)}


def _job(args: tuple) -> dict:
    kind, scene_file, seed, figures, params = args
    try:
        return run_cable(scene_file, seed) if kind == "cable" else run_scan(scene_file, seed, figures, params)
    except Exception as exc:  # a crash is a row of its own, not the end of the table
        return {"kind": kind, "scene": scene_file.stem, "seed": seed, "status": "error", "reason": repr(exc),
                "sim_time_s": math.nan, "budget_s": math.nan, "measures": "", "goals_met": False,
                "force": {"peak_force_n": math.nan, "longest_over_s": math.nan}, "force_ok": False,
                "verdict": "**ERROR**", "false_success": False}


def _short(reason: str) -> str:
    """A reason without the counts in brackets (``(171 targets, …)``, ``(402 stall, …)``) and the
    lists after a semicolon, and without the name of the node that gave it; a joint held at its
    limit (``; joint 4 held at its upper limit (+120°) since …``) stays, and so does what a task
    had achieved when the mission's time ran out (``; the scan so far: …``)."""
    for leaf in ("cable_end: ", "frontier_guidance: ", "end of cable: "):
        reason = reason.replace(leaf, "")
    reason, so_far, tail = reason.partition("; the scan so far: ")
    if so_far:
        return f"{_short(reason)}{so_far}{tail}"
    held = re.search(r"; (joint \d+ held at its \w+ limit)", reason)
    counts = re.search(r" \(\d+ [a-z]", reason)
    cut = min((i for i in (counts.start() if counts else -1, reason.find(";")) if i > 0), default=len(reason))
    short = reason[:cut]
    short += ")" * (short.count("(") - short.count(")"))
    return f"{short}; {held.group(1)}" if held else short


def markdown(rows: list[dict], short: bool = False) -> str:
    lines = ["| scene, seed | status: reason | mission | figures | peak force | over 2× target | verdict |",
             "|---|---|---|---|---|---|---|"]
    for row in rows:
        f = row["force"]
        force = "" if row["force_ok"] else " **(force)**"
        reason = _short(row["reason"]) if short else row["reason"]
        lines.append(f"| `{row['scene']}` {row['seed']} | {row['status']}: {reason} | "
                     f"{row['sim_time_s']:.1f} of {row['budget_s']:.0f} s | {row['measures']} | "
                     f"{f['peak_force_n']:.1f} N | {f['longest_over_s']:.2f} s | {row['verdict']}{force} |")
    true = sum(r["verdict"] == "true success" for r in rows)
    honest = sum(r["verdict"] == "honest failure" for r in rows)
    false = sum(r["false_success"] for r in rows)
    force_bad = sum(not r["force_ok"] for r in rows)
    lines.append("")
    lines.append(f"{len(rows)} runs: {true} true successes, {honest} honest failures, {false} false successes, "
                 f"{force_bad} with a force above its bound.")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of every scene (default: 0 1 2)")
    parser.add_argument("--only", nargs="+", default=None, metavar="SCENE",
                        help="only these scenes (file stems, e.g. cable_bend30 scan_groove)")
    parser.add_argument("--kind", choices=("cable", "scan", "all"), default="all", help="cable or scan scenes only")
    parser.add_argument("--workers", type=int, default=2, help="missions run at once (default: 2)")
    parser.add_argument("--figures", type=Path, default=None,
                        help="copy each scan's render (seed 0) to DIR/exploration_<scene>.png")
    parser.add_argument("--short", action="store_true", help="reasons without their counts and lists (the README's table)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows to this JSON file")
    add_param_option(parser)
    args = parser.parse_args(argv)
    check_params(parser, args.param)
    jobs = []
    for kind, files in scenes().items():
        if args.kind not in ("all", kind):
            continue
        for f in files:
            if args.only and f.stem not in args.only:
                continue
            jobs += [(kind, f, seed, args.figures, tuple(args.param)) for seed in args.seeds]
    if not jobs:
        parser.error(f"no scene matches --only {' '.join(args.only or [])}")
    # the scans first: they take longest
    jobs.sort(key=lambda job: job[0] != "scan")
    with ProcessPoolExecutor(max_workers=max(args.workers, 1)) as pool:
        rows = list(pool.map(_job, jobs))
    rows.sort(key=lambda r: (r["kind"], r["scene"], r["seed"]))
    return finish(rows, args.short, args.json)


def add_param_option(parser: argparse.ArgumentParser) -> None:
    """The ``--param`` option: a parameter of the scan tree, changed for every scan."""
    parser.add_argument("--param", action="append", default=[], metavar="NODE.PARAM=VALUE",
                        help="change a parameter of the scan tree for every scan (repeatable), "
                             "e.g. \"frontier_guidance.speed_mps=30 mm/s\"")


def check_params(parser: argparse.ArgumentParser, params: list[str]) -> None:
    """Stop with the loader's message (the node or parameter it does not know, the value it
    cannot read) before any mission runs, when ``params`` do not fit the scan tree."""
    if not params:
        return
    from tactile_bt.errors import YamlError
    from tactile_bt.tree import load_tree

    try:
        load_tree(SCAN_TREE, params=params)
    except YamlError as exc:
        parser.error(str(exc))


def finish(rows: list[dict], short: bool, json_path: Path | None) -> int:
    """Print the table of ``rows``, write them to ``json_path`` (if any) and return the exit
    status: 1 when a row is a false success, fails on force or is an error, else 0."""
    print(markdown(rows, short=short))
    if json_path:
        json_path.write_text(json.dumps(rows, indent=1, default=float))
    return 1 if any(r["false_success"] or not r["force_ok"] or r["status"] == "error" for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
