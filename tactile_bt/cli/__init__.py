"""The ``tactile-bt`` command line: :func:`main` parses the arguments (:mod:`tactile_bt.cli.parser`)
and runs the command (:mod:`~tactile_bt.cli.missions`, :mod:`~tactile_bt.cli.tools`,
:mod:`~tactile_bt.cli.studies`).

Layer: the entry point, above every layer (it imports what a command needs, nothing imports it).
"""

from __future__ import annotations

import atexit
import os
import sys
import threading

from tactile_bt.errors import MissionInterrupted, TactileBtError
from tactile_bt.cli.parser import build_parser

__all__ = ["main", "console", "build_parser"]


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
