"""Fault injection of the device emulator: what can go wrong on the line, and the ground truth.

:class:`FaultConfig` holds the per-frame fault probabilities; the damage functions
(:func:`choose_fault`, :func:`plant_header`, :func:`flip_bit`, :func:`tear`,
:func:`garbage_burst`) apply them to one datagram with the emulator's random generator; and
:class:`EmulatorLog` (with one :class:`SentFrame` per frame) records what was sent, so tests can
check the driver's frames and counters against it.  :mod:`tactile_bt.sense.hardware.emulator`
re-exports these names.

To keep that ground truth exact, garbage never contains ``0xF0``, bit flips hit only bytes
after the datagram id and never create a new header pattern, tears keep at least header and
id, and a header pattern is only planted in undamaged frames that no garbage follows (the
parser drops a frame that carries a datagram start and is followed by junk: on a real line that
is far more often a torn datagram passing the checksum by chance).  The emulator adds what
depends on the bytes around a frame: no timestamp forms a header pattern, no garbage continues
one, and a torn datagram never passes the 8-bit XOR together with the bytes that follow it
(1 in 256 would, which the parser could not tell from a valid frame followed by garbage, or
would drop as an overlap together with the damaged frames inside it): when the next bytes
would complete it with a zero XOR, one filler byte of garbage goes first.  So every damaged
frame costs the parser exactly one checksum error, as long as the host keeps reading (a line
stalled for 0.5 s tears frames wherever it stops).

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields

import numpy as np

from tactile_bt.sense.hardware.framing import HDR1, HEADER

__all__ = [
    "FaultConfig",
    "SentFrame",
    "EmulatorLog",
    "choose_fault",
    "plant_header",
    "flip_bit",
    "tear",
    "garbage_burst",
]

#: Largest garbage burst (bytes) a fault configuration may ask for.
GARBAGE_MAX_LIMIT = 65536
_PROBABILITIES = ("garbage", "bitflip", "tear", "pause", "header")
GARBAGE_ALPHABET = np.array([b for b in range(256) if b != HDR1], dtype=np.uint8)


@dataclass
class FaultConfig:
    """Per-frame fault probabilities (0..1) of the emulated line.

    ``garbage``: a burst of 1..``garbage_max`` random bytes after the frame; ``bitflip``: one
    flipped bit; ``tear``: the datagram is cut short; ``pause``: the line goes quiet for
    ``pause_s`` seconds after the frame; ``header``: the payload carries ``F0 C4 <id>`` in its
    non-data bits (the frame stays valid).  At most one of bitflip/tear/header per frame.
    """

    garbage: float = 0.0
    bitflip: float = 0.0
    tear: float = 0.0
    pause: float = 0.0
    header: float = 0.0
    garbage_max: int = 64
    pause_s: float = 0.01

    def __post_init__(self) -> None:
        self.check()

    def check(self) -> None:
        """Raise ValueError naming the field unless the probabilities lie in 0..1 (bitflip, tear
        and header together at most 1: at most one of them per frame), ``garbage_max`` is an
        integer from 1 to ``GARBAGE_MAX_LIMIT`` and ``pause_s`` a finite number >= 0."""
        for name in _PROBABILITIES:
            p = getattr(self, name)
            if not (isinstance(p, numbers.Real) and 0.0 <= p <= 1.0):
                raise ValueError(f"fault {name}={p:g}: a probability must lie in 0..1"
                                 if isinstance(p, numbers.Real) else f"fault {name}={p!r}: not a number")
        exclusive = self.bitflip + self.tear + self.header
        if exclusive > 1.0:
            raise ValueError(f"faults bitflip={self.bitflip:g} + tear={self.tear:g} + header={self.header:g} = "
                             f"{exclusive:g} exceed 1 (at most one of them per frame)")
        g = self.garbage_max
        if isinstance(g, bool) or not isinstance(g, numbers.Integral) or not 1 <= g <= GARBAGE_MAX_LIMIT:
            raise ValueError(f"fault garbage_max={g!r}: expected an integer from 1 to {GARBAGE_MAX_LIMIT}")
        if not (isinstance(self.pause_s, numbers.Real) and math.isfinite(self.pause_s) and self.pause_s >= 0):
            raise ValueError(f"fault pause_s={self.pause_s}: expected a finite number of seconds >= 0")

    @classmethod
    def parse(cls, spec: str | None) -> "FaultConfig":
        """Parse ``"garbage=0.01,bitflip=0.01,tear=0.01,pause=0.001,header=0.05"``.

        ``all=P`` sets the five probabilities at once.  Raises ValueError naming the item on an
        unknown name, a malformed number or a value out of range (see :meth:`check`).
        """
        cfg = cls()
        names = [f.name for f in fields(cls)]
        for item in filter(None, (s.strip() for s in (spec or "").split(","))):
            key, sep, value = item.partition("=")
            key = key.strip()
            if key != "all" and key not in names:
                raise ValueError(f"unknown fault {key!r} in {item!r}; known: all, {', '.join(names)}")
            try:
                number = float(value) if sep else None
            except ValueError:
                number = None
            if number is None:
                raise ValueError(f"fault spec {item!r}: expected name=number")
            if key == "garbage_max" and number.is_integer():
                number = int(number)
            for name in _PROBABILITIES if key == "all" else (key,):
                setattr(cfg, name, number)
        cfg.check()
        return cfg


@dataclass(eq=False)
class SentFrame:
    """Ground truth of one emitted frame: values as the driver must decode them."""

    index: int
    values: np.ndarray
    device_timestamp: int
    fault: str | None = None  #: "bitflip" or "tear" (damaged), else None
    header_pattern: bool = False  #: a header pattern was planted in the payload
    pushed: bool = False


@dataclass
class EmulatorLog:
    """What the emulator sent, in order: ``events`` is a list of ``(kind, value)`` with kinds
    ``frame`` (index into ``frames``), ``garbage`` (bytes) and ``pause`` (seconds)."""

    frames: list[SentFrame] = field(default_factory=list)
    events: list[tuple[str, float]] = field(default_factory=list)
    garbage_bytes: int = 0

    def intact(self) -> list[SentFrame]:
        """Frames sent undamaged: the driver must deliver exactly these."""
        return [f for f in self.frames if f.fault is None]

    def damaged(self) -> list[SentFrame]:
        """Frames sent damaged: the driver must drop exactly these."""
        return [f for f in self.frames if f.fault is not None]

    def expected_resyncs(self) -> int:
        """Runs of garbage/damaged frames that end in an intact frame (one resync each)."""
        runs, in_run = 0, False
        for kind, value in self.events:
            if kind == "garbage" or (kind == "frame" and self.frames[int(value)].fault):
                in_run = True
            elif kind == "frame":
                runs += in_run
                in_run = False
        return runs



def choose_fault(faults: FaultConfig, rng: np.random.Generator) -> str | None:
    """Draw the datagram fault of one frame: ``"bitflip"``, ``"tear"``, ``"header"`` or None."""
    r = rng.random()
    for name, p in (("bitflip", faults.bitflip), ("tear", faults.tear), ("header", faults.header)):
        if r < p:
            return name
        r -= p
    return None


def plant_header(values: np.ndarray, order: np.ndarray, sensor_id: int,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Make words w, w+1 read ``F0 C4 <id>``: value 0x4F0 with high nibble 0xC, then id.

    Parameters
    ----------
    values
        ``(rows, cols)`` raw counts of the frame (not modified).
    order
        Device cell order (:func:`~tactile_bt.sense.hardware.protocol.cell_permutation`).
    sensor_id
        Logical sensor id the planted pattern names.
    rng
        Random generator that picks the word.

    Returns
    -------
    tuple
        The changed counts and the high nibbles of the words (device order), as
        :func:`~tactile_bt.sense.hardware.protocol.encode_values` takes them.
    """
    n = len(order)
    w = int(rng.integers(0, n - 1))
    flat = values.ravel().copy()
    flat[order[w]] = 0x4F0
    flat[order[w + 1]] = (flat[order[w + 1]] & 0xF00) | sensor_id
    high = np.zeros(n, dtype=np.uint16)
    high[w] = 0xC
    return flat.reshape(values.shape), high


def flip_bit(datagram: bytes, rng: np.random.Generator) -> bytes:
    """``datagram`` with one bit flipped after the datagram id, creating no new header pattern.

    If 64 random tries all would, the checksum byte is changed instead.
    """
    count = datagram.count(HEADER)
    for _ in range(64):
        pos = int(rng.integers(3, len(datagram)))
        damaged = bytearray(datagram)
        damaged[pos] ^= 1 << int(rng.integers(0, 8))
        if damaged.count(HEADER) == count and damaged[-1] != HDR1:
            return bytes(damaged)
    damaged = bytearray(datagram)
    damaged[-1] ^= 0x01 if damaged[-1] != 0xF1 else 0x02
    return bytes(damaged)


def tear(datagram: bytes, rng: np.random.Generator) -> bytes:
    """``datagram`` cut short, keeping at least the header and the datagram id."""
    return datagram[: int(rng.integers(3, len(datagram)))]


def garbage_burst(faults: FaultConfig, rng: np.random.Generator) -> bytes:
    """1..``faults.garbage_max`` random bytes, none of them ``0xF0`` (so no header starts)."""
    return rng.choice(GARBAGE_ALPHABET, size=int(rng.integers(1, max(1, faults.garbage_max) + 1))).tobytes()
