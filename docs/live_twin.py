"""The cable mission live against the real-time twin, and its row of the README's results.

    python docs/live_twin.py                       # trees/cable_follow.yaml on sim/cable.yaml
    python docs/live_twin.py --scene sim/cable_sine.yaml --out out/live_sine

Starts ``tactile-bt twin SCENE --out OUT/twin``, runs ``tactile-bt live TREE --sensor PORT --robot
OUT/twin/robot.yaml --truth SCENE --out OUT/live`` against it, stops the twin, and prints a Markdown
table row: how the mission ended, the path error, the share of the cable followed, and the real-time
figures of the live loop (latency from a frame's arrival to the twist sent, period jitter, cycles
over budget). ROS 2 stays on this host (localhost discovery, shared-memory transport).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

HEADER = ("| run | end | mission time | path error mean / max | followed | latency p50 / p99 | jitter p99 | "
          "over budget |\n|---|---|---|---|---|---|---|---|")


def run(tree: str, scene: str, out: Path) -> dict:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", FASTDDS_BUILTIN_TRANSPORTS="SHM")
    twin = subprocess.Popen([sys.executable, "-m", "tactile_bt.cli", "twin", scene, "--out", str(out / "twin")],
                            stdout=subprocess.PIPE, text=True, env=env)
    try:
        port = twin.stdout.readline().strip()
        if not port:
            raise SystemExit("the twin did not start")
        subprocess.run([sys.executable, "-m", "tactile_bt.cli", "live", tree, "--sensor", port, "--robot",
                        str(out / "twin" / "robot.yaml"), "--truth", scene, "--out", str(out / "live")],
                       env=env, check=False)
    finally:
        twin.send_signal(signal.SIGTERM)
        twin.wait(timeout=60)
    return json.loads((out / "live" / "report.json").read_text())


def row(label: str, r: dict) -> str:
    reason = r["reason"].split(": ", 1)[-1]
    p, rt = r.get("path_error_m") or {}, r.get("realtime") or {}
    followed = f"{p['followed_m'] / p['cable_length_m']:.0%}" if p else "–"
    path = f"{p['mean'] * 1e3:.2f} / {p['max'] * 1e3:.2f} mm" if p else "–"
    lat, jit = rt.get("latency_ms", {}), rt.get("jitter_ms", {})
    return (f"| {label} | {r['status']}: {reason} | {r['sim_time_s']:.1f} s | {path} | {followed} | "
            f"{lat.get('p50', float('nan')):.2f} / {lat.get('p99', float('nan')):.2f} ms | "
            f"{jit.get('p99', float('nan')):.2f} ms | {rt.get('over_budget', 0)} of {rt.get('cycles', 0)} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tree", default="trees/cable_follow.yaml")
    parser.add_argument("--scene", default="sim/cable.yaml")
    parser.add_argument("--out", default="out/live_twin")
    args = parser.parse_args(argv)
    report = run(args.tree, args.scene, Path(args.out))
    print(HEADER)
    print(row(f"live against the twin, `{Path(args.scene).name}`", report))
    return 0 if report["status"] == "success" else 1


if __name__ == "__main__":
    sys.exit(main())
