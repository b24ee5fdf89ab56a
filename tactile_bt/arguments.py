"""Checks of command-line arguments shared by every ``tactile-bt`` command.

The ``type=`` validators raise :class:`argparse.ArgumentTypeError`, so argparse rejects a bad
value before anything runs, with one line naming the option (:class:`OneLineParser`: no usage
block). :func:`check_output` checks an
output file before any work (and refuses to overwrite one without ``--force`` where a file is
precious). :func:`one_line_warnings` shows the :class:`~tactile_bt.errors.RecordingWarning` of a
replay as ``warning: ...`` lines. :func:`parse_assignments` reads the ``KEY=VALUE`` strings of
``--param`` and ``--blackboard``; what the keys mean is the tree loader's to check.

Layer: base (imports only :mod:`tactile_bt.errors` and :mod:`tactile_bt.yamlutil`).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import warnings
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

import yaml

from tactile_bt.errors import OutputPathError, YamlError
from tactile_bt.yamlutil import parse_value

__all__ = ["OneLineParser", "validator", "positive_float", "positive_int", "nonnegative_int", "check_output", "check_output_dir",
           "one_line_warnings", "option_error", "parse_assignments"]


class OneLineParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose errors are one line,
    ``tactile-bt run: error: the following arguments are required: --scene (see 'tactile-bt run --help')``,
    and exit code 2, instead of the usage block and the message. ``--help`` is unchanged; the
    parsers of subcommands are of this class too."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def validator(convert: Callable[[str], float], ok: Callable[[float], bool], expected: str) -> Callable[[str], float]:
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
positive_float = validator(float, lambda v: math.isfinite(v) and v > 0, "a finite number > 0")
#: An integer >= 1 (rows, columns, baud rates, frames per chunk).
positive_int = validator(int, lambda v: v >= 1, "an integer >= 1")
#: An integer >= 0 (seeds).
nonnegative_int = validator(int, lambda v: v >= 0, "an integer >= 0")


def option_error(source: str, message: str, field: str | None = None) -> YamlError:
    """The error of a command-line value: ``SOURCE: message`` (``--param hold.kp: ...``), carrying
    ``message`` and ``field`` as the tree loader's located errors do."""
    err = YamlError(message, source)
    err.message, err.field = message, field  # type: ignore[attr-defined]
    return err


def parse_assignments(items: Iterable[str], option: str, what: str) -> list[tuple[str, str, Any]]:
    """``KEY=VALUE`` strings of ``option`` as ``(key, source, value)``, ``source`` being
    ``"OPTION KEY"`` for messages.

    VALUE is read like a YAML value (``1.5 kPa``, ``5e-5``, ``[1 mm, 0]``); one that starts with
    ``@`` is kept as text (a blackboard reference); an empty one is ``None``. ``what`` names the
    key in the message of a string without ``=`` (``expected NODE.PARAM=VALUE``).

    Raises
    ------
    YamlError
        ``OPTION ITEM: expected WHAT=VALUE``, or ``OPTION KEY: cannot read the value ...``.
    """
    out = []
    for item in items:
        if not isinstance(item, str) or "=" not in item:
            raise option_error(f"{option} {item}", f"expected {what}=VALUE")
        key, text = item.split("=", 1)
        key, text = key.strip(), text.strip()
        source = f"{option} {key}"
        if text.startswith("@"):
            value: Any = text  # a blackboard reference: '@' cannot start a plain YAML scalar
        else:
            try:
                value = parse_value(text) if text else None
            except yaml.YAMLError as exc:
                problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
                raise option_error(source, f"cannot read the value {text!r}: {problem}") from None
        out.append((key, source, value))
    return out


def check_output(path: str | os.PathLike, force: bool = False, option: str | None = None,
                 create_parent: bool = False) -> Path:
    """Check that ``path`` can be written as a file, before anything is written.

    Raises :class:`OutputPathError` when the path is a directory, its parent is missing (or
    cannot be made, with ``create_parent``), not a directory or not writable, or the file
    exists and ``force`` is false. ``option`` (e.g. ``"--png"``) starts the message.
    """
    p = Path(path)
    parent = p.parent
    label = f"{option} {p}" if option else str(p)
    if p.is_dir():
        raise OutputPathError(f"{label} is a directory, not a file")
    if create_parent and not parent.exists():
        blocker = next((q for q in parent.parents if q.exists() and not q.is_dir()), None)
        if blocker is not None:
            raise OutputPathError(f"{label}: cannot create the folder, {blocker} is a file")
        parent.mkdir(parents=True, exist_ok=True)
    if not parent.exists():
        raise OutputPathError(f"{label}: directory {parent} does not exist")
    if not parent.is_dir():
        raise OutputPathError(f"{label}: {parent} is not a directory")
    if p.exists() or p.is_symlink():
        if not force:
            raise OutputPathError(f"{label} exists (use --force to overwrite)")
        if not os.access(p, os.W_OK):
            raise OutputPathError(f"{label} is not writable")
    elif not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(f"{label}: directory {parent} is not writable")
    return p


def check_output_dir(path: str | os.PathLike, option: str = "--out") -> Path:
    """Create the output directory ``path`` (and its parents) before any work is done.

    Raises :class:`OutputPathError` naming ``option`` and the path when it is a file, lies under
    a file, or cannot be created.
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise OutputPathError(f"{option} {out}: is a file, not a directory (choose another {option})")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        blocker = next((p for p in out.parents if p.exists() and not p.is_dir()), out.parent)
        raise OutputPathError(f"{option} {out}: cannot create the directory, {blocker} is a file") from None
    except OSError as exc:
        raise OutputPathError(f"{option} {out}: cannot create the directory ({exc.strerror})") from None
    return out


@contextlib.contextmanager
def one_line_warnings() -> Iterator[None]:
    """Within the block, show every RecordingWarning at once as ``warning: <message>`` on stderr."""
    from tactile_bt.errors import RecordingWarning

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
