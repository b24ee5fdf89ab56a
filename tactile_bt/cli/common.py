"""What the commands share: plugins, shipped files, notes, watchers.

Layer: the entry point (:mod:`tactile_bt.cli`).
"""

from __future__ import annotations

import sys


from tactile_bt.arguments import (check_output)


def load_plugins(args) -> tuple[str, ...]:
    """Import the ``--plugin`` modules (before any tree is read); return them as a worker imports
    them (files as absolute paths)."""
    from tactile_bt.tree.registry import import_plugin, load_entry_points

    load_entry_points()
    return tuple(import_plugin(spec) for spec in getattr(args, "plugin", None) or ())


def shipped_file(given: str) -> str:
    """``given``, or the shipped file it names where no such file is here (with a note)."""
    from tactile_bt import shipped

    found = shipped.resolve(given)
    if str(found) != str(given):
        note(f"{given}: using the file that ships with tactile_bt, {found} "
              "('tactile-bt examples --copy DIR' makes copies to edit)")
    return str(found)


def note(message: str) -> None:
    print(f"note: {message}", file=sys.stderr)


def terminate_as_interrupt() -> None:
    """SIGTERM ends the command the way Ctrl-C does (outputs written, the robot's last twist zero)."""
    import signal

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupt)


def watchers_of(args) -> list:
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


def report_watched(args) -> None:
    if args.rerun is not None:
        print(f"  rerun recording in {args.rerun}")

