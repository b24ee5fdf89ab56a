"""Command-line helpers of the sensor and replay commands: option checks, output files, warnings.

The ``type=`` validators raise :class:`argparse.ArgumentTypeError`, so argparse rejects a bad
value before anything runs, with one line naming the option.  :func:`check_output` refuses to
overwrite an existing file without ``--force`` and checks that the file can be created, before
a mission or a stream starts.  :func:`one_line_warnings` shows the
:class:`~tactile_bt.sense.hardware.recording.RecordingWarning` of a replay as ``warning: ...`` lines.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import warnings
from pathlib import Path
from typing import Callable, Iterator

from tactile_bt.sense.hardware.framing import PERIOD_UNIT_S

__all__ = [
    "positive_float",
    "positive_int",
    "nonnegative_int",
    "device_rate",
    "fault_spec",
    "OutputPathError",
    "check_output",
    "one_line_warnings",
]

#: Frame rates a device period can express: 1..65535 steps of 100 us.
MIN_RATE_HZ = 1.0 / (65535 * PERIOD_UNIT_S)
MAX_RATE_HZ = 1.0 / PERIOD_UNIT_S


def _validator(convert: Callable[[str], float], ok: Callable[[float], bool], expected: str) -> Callable[[str], float]:
    def parse(text: str):
        try:
            value = convert(text)
        except ValueError:
            value = None
        if value is None or not ok(value):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    parse.__name__ = expected
    return parse


#: A finite number > 0 (rates, durations, timeouts, intervals, speeds).
positive_float = _validator(float, lambda v: math.isfinite(v) and v > 0, "a finite number > 0")
#: An integer >= 1 (rows, columns, baud rates, frames per chunk).
positive_int = _validator(int, lambda v: v >= 1, "an integer >= 1")
#: An integer >= 0 (seeds).
nonnegative_int = _validator(int, lambda v: v >= 0, "an integer >= 0")
#: A frame rate a device period can be set to (100 us steps, at most 65535 of them).
device_rate = _validator(float, lambda v: math.isfinite(v) and MIN_RATE_HZ <= v <= MAX_RATE_HZ,
                         f"a frame rate from {MIN_RATE_HZ:.3g} to {MAX_RATE_HZ:g} Hz")


def fault_spec(text: str):
    """``--faults`` value -> :class:`~tactile_bt.sense.hardware.faults.FaultConfig` (checked)."""
    from tactile_bt.sense.hardware.faults import FaultConfig

    try:
        return FaultConfig.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class OutputPathError(ValueError):
    """An output file cannot or may not be written; the message names it."""


def check_output(path: str | os.PathLike, force: bool = False) -> Path:
    """Check that ``path`` can be written as a new file, before anything is written.

    Raises :class:`OutputPathError` when the path is a directory, its parent is missing, not
    a directory or not writable, or the file exists and ``force`` is false.
    """
    p = Path(path)
    parent = p.parent
    if p.is_dir():
        raise OutputPathError(f"{p} is a directory, not a file")
    if not parent.exists():
        raise OutputPathError(f"{p}: directory {parent} does not exist")
    if not parent.is_dir():
        raise OutputPathError(f"{p}: {parent} is not a directory")
    if p.exists() or p.is_symlink():
        if not force:
            raise OutputPathError(f"{p} exists (use --force to overwrite)")
        if not os.access(p, os.W_OK):
            raise OutputPathError(f"{p} is not writable")
    elif not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(f"{p}: directory {parent} is not writable")
    return p


@contextlib.contextmanager
def one_line_warnings() -> Iterator[None]:
    """Within the block, show every RecordingWarning at once as ``warning: <message>`` on stderr."""
    from tactile_bt.sense.hardware.recording import RecordingWarning

    with warnings.catch_warnings():
        warnings.simplefilter("always", RecordingWarning)
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, RecordingWarning):
                print(f"warning: {message}", file=sys.stderr, flush=True)
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield
