"""Compare the README's figures with a fresh run, and refresh them.

    python docs/check_figures.py            # the short checks (the cable mission, ~10 s); CI runs these
    python docs/check_figures.py --all      # every table below (~25 min on 2 cores)
    python docs/check_figures.py --all --update   # ... and write the fresh rows into README.md
    python docs/check_figures.py --only exploration   # one check (its name as the list below gives it)

Each check runs the command the README quotes, formats its figures as the README's table rows,
and compares them, row by row (matched by the first cell and the table's header), number by
number with the rows in README.md. A number drifts when it differs from the README's by more
than the tolerance: 10 % of the README's value or 2 in its last printed digit, whichever is
larger; the columns in :data:`LOOSER` have a looser relative tolerance (the mission time and the
number of samples of a scan follow the path it takes, which the last bit of floating point can
change between machines; a Hausdorff distance is one worst point). Columns of wall time and
real-time factor, latency and jitter are not compared (they measure the machine). A cell's words (a status and its
reason) must match exactly. Exit status 1 when anything drifted or a README row is missing.

Not checked here: the speed figures (``tactile-bt bench``, machine-bound by nature), the first
run after an install (``docs/first_run.sh``) and the scans of objects that are not in the
repository (their scenes are described in docs/scanning.md, not shipped).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
REL_TOL = 0.10
LAST_DIGITS = 2
#: Header words -> relative tolerance of that column.
LOOSER = {"mission": 0.25, "samples": 0.25, "hausdorff": 1.0, "wall": math.inf, "real-time": math.inf,
          "latency": math.inf, "jitter": math.inf, "over budget": math.inf}

_NUMBER = re.compile(r"[-+−]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _numbers(cell: str) -> list[tuple[float, int]]:
    """(value, decimals printed) of every number in a table cell ("12 679" is one number)."""
    cell = re.sub(r"(?<=\d)[  ](?=\d{3}\b)", "", cell)
    out = []
    for m in _NUMBER.finditer(cell):
        text = m.group().replace("−", "-")
        decimals = len(text.split(".")[1].split("e")[0]) if "." in text else 0
        out.append((float(text), decimals))
    return out


def _words(cell: str) -> str:
    return " ".join(_NUMBER.sub("#", cell.replace("*", "")).split())


def _cells(line: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]


@dataclass
class Row:
    header: tuple[str, ...]
    cells: list[str]
    line: int  # 0-based line in its text

    @property
    def key(self) -> str:
        return self.cells[0] if self.cells else ""


def table_rows(text: str) -> list[Row]:
    """Every row of every Markdown table in ``text``, with its table's header."""
    lines = text.splitlines()
    rows, header = [], None
    for i, line in enumerate(lines):
        if not line.startswith("|"):
            header = None
            continue
        if i + 1 < len(lines) and re.match(r"^\|\s*:?-{3,}", lines[i + 1]):
            header = tuple(_cells(line))
        elif header is not None and not re.match(r"^\|\s*:?-{3,}", line):
            rows.append(Row(header, _cells(line), i))
    return rows


def compare(fresh: Row, old: Row) -> list[str]:
    """The drifts of a fresh row against the README's, one message per cell."""
    problems = []
    for col, (new_cell, old_cell) in enumerate(zip(fresh.cells, old.cells)):
        name = old.header[col] if col < len(old.header) else f"column {col + 1}"
        rel = next((tol for word, tol in LOOSER.items() if word in name.lower()), REL_TOL)
        if math.isinf(rel):
            continue
        if _words(new_cell) != _words(old_cell):
            problems.append(f"{name}: {old_cell!r} -> {new_cell!r}")
            continue
        for (new, _), (was, decimals) in zip(_numbers(new_cell), _numbers(old_cell)):
            allowed = max(rel * abs(was), LAST_DIGITS * 10.0 ** -decimals)
            if abs(new - was) > allowed:
                problems.append(f"{name}: {old_cell} -> {new_cell} (tolerance {allowed:.3g})")
                break
    return problems


# --------------------------------------------------------------------------- the checks
def _tactile_bt(*args: str) -> str:
    done = subprocess.run([sys.executable, "-m", "tactile_bt.cli", *args], cwd=ROOT, capture_output=True, text=True)
    if done.returncode not in (0, 1):
        raise RuntimeError(f"tactile-bt {' '.join(args)} exited {done.returncode}: {done.stderr[-2000:]}")
    return done.stdout


def _report(tree: str, scene: str) -> dict:
    with tempfile.TemporaryDirectory() as out:
        _tactile_bt("run", tree, "--scene", scene, "--out", out)
        return json.loads((Path(out) / "report.json").read_text())


def _signed(value: float, digits: int) -> str:
    return f"{value:+.{digits}f}".replace("-", "−")


def cable_mission() -> str:
    """The cable mission's Table I-III metrics and path error (README, "Cable following")."""
    r = _report("trees/cable_follow.yaml", "sim/cable.yaml")
    m = r["metrics"]
    p, x, y, a = m["pressure_pa"], m["cop_x_px"], m["cop_y_px"], m["orientation_rad"]
    target = 2000.0
    rows = [
        "| metric (after the approach, 20 s window) | steady-state error | std | response time |",
        "|---|---|---|---|",
        f"| pressure (Pa; target 2000) | {_signed(p['steady_state_error'], 1)} | {p['std']:.1f} "
        f"({p['std'] / target:.3f} × target) | {p['response_time_s']:.2f} s |",
        f"| COP x (px) | {x['steady_state_error']:+.3f} | {x['std']:.3f} | {x['response_time_s']:.2f} s |",
        f"| COP y (px) | {y['steady_state_error']:+.3f} | {y['std']:.3f} | {y['response_time_s']:.2f} s |",
        f"| orientation (rad) | {_signed(a['steady_state_error'], 4)} | {a['std']:.4f} "
        f"({math.degrees(a['std']):.2f}°) | {a['response_time_s']:.2f} s |",
        "",
        "| path error: distance of recorded contacts from the true centreline, in the table plane | mean | max |",
        "|---|---|---|",
        f"| `record_contacts {{point: local}}` (the tree's setting) | **{r['path_error_m']['mean'] * 1e3:.2f} mm** | "
        f"**{r['path_error_m']['max'] * 1e3:.2f} mm** |",
        f"| plain centre of pressure of every cycle (`path_error_cop_m` in the report) | "
        f"{r['path_error_cop_m']['mean'] * 1e3:.2f} mm | {r['path_error_cop_m']['max'] * 1e3:.2f} mm |",
    ]
    return "\n".join(rows)


def cable_scenes() -> str:
    """Every shipped cable scene and four random cables (README, "Other cables")."""
    script = str(ROOT / "docs" / "cable_scenes.py")
    out = []
    for extra in ([], ["--random", "4", "--seed", "7"]):
        done = subprocess.run([sys.executable, script, *extra], cwd=ROOT, capture_output=True, text=True, check=True)
        out.append(done.stdout.replace("| `random_cable_", "| random `random_cable_"))  # as the README names them
    return "\n".join(out)


def exploration() -> str:
    """Every shipped cable and scan scene with seeds 0, 1 and 2 and the verdicts (README, "Honest
    exploration")."""
    done = subprocess.run([sys.executable, str(ROOT / "docs" / "exploration_scenes.py"), "--seeds", "0", "1", "2",
                           "--short"], cwd=ROOT, capture_output=True, text=True)
    return done.stdout


def paper() -> str:
    """The paper's Tables I-III, 20 trials each (README, "The paper's Tables I-III")."""
    with tempfile.TemporaryDirectory() as out:
        return _tactile_bt("paper", "--out", out)


def stability() -> str:
    """The stiffness sweep, extreme cases and control rates (README, "Numerical stability")."""
    with tempfile.TemporaryDirectory() as out:
        return _tactile_bt("stability", "--out", out)


def live_twin() -> str:
    """The cable mission live against the real-time twin (README, "Live against the twin")."""
    with tempfile.TemporaryDirectory() as out:
        done = subprocess.run([sys.executable, str(ROOT / "docs" / "live_twin.py"), "--out", out], cwd=ROOT,
                              capture_output=True, text=True)
        return done.stdout


@dataclass(frozen=True)
class Check:
    name: str
    make: Callable[[], str]
    quick: bool


CHECKS = (Check("cable mission", cable_mission, True), Check("cable scenes", cable_scenes, False),
          Check("paper tables", paper, False), Check("stability", stability, False), Check("exploration", exploration, False),
          Check("live against the twin", live_twin, False))


def run_checks(checks, readme: str) -> tuple[list[str], dict[int, str]]:
    """(messages of drift, README line -> fresh line) over ``checks``."""
    old_rows = table_rows(readme)
    messages, fresh_lines = [], {}
    for check in checks:
        print(f"{check.name} ...", file=sys.stderr, flush=True)
        fresh_text = check.make()
        seen: dict[tuple, int] = {}
        for fresh in table_rows(fresh_text):
            ident = (fresh.header, fresh.key)
            k = seen.get(ident, 0)
            seen[ident] = k + 1
            matches = [r for r in old_rows if r.key == fresh.key and r.header == fresh.header]
            if len(matches) <= k:
                messages.append(f"{check.name}: the README has no row {fresh.key!r} under | {' | '.join(fresh.header)} |")
                continue
            old = matches[k]
            fresh_lines[old.line] = fresh_text.splitlines()[fresh.line]
            messages += [f"{check.name}: {fresh.key}: {p}" for p in compare(fresh, old)]
    return messages, fresh_lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--all", action="store_true", help="every check, not only the short ones")
    parser.add_argument("--update", action="store_true", help="write the fresh rows into README.md")
    parser.add_argument("--only", action="append", default=[], metavar="NAME", choices=[c.name for c in CHECKS],
                        help="run this check alone (repeatable): " + ", ".join(c.name for c in CHECKS))
    args = parser.parse_args(argv)
    readme = README.read_text(encoding="utf-8")
    checks = [c for c in CHECKS if (c.name in args.only) if args.only] or \
        [c for c in CHECKS if (args.all or c.quick) and not args.only]
    messages, fresh_lines = run_checks(checks, readme)
    for message in messages:
        print(f"drift: {message}")
    print(f"{len(fresh_lines)} README rows compared ({', '.join(c.name for c in checks)}): "
          f"{len(messages)} drifted beyond the tolerance")
    if args.update and fresh_lines:
        lines = readme.splitlines(keepends=True)
        for i, new in fresh_lines.items():
            lines[i] = new + ("\n" if lines[i].endswith("\n") else "")
        README.write_text("".join(lines), encoding="utf-8")
        print(f"README.md: {len(fresh_lines)} rows written")
    return 1 if messages and not args.update else 0


if __name__ == "__main__":
    sys.exit(main())
