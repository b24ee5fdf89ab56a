"""The commands that run a mission: ``run``, ``live``, ``twin``, ``replay``.

Layer: the entry point (:mod:`tactile_bt.cli`).
"""

from __future__ import annotations

import sys
import threading


from tactile_bt.arguments import (check_output, check_output_dir, one_line_warnings)
from tactile_bt.cli.common import load_plugins, report_watched, shipped_file, terminate_as_interrupt, watchers_of


def cmd_run(args) -> int:
    from tactile_bt.sim import warmup

    warmup.start()  # first, so a cold kernel cache compiles while the rest is imported
    from tactile_bt.mission.run import calibration_path, run_mission

    load_plugins(args)

    if args.record is not None:  # before the mission: never overwrite a file unasked
        check_output(args.record, args.force)
        check_output(calibration_path(args.record), args.force)
    from tactile_bt.progress import Progress

    watchers = watchers_of(args)
    progress = Progress(args.duration or 0.0, unit="s", label="mission time")
    try:
        result = run_mission(shipped_file(args.tree), shipped_file(args.scene), duration=args.duration, seed=args.seed,
                             overrides=args.set, out=args.out, progress=progress,
                             orientation_method=args.orientation, via_emulator=args.via_emulator,
                             recording=args.record, reconstruct=args.reconstruct,
                             params=args.param, blackboard=args.blackboard, watchers=watchers)
    finally:
        progress.close()
    r = result.summary
    print(f"{r.status}{': ' + r.reason if r.reason else ''} after {r.sim_time_s:.2f} s "
          f"({r.ticks} ticks, {r.real_time_factor:.1f}x real time)")
    return _outcome(r, args)


def cmd_live(args) -> int:
    from tactile_bt.mission.live import run_live
    from tactile_bt.progress import Progress

    load_plugins(args)
    if args.record is not None:
        from tactile_bt.mission.run import calibration_path

        check_output(args.record, args.force)
        check_output(calibration_path(args.record), args.force)
    watchers = watchers_of(args)
    terminate_as_interrupt()
    progress = Progress(args.duration or 0.0, unit="s", label="mission time")
    try:
        result = run_live(shipped_file(args.tree), args.sensor, args.robot, duration=args.duration, out=args.out,
                          truth=shipped_file(args.truth) if args.truth else None, record=args.record,
                          module=args.module, orientation_method=args.orientation, progress=progress,
                          watchers=watchers)
    finally:
        progress.close()
    r = result.summary
    print(f"{r.status}{': ' + r.reason if r.reason else ''} after {r.sim_time_s:.2f} s ({r.ticks} cycles)")
    return _outcome(r, args)


def cmd_twin(args) -> int:
    import signal

    from tactile_bt.mission.twin import serve_twin, twin_summary

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    out = check_output_dir(args.out)
    result = serve_twin(shipped_file(args.scene), out, seed=args.seed, duration=args.duration, module=args.module,
                        stall_after_s=args.stall_after, stop=stop, network=args.network,
                        announce=lambda port: print(port, flush=True))
    print(twin_summary(result), file=sys.stderr)
    return 0


def cmd_replay(args) -> int:
    from tactile_bt.mission.replay import replay_mission

    load_plugins(args)
    watchers = watchers_of(args)
    try:
        with one_line_warnings():
            result = replay_mission(shipped_file(args.tree), args.recording, calibration=args.calibration, speed=args.speed,
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
    report_watched(args)
    return 0 if r.ok else 1


def _outcome(r, args) -> int:
    """Print a finished mission's summary lines, warnings and outputs (after its one-line status),
    and what the watchers wrote; the command's exit status."""
    print("\n".join(r.summary_lines()))
    for warning in r.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    print(f"  outputs in {args.out}")
    report_watched(args)
    return 0 if r.ok else 1
