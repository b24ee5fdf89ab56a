"""Messages of the YAML tree loader: located :class:`~tactile_bt.errors.TreeError` objects with a
did-you-mean hint.

Every error of :mod:`tactile_bt.tree.loader` and :mod:`tactile_bt.tree.subtrees` names the file, line and
column of the offending value and the field it belongs to (``err.message``, ``err.field``), so
that editors and tests can point at it; this module builds them.

Layer: tree.
"""

from __future__ import annotations

from difflib import get_close_matches

from tactile_bt.yamlutil import Located
from tactile_bt.errors import YamlError

__all__ = ["located_error", "message_of", "with_context", "did_you_mean", "origin_of"]



def located_error(loc: Located, message: str, field: str | None = None) -> YamlError:
    """A :class:`TreeError` at ``loc`` that also carries ``message`` and ``field`` as attributes."""
    err = loc.error(message)
    err.message = message  # type: ignore[attr-defined]
    err.field = field  # type: ignore[attr-defined]
    return err


def message_of(exc: YamlError) -> str:
    """The message of ``exc`` without its ``file:line:column`` prefix."""
    message = getattr(exc, "message", None)
    if message is not None:
        return message
    prefix = str(YamlError("", exc.file, exc.line, exc.column))
    return str(exc)[len(prefix):]


def with_context(exc: YamlError, context: str) -> YamlError:
    """A copy of ``exc`` (same position and field) with ``context`` appended to its message."""
    message = message_of(exc) + context
    new = YamlError(message, exc.file, exc.line, exc.column)
    new.message = message  # type: ignore[attr-defined]
    new.field = getattr(exc, "field", None)  # type: ignore[attr-defined]
    return new


def did_you_mean(name: str, options) -> str:
    """`` (did you mean 'x'?)`` for the option closest to ``name``, or an empty string."""
    close = get_close_matches(str(name), [str(o) for o in options], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def origin_of(loc: Located) -> str:
    """``file:line:column`` of a located value, for messages that point at a second place (just
    the source, e.g. ``--param hold.target_pa``, for a value that has no line)."""
    if loc.line is None:
        return str(loc.file)
    return f"{loc.file}:{loc.line}:{loc.column}"
