"""The trees, scenes, meshes and studies that ship with tactile_bt.

In a checkout they are the folders ``trees/``, ``sim/`` and ``studies/`` beside the package. A
built package (a wheel, ``pip install .``) carries a copy of them in ``tactile_bt/_shipped/``,
made by ``setup.py`` at build time, so that every command finds them wherever the package is
installed. :func:`resolve` lets a relative path such as ``sim/cable.yaml`` name a shipped file
when no such file exists where the command runs; ``tactile-bt examples`` lists and copies them.

Layer: base.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

__all__ = ["FOLDERS", "ShippedFile", "root", "path", "resolve", "listing", "copy_to"]

#: The shipped folders and what they hold.
FOLDERS: dict[str, str] = {
    "trees": "behaviour trees (YAML) and the subtrees they include (trees/lib/)",
    "sim": "simulated scenes (YAML) and the meshes they use (sim/meshes/)",
    "studies": "sweep specifications for 'tactile-bt sweep'",
}
_PACKAGE = Path(__file__).resolve().parent
_SKIP = {"__pycache__"}


def root() -> Path:
    """The folder that holds ``trees/``, ``sim/`` and ``studies/``: the package's copy when the
    package was built (installed from a wheel), else the checkout the package lies in."""
    packaged = _PACKAGE / "_shipped"
    return packaged if packaged.is_dir() else _PACKAGE.parent


def path(relative: str | Path) -> Path:
    """The shipped file ``relative`` (e.g. ``"sim/cable.yaml"``).

    Raises
    ------
    FileNotFoundError
        When the package ships no such file (the message lists the folders it ships).
    """
    p = root() / relative
    if not p.exists():
        raise FileNotFoundError(f"{relative}: tactile_bt ships no such file (it ships {', '.join(FOLDERS)}; "
                                "'tactile-bt examples' lists them)")
    return p


def resolve(given: str | Path) -> Path:
    """``given`` if it exists; else, for a relative path into a shipped folder
    (``trees/...``, ``sim/...``, ``studies/...``), the shipped file of that name if there is one;
    else ``given`` unchanged (so that reading it gives the usual error)."""
    p = Path(given)
    if p.exists() or p.is_absolute() or not p.parts or p.parts[0] not in FOLDERS:
        return p
    shipped = root() / p
    return shipped if shipped.is_file() else p


@dataclass(frozen=True)
class ShippedFile:
    """One shipped file: its path relative to :func:`root` and the first line of its comment."""

    relative: str
    summary: str


def _summary(file: Path) -> str:
    if file.suffix not in (".yaml", ".yml", ".py", ".md"):
        return ""
    try:
        with file.open(encoding="utf-8") as stream:
            for line in stream:
                text = line.strip().lstrip("#").strip()
                if text and not text.startswith(("!", '"""')):
                    return text.removeprefix("# ")
    except (OSError, UnicodeDecodeError):
        return ""
    return ""


def _files() -> list[Path]:
    base = root()
    found: list[Path] = []
    for folder in FOLDERS:
        top = base / folder
        if top.is_dir():
            found += [f for f in sorted(top.rglob("*")) if f.is_file() and not _SKIP & set(f.parts)]
    return found


def listing() -> list[ShippedFile]:
    """Every shipped file, folder by folder, with the first line of its comment."""
    base = root()
    return [ShippedFile(f.relative_to(base).as_posix(), _summary(f)) for f in _files()]


def copy_to(target: str | Path, force: bool = False) -> list[Path]:
    """Copy every shipped file into ``target`` (``target/trees/...``, ``target/sim/...``), keeping the
    folders, so that trees and scenes can be edited and their relative paths still hold.

    Raises
    ------
    FileExistsError
        When a file to be written exists already and ``force`` is false; nothing is written then.
    """
    base, target = root(), Path(target)
    pairs = [(f, target / f.relative_to(base)) for f in _files()]
    existing = [dst for _, dst in pairs if dst.exists()]
    if existing and not force:
        raise FileExistsError(f"{existing[0]} exists already ({len(existing)} of the {len(pairs)} files do; "
                              "--force overwrites them)")
    for src, dst in pairs:
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)
    return [dst for _, dst in pairs]
