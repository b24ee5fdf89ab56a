"""Numerical stability of the simulator and the loop (``tactile-bt stability``).

Three parts, each a set of short missions:

* a stiffness sweep: force hold on the rigid pen with its stiffness set from 10² to 10⁷ N/m;
* extreme cases: contact only at the pad's edge or corner, a single-tactel contact, a pad driven
  into saturation, sudden contact loss, an object starting inside the pad, a cable crossing
  itself, the arm driven into a joint limit and into its stretched singularity, and force hold
  at 100 Hz and 1.9 kHz;
* the cable mission at 100–1900 Hz: path and pressure error against wall-clock run time.

Per case: force overshoot, steady-state error, standard deviation, response time, largest
penetration, whether anything non-finite appeared, the wall time, and a verdict.

Layer: experiments.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_bt import defaults, shipped

__all__ = ["Case", "stiffness_cases", "extreme_cases", "run_case", "run_stability", "format_table"]

TARGET = defaults.TARGET_PRESSURE_PA

FORCE_HOLD = "trees/force_hold.yaml"
#: Force hold with a force limit: what a careful user runs near limits.
GUARDED = """
root:
  sequence:
    children:
      - approach: {{timeout_s: 5.0}}
      - parallel:
          policy: success_on_one
          children:
            - force_hold: {{target_pa: {target}}}
            - force_limit: {{limit_n: {limit}}}
"""
#: Drive the pad sideways without caring for contact (joint limit, singularity).
DRIVE = """
root:
  guided_slide: {{twist: {twist}, require_contact: false}}
"""


@dataclass(frozen=True)
class Case:
    """One stability run: a tree (file or inline text) on a scene with overrides."""

    name: str
    group: str
    scene: str
    tree: str = FORCE_HOLD
    tree_text: str | None = None
    overrides: tuple[str, ...] = ()
    duration: float = 3.0
    expect: str = "settled"  # "settled", "finite" or "guarded" (a guard must stop the run)
    note: str = ""


def stiffness_cases() -> list[Case]:
    return [Case(f"pen {k:.0e} N/m", "stiffness", "sim/pen.yaml", overrides=(f"objects.0.stiffness={k}",))
            for k in (1e2, 1e3, 1e4, 1e5, 1e6, 1e7)]


def extreme_cases() -> list[Case]:
    return [
        Case("edge contact", "extreme", "sim/pen.yaml",
             overrides=("mount.position=[0.0, 0.034, 0.011]", "objects.0.rpy_deg=[0, 0, 0]"),
             note="the pen under the pad's last rows only"),
        Case("corner contact", "extreme", "sim/point_contact.yaml",
             overrides=("mount.position=[-0.036, -0.036, 0.103]",), note="the ball under the pad's corner"),
        Case("single tactel", "extreme", "sim/point_contact.yaml",
             overrides=("objects.0.radius=0.003", "objects.0.position=[0.0025, -0.0025, 0.003]",
                        "objects.0.stiffness=1e6", "mount.position=[0.0, 0.0, 0.009]"),
             expect="finite", note="a 6 mm stiff bead: one tactel and its foam spread"),
        Case("saturated pad", "extreme", "sim/toy_box.yaml", tree_text=GUARDED.format(target=15000, limit=15),
             duration=4.0, expect="guarded", note="target 15 kPa above the 10 kPa range; force limit 15 N"),
        Case("sudden contact loss", "extreme", "sim/pen.yaml",
             overrides=("events=[{at_s: 1.5, object: 0, translate: [0.0, 0.0, -0.02]}]",),
             expect="guarded", note="the pen drops 20 mm at 1.5 s; contact_lost ends the run"),
        Case("object inside the pad", "extreme", "sim/pen.yaml",
             overrides=("mount.position=[0.0, 0.0, 0.006]",), note="pad starts 2 mm inside the pen"),
        Case("cable crossing itself", "extreme", "sim/cable.yaml", tree="trees/cable_follow.yaml",
             overrides=("objects.1.path=[{straight: 0.06}, {arc: {radius: 0.06, angle_deg: -270}}, "
                        "{straight: 0.16}]",), duration=8.0, expect="finite"),
        Case("joint limit", "extreme", "sim/pen.yaml", tree_text=DRIVE.format(twist=[0, 0, 0, 0, 0, 1.2]),
             duration=6.0, expect="finite", note="turn about the normal past joint 7's limit"),
        Case("singularity", "extreme", "sim/cable.yaml", tree="trees/cable_follow.yaml",
             overrides=("mount.base=[-0.542, 0.04, -0.333]",), duration=20.0, expect="finite",
             note="arm base 90 mm closer: following the cable stretches the arm (elbow at 0°)"),
        Case("force hold at 100 Hz", "extreme", "sim/pen.yaml", overrides=("rate_hz=100",)),
        Case("force hold at 1.9 kHz", "extreme", "sim/pen.yaml", overrides=("rate_hz=1900",)),
    ]


def _finite(log: dict) -> bool:
    keys = ("position_m", "rotation", "twist_s", "force_n", "penetration_m")
    return all(np.all(np.isfinite(log[k])) for k in keys)


def run_case(case: Case) -> dict:
    """Run one case and judge it."""
    from tactile_bt.tree.loader import load_tree
    from tactile_bt.mission.run import run_mission

    tree = load_tree(case.name, text=case.tree_text) if case.tree_text else shipped.path(case.tree)
    started = time.perf_counter()
    try:
        result = run_mission(tree, shipped.path(case.scene), duration=case.duration, seed=0, overrides=list(case.overrides))
    except Exception as exc:  # a crash is a finding, not the end of the table
        return {"case": case.name, "group": case.group, "verdict": f"error: {type(exc).__name__}: {exc}",
                "ok": False, "wall_time_s": time.perf_counter() - started, "note": case.note}
    log, report = result.log, result.summary
    finite = _finite(log)
    m = report.metrics.get("pressure_pa")
    err = log["pressure_raw_pa"] - TARGET
    controlled = np.isfinite(log["error_pressure_pa"])
    overshoot = float(np.max(err[controlled]) / TARGET) if controlled.any() else math.nan
    response = m.response_time_s if m else math.nan
    margin = manipulability = math.nan
    if "joints_rad" in log:
        from tactile_bt.robot.kinematics import LWR4Kinematics
        from tactile_bt.robot.lwr4_params import Q_MAX, Q_MIN

        q = log["joints_rad"]
        margin = float(np.rad2deg(np.min(np.minimum(q - Q_MIN, Q_MAX - q))))
        kin = LWR4Kinematics()
        manipulability = float(min(kin.manipulability(qk) for qk in q[:: max(1, len(q) // 200)]))
    row = {
        "case": case.name,
        "min_joint_margin_deg": margin,
        "min_manipulability": manipulability,
        "group": case.group,
        "status": report.status,
        "reason": report.reason,
        "overshoot": overshoot,
        "steady_state_error": m.steady_state_error / TARGET if m else math.nan,
        "std": m.std / TARGET if m else math.nan,
        "response_time_s": response,
        "max_penetration_mm": float(np.nanmax(log["penetration_m"])) * 1e3 if len(log["t"]) else 0.0,
        "finite": finite,
        "sim_time_s": report.sim_time_s,
        "wall_time_s": time.perf_counter() - started,
        "note": case.note,
    }
    if not finite:
        verdict, ok = "non-finite values", False
    elif case.expect == "settled":
        ok = report.ok and math.isfinite(response) and response <= 2.0
        verdict = f"settled in {response:.2f} s" if ok else f"not settled within 2 s ({report.status})"
    elif case.expect == "guarded":
        ok = report.status == "failure" and bool(report.reason)
        verdict = f"stopped by the guard: {report.reason}" if ok else f"guard did not act ({report.status})"
    else:
        ok = report.status in ("success", "completed", "failure")
        verdict = f"finite ({report.status})"
    row.update(ok=ok, verdict=verdict)
    return row


#: Control rates of the cable mission (Hz) and its mission time (s).
RATES = (100, 250, 500, 1000, 1900)
RATE_DURATION_S = 20.0


@dataclass(frozen=True)
class RateRun:
    """The cable mission at one control rate."""

    rate_hz: float
    duration: float = RATE_DURATION_S


def run_rate(rate: RateRun) -> dict:
    """The cable mission at one control rate: accuracy and wall-clock time."""
    from tactile_bt.mission.run import run_mission

    r = run_mission(shipped.path("trees/cable_follow.yaml"), shipped.path("sim/cable.yaml"), duration=rate.duration, seed=0,
                    overrides=[f"rate_hz={rate.rate_hz}"])
    rep = r.summary
    path = rep.path_error_m
    return {
        "rate_hz": rate.rate_hz, "status": rep.status, "wall_time_s": rep.wall_time_s,
        "real_time_factor": rep.real_time_factor, "path_error_mean_mm": path["mean"] * 1e3,
        "path_error_max_mm": path["max"] * 1e3, "followed_mm": path["followed_m"] * 1e3,
        "pressure_std": rep.metrics["pressure_pa"].std / TARGET,
        "pressure_steady_state_error": rep.metrics["pressure_pa"].steady_state_error / TARGET,
        "finite": _finite(r.log),
    }


def run_rates(rates=RATES, duration: float = RATE_DURATION_S, executor=None) -> list[dict]:
    """The cable mission at several control rates: accuracy against wall-clock time."""
    from tactile_bt.experiments.executors import run_all

    return run_all(run_rate, [RateRun(rate, duration) for rate in rates], executor)


def plot_rates(rows: list[dict], path: Path) -> Path:
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    wall = [r["wall_time_s"] for r in rows]
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6), constrained_layout=True)
    a.plot(wall, [r["path_error_mean_mm"] for r in rows], "o-", label="mean")
    a.plot(wall, [r["path_error_max_mm"] for r in rows], "s--", label="max")
    b.plot(wall, [r["pressure_std"] for r in rows], "o-", color="C2", label="std")
    b.plot(wall, [abs(r["pressure_steady_state_error"]) for r in rows], "s--", color="C3", label="|steady-state error|")
    for ax in (a, b):
        for r in rows:
            ax.annotate(f"{r['rate_hz']} Hz", (r["wall_time_s"], ax.get_lines()[0].get_ydata()[rows.index(r)]),
                        textcoords="offset points", xytext=(4, 4), fontsize=8)
        ax.set_xlabel("wall-clock run time of the 20 s mission (s)")
        ax.set_xscale("log")
        ax.set_xticks(wall, [f"{w:.1f}" for w in wall])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    a.set_ylabel("path error (mm)")
    b.set_ylabel("pressure error (units of 2 kPa)")
    fig.suptitle("Cable mission: accuracy against run time for control rates 100–1900 Hz", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _fmt(x, spec: str) -> str:
    """``x`` formatted, ``–`` for none or non-finite; a negative number that rounds to zero
    prints as zero (no ``-0.0``)."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    text = format(x, spec)
    if text.startswith("-") and float(text) == 0.0:
        text = format(0.0, spec)
    return text


def format_table(cases: list[dict], rates: list[dict]) -> str:
    lines = ["| case | overshoot | steady-state error | std | response (s) | max penetration (mm) | "
             "joint margin (deg) | manipulability | finite | wall (s) | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in cases:
        lines.append(
            f"| {r['case']} | {_fmt(r.get('overshoot'), '+.3f')} | {_fmt(r.get('steady_state_error'), '+.4f')} | "
            f"{_fmt(r.get('std'), '.4f')} | {_fmt(r.get('response_time_s'), '.2f')} | "
            f"{_fmt(r.get('max_penetration_mm'), '.2f')} | {_fmt(r.get('min_joint_margin_deg'), '.1f')} | "
            f"{_fmt(r.get('min_manipulability'), '.3f')} | {'yes' if r.get('finite') else 'NO'} | "
            f"{r['wall_time_s']:.1f} | {'✓' if r['ok'] else '✗'} {r['verdict']} |")
    lines += ["", "Pressure errors in units of the 2 kPa target; overshoot is the largest raw pressure above "
              "the target while the force controller runs.", "",
              "| rate (Hz) | wall time (s) | real-time factor | path error mean / max (mm) | followed (mm) | pressure std | finite |",
              "|---|---|---|---|---|---|---|"]
    for r in rates:
        lines.append(f"| {r['rate_hz']} | {r['wall_time_s']:.1f} | {r['real_time_factor']:.1f} | "
                     f"{r['path_error_mean_mm']:.2f} / {r['path_error_max_mm']:.2f} | {r['followed_mm']:.0f} | "
                     f"{r['pressure_std']:.4f} | {'yes' if r['finite'] else 'NO'} |")
    return "\n".join(lines) + "\n"


def _run_item(item: "Case | RateRun") -> dict:
    """One run of the stability study, on any executor."""
    return run_rate(item) if isinstance(item, RateRun) else run_case(item)


def _cycles(item: "Case | RateRun") -> float:
    """Control cycles of a run: what its wall time grows with."""
    if isinstance(item, RateRun):
        return item.duration * item.rate_hz
    rate = next((float(o.split("=", 1)[1]) for o in item.overrides if o.startswith("rate_hz=")), defaults.RATE_HZ)
    return item.duration * rate


def run_stability(out: Path, rates: bool = True, executor=None, progress=None) -> dict:
    """Every case; writes stability.md, stability.json and error_vs_runtime.png into ``out``.

    The runs go to ``executor`` (:mod:`tactile_bt.experiments.executors`; default: this
    process), the longest first; ``progress(done, total)`` is called as they finish. The tables
    keep the cases' order."""
    from tactile_bt.experiments.executors import run_all

    out.mkdir(parents=True, exist_ok=True)
    items = [*stiffness_cases(), *extreme_cases(), *([RateRun(rate) for rate in RATES] if rates else [])]
    longest_first = sorted(range(len(items)), key=lambda i: -_cycles(items[i]))
    done = run_all(_run_item, [items[i] for i in longest_first], executor, progress)
    rows: list = [None] * len(items)
    for i, row in zip(longest_first, done):
        rows[i] = row
    n_cases = len(stiffness_cases()) + len(extreme_cases())
    cases, rate_rows = rows[:n_cases], rows[n_cases:]
    (out / "stability.md").write_text(format_table(cases, rate_rows))
    (out / "stability.json").write_text(json.dumps({"cases": cases, "rates": rate_rows}, indent=2, default=float) + "\n")
    if rate_rows:
        plot_rates(rate_rows, out / "error_vs_runtime.png")
    return {"cases": cases, "rates": rate_rows}
