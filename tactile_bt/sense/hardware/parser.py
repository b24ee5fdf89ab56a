"""Incremental parsers of the AGNI serial byte streams, and the messages they return.

:class:`DatagramParser` is an incremental, resynchronising parser for the device-to-host
direction: feed it arbitrary chunks of bytes, it returns the valid datagrams
(:class:`DataDatagram`, :class:`ConfigAnswer`, :class:`DeviceError`) and counts what it had to
throw away (:class:`ParserStats`).  :class:`CommandParser` is the host-to-device counterpart the
emulator uses (it returns :class:`Command` objects).  The framing is described in
:mod:`tactile_bt.sense.hardware.framing`; :mod:`tactile_bt.sense.hardware.protocol` re-exports this module.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Mapping

from tactile_bt.sense.hardware.framing import (
    CMD_SET_PERIOD,
    DID_ERROR,
    DID_MASTER,
    ERROR_CODES,
    HDR1,
    HDR2,
    HEADER,
    TIMESTAMP_LEN,
    checksum,
)

__all__ = ["DataDatagram", "ConfigAnswer", "DeviceError", "Command", "ParserStats", "DatagramParser", "CommandParser"]


@dataclass(frozen=True, slots=True)
class DataDatagram:
    """A checksum-valid data datagram: logical sensor id, raw device timestamp, payload."""

    sensor_id: int
    timestamp: int
    payload: bytes


@dataclass(frozen=True, slots=True)
class ConfigAnswer:
    """The device's configuration: version, device id, ``(type, length)`` per sensor."""

    version: int
    device_id: int
    sensors: tuple[tuple[int, int], ...]


@dataclass(frozen=True, slots=True)
class DeviceError:
    """An error datagram sent by the device (``code`` as in the protocol)."""

    code: int


@dataclass(frozen=True, slots=True)
class Command:
    """A checksum-valid host command as seen by a device."""

    destination: int
    command: int
    data: bytes


@dataclass(slots=True)
class ParserStats:
    """Counters of :class:`DatagramParser`.

    Every byte fed ends up in exactly one of: a returned datagram, ``bytes_skipped``, or the
    parser's pending buffer.
    """

    datagrams: int = 0  #: valid datagrams returned
    checksum_errors: int = 0  #: complete candidates whose checksum failed
    overlaps: int = 0  #: checksum-valid candidates dropped as glued to a following datagram
    resyncs: int = 0  #: times the parser lost sync and had to search for a header
    bytes_skipped: int = 0  #: bytes discarded outside any valid datagram
    bytes_in: int = 0  #: bytes fed in total
    datagram_bytes: int = 0  #: bytes of returned datagrams


_NEED_MORE = object()


class DatagramParser:
    """Incremental, resynchronising parser of the device-to-host byte stream.

    Parameters
    ----------
    lengths
        Payload length in bytes per logical sensor id; datagrams of other ids are not accepted.
    accept_config
        Accept configuration answers (DID 0x00); turn off once streaming to avoid waiting on
        false config headers.

    Notes
    -----
    A candidate starts at every ``F0 C4`` followed by an accepted datagram id; its length
    follows from the id.  A candidate is returned only if its XOR is zero.  On a failed
    candidate the parser moves one byte on and searches the next header, so a datagram that
    follows a torn one is recovered.  An 8-bit XOR passes 1 in 256 random candidates, so a
    torn datagram glued to the next bytes can pass; such a candidate contains the start of the
    next datagram unless line garbage fills the rest of it (then it cannot be told from a valid
    datagram followed by garbage).  A valid candidate with a plausible datagram start inside it is
    therefore accepted only if a header follows it (or nothing yet, when settling) and no
    overlapping valid datagram is followed by a header when it is not; otherwise it is
    dropped and counted in ``overlaps``.  Decisions depend only on the byte stream, never on
    how it was chunked, unless ``settle=True`` forces them early.
    """

    def __init__(self, lengths: Mapping[int, int] | None = None, accept_config: bool = True) -> None:
        self.lengths: dict[int, int] = dict(lengths or {})
        self.accept_config = accept_config
        self.stats = ParserStats()
        self._buf = bytearray()
        self._skipping = False

    @property
    def pending(self) -> int:
        """Bytes held back waiting for more data."""
        return len(self._buf)

    def reset(self) -> None:
        """Drop pending bytes and zero the counters."""
        self._buf.clear()
        self.stats = ParserStats()
        self._skipping = False

    def _length(self, buf: bytearray, i: int) -> int:
        """Datagram length at header ``i``: >0 length, 0 need more bytes, -1 not a datagram."""
        n = len(buf)
        if i + 3 > n:
            return 0
        did = buf[i + 2]
        plen = self.lengths.get(did)
        if plen is not None:
            return 3 + TIMESTAMP_LEN + plen + 1
        if did == DID_MASTER and self.accept_config:
            return 0 if i + 6 > n else 7 + 4 * buf[i + 5]
        if did == DID_ERROR:
            return 0 if i + 4 > n else (5 if buf[i + 3] in ERROR_CODES else -1)
        return -1

    def _skip(self, k: int) -> None:
        if k > 0:
            self.stats.bytes_skipped += k
            if not self._skipping:
                self._skipping = True
                self.stats.resyncs += 1

    @staticmethod
    def _follow(buf: bytearray, e: int) -> int:
        """2 if a header starts at ``e``, 0 if something else does, 1 if unknown yet."""
        n = len(buf)
        if e + 2 <= n:
            return 2 if buf[e] == HDR1 and buf[e + 1] == HDR2 else 0
        if e + 1 == n:
            return 1 if buf[e] == HDR1 else 0
        return 1

    def _arbitrate(self, buf: bytearray, i: int, total: int, settle: bool) -> object:
        """Check the valid candidate at ``i`` against datagram starts inside it.

        Returns None to accept it, the index to resume parsing at to reject it, or _NEED_MORE.
        """
        end, n = i + total, len(buf)
        first = None
        j = buf.find(HEADER, i + 1, end + 1)
        while j >= 0:
            rt = self._length(buf, j)
            if rt != -1:  # a plausible datagram start inside the candidate
                first = j if first is None else first
                if rt == 0 or j + rt > n:
                    if not settle:
                        return _NEED_MORE
                elif checksum(buf[j : j + rt]) == 0:
                    if not settle and max(end, j + rt) + 2 > n:
                        return _NEED_MORE  # decide once both followers are known
                    mine = self._follow(buf, end)
                    return j if mine == 0 or self._follow(buf, j + rt) > mine else None
            j = buf.find(HEADER, j + 1, end + 1)
        if first is None:
            return None
        if not settle and end + 2 > n:
            return _NEED_MORE
        return first if self._follow(buf, end) == 0 else None

    def feed(self, data: bytes | bytearray = b"", settle: bool = False) -> list:
        """Add bytes and return the datagrams completed by them, in stream order.

        Parameters
        ----------
        data
            Next bytes of the stream, any length.
        settle
            Decide pending overlap checks with the bytes at hand (call when the line is idle).

        Returns
        -------
        list
            :class:`DataDatagram`, :class:`ConfigAnswer` and :class:`DeviceError` objects.
        """
        buf = self._buf
        buf += data
        self.stats.bytes_in += len(data)
        out: list = []
        pos = 0
        while True:
            n = len(buf)
            i = buf.find(HEADER, pos)
            if i < 0:
                keep = 1 if n > pos and buf[-1] == HDR1 else 0
                self._skip(n - keep - pos)
                pos = n - keep
                break
            self._skip(i - pos)
            pos = i
            total = self._length(buf, i)
            if total == 0 or (total > 0 and i + total > n):
                break
            if total < 0:
                self._skip(1)
                pos = i + 1
                continue
            chunk = bytes(buf[i : i + total])
            if checksum(chunk) != 0:
                self.stats.checksum_errors += 1
                self._skip(1)
                pos = i + 1
                continue
            verdict = self._arbitrate(buf, i, total, settle)
            if verdict is _NEED_MORE:
                break
            if verdict is not None:
                self.stats.overlaps += 1
                self._skip(verdict - i)
                pos = verdict
                continue
            out.append(_decode(chunk))
            self.stats.datagrams += 1
            self.stats.datagram_bytes += total
            self._skipping = False
            pos = i + total
        del buf[:pos]
        return out


def _decode(chunk: bytes) -> DataDatagram | ConfigAnswer | DeviceError:
    did = chunk[2]
    if did == DID_MASTER:
        n = chunk[5]
        sensors = tuple(struct.unpack_from("<HH", chunk, 6 + 4 * k) for k in range(n))
        return ConfigAnswer(version=chunk[3], device_id=chunk[4], sensors=sensors)
    if did == DID_ERROR:
        return DeviceError(code=chunk[3])
    (ts,) = struct.unpack_from("<I", chunk, 3)
    return DataDatagram(sensor_id=did, timestamp=ts, payload=chunk[7:-1])


@dataclass(slots=True)
class CommandParser:
    """Incremental parser of host commands (the device side, used by the emulator).

    Commands carry data only for ``CMD_SET_PERIOD``: a 2-byte count, then ``count`` bytes
    when addressed to one sensor or ``count`` 3-byte ``(sensor id, period u16)`` items when
    addressed to the master.  Bad checksums are counted in ``checksum_errors``.
    """

    checksum_errors: int = 0
    _buf: bytearray = field(default_factory=bytearray)

    def feed(self, data: bytes) -> list[Command]:
        """Add bytes, return the complete checksum-valid commands."""
        buf = self._buf
        buf += data
        out: list[Command] = []
        pos = 0
        while True:
            i = buf.find(HEADER, pos)
            if i < 0:
                pos = len(buf) - 1 if buf and buf[-1] == HDR1 else len(buf)
                break
            pos = i
            if i + 4 > len(buf):
                break
            dst, cmd = buf[i + 2], buf[i + 3]
            if cmd == CMD_SET_PERIOD:
                if i + 6 > len(buf):
                    break
                (count,) = struct.unpack_from("<H", buf, i + 4)
                dlen = count if dst != DID_MASTER else 3 * count
                total, data_off = 7 + dlen, i + 6
            else:
                total, data_off = 5, i + 4
            if i + total > len(buf):
                break
            if checksum(buf[i : i + total]) != 0:
                self.checksum_errors += 1
                pos = i + 1
                continue
            out.append(Command(dst, cmd, bytes(buf[data_off : i + total - 1])))
            pos = i + total
        del buf[:pos]
        return out
