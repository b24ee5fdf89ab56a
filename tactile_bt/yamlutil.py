"""YAML reading that remembers where every value came from, for errors that name file and line.

Layer: base.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any
import re

import yaml

from tactile_bt.errors import YamlError

__all__ = ["Located", "YamlError", "Loader", "load_located", "decode_utf8", "parse_value", "where"]


class Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``1e5`` and ``1.0e6`` as numbers (YAML 1.2 floats)."""


Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def parse_value(text: str):
    """Parse one YAML scalar or flow value (``--set`` values) with :class:`Loader`."""
    return yaml.load(text, Loader=Loader)


@dataclass
class Located:
    """A YAML value together with its position (1-based line and column) in ``file``."""

    value: Any
    file: str
    line: int
    column: int

    def error(self, message: str) -> YamlError:
        return YamlError(message, self.file, self.line, self.column)


def _convert(node: yaml.Node, file: str, constructor: yaml.constructor.SafeConstructor) -> Located:
    mark = node.start_mark
    if isinstance(node, yaml.MappingNode):
        out: dict[str, Located] = {}
        keys: dict[str, Located] = {}
        for knode, vnode in node.value:
            key = constructor.construct_object(knode, deep=True)
            if not isinstance(key, str):
                raise YamlError(f"keys must be strings, got {key!r}", file, knode.start_mark.line + 1, knode.start_mark.column + 1)
            if key in out:
                raise YamlError(f"duplicate key {key!r}", file, knode.start_mark.line + 1, knode.start_mark.column + 1)
            out[key] = _convert(vnode, file, constructor)
            keys[key] = Located(key, file, knode.start_mark.line + 1, knode.start_mark.column + 1)
        located = Located(out, file, mark.line + 1, mark.column + 1)
        located.keys = keys  # type: ignore[attr-defined]
        return located
    if isinstance(node, yaml.SequenceNode):
        return Located([_convert(v, file, constructor) for v in node.value], file, mark.line + 1, mark.column + 1)
    return Located(constructor.construct_object(node, deep=True), file, mark.line + 1, mark.column + 1)


def _position(text: str, offset: int) -> tuple[int, int]:
    """1-based line and column of character ``offset`` of ``text``."""
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def decode_utf8(data: bytes, file: str) -> str:
    """The text of a file's bytes (UTF-8, with or without a byte order mark); a
    :class:`YamlError` naming the line, column and byte offset of the first byte that is not
    UTF-8 otherwise."""
    bom = b"\xef\xbb\xbf"
    body = data[len(bom):] if data.startswith(bom) else data
    try:
        return body.decode("utf-8")
    except UnicodeDecodeError as exc:
        start = exc.start + len(data) - len(body)
        before = data[:start].decode("utf-8", errors="replace")
        line, column = _position(before, len(before))
        raise YamlError(f"not UTF-8 text: byte 0x{data[start]:02x} at byte offset {start} cannot be decoded "
                        "(save the file as UTF-8)", file, line, column) from None


def load_located(source: str | Path, text: str | None = None) -> Located:
    """Parse a YAML file (or ``text`` named ``source``) into nested :class:`Located` values.

    Syntax errors become :class:`YamlError` naming the file and line.
    """
    file = str(source)
    if text is None:
        try:
            data = Path(source).read_bytes()
        except OSError as exc:
            raise YamlError(f"cannot read: {exc.strerror}", file) from None
        text = decode_utf8(data, file)
    try:
        node = yaml.compose(text, Loader=Loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        raise YamlError(f"invalid YAML: {exc.problem}", file, mark.line + 1 if mark else None,
                        mark.column + 1 if mark else None) from None
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow, e.g. a NUL byte
        line, column = _position(text, exc.position)
        code = exc.character if isinstance(exc.character, int) else ord(str(exc.character)[:1] or "\0")
        raise YamlError(f"invalid YAML: the character U+{code:04X} is not allowed in a YAML file", file,
                        line, column) from None
    if node is None:
        raise YamlError("the file is empty", file)
    constructor = Loader("")
    try:
        return _convert(node, file, constructor)
    except yaml.constructor.ConstructorError as exc:
        mark = exc.problem_mark
        raise YamlError(f"invalid value: {exc.problem}", file, mark.line + 1 if mark else None) from None


def plain(value: Any) -> Any:
    """Strip :class:`Located` wrappers recursively."""
    if isinstance(value, Located):
        value = value.value
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def where(value: Located) -> str:
    """``file:line`` of a located value."""
    return f"{value.file}:{value.line}"
