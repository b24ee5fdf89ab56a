"""The subset of the AGNI serial protocol spoken by the Bielefeld tactile modules.

Framing (see ``docs/hardware.md`` for the byte tables)::

    data datagram     F0 C4 <lid 0x01..0xC9> <timestamp u32 LE> <payload> <xor>
    config answer     F0 C4 00 <version> <device id> <n> n x (<type u16 LE> <length u16 LE>) <xor>
    device error      F0 C4 FE <code> <xor>
    host command      F0 C4 <destination> <command> [<count u16 LE> <data>] <xor>

``xor`` is the XOR of every byte before it, header included, so the XOR over a whole valid
datagram is zero.  The 16x16 module's payload is 256 little-endian 16-bit words whose low 12
bits are the tactel values, in the device's cell order.

This module builds datagrams and host commands, maps tactel arrays to and from payloads in the
device's cell order and defines :class:`TactileFrame`, the decoded image.  It re-exports the
wire constants and :func:`checksum` (:mod:`tactile_bt.sense.hardware.framing`) and the parsers
(:mod:`tactile_bt.sense.hardware.parser`): :class:`DatagramParser`, an incremental, resynchronising
parser for the device-to-host direction (feed it arbitrary chunks of bytes, it returns the valid
datagrams and counts what it had to throw away), and :class:`CommandParser`, the host-to-device
counterpart the emulator uses.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from tactile_bt.errors import ProtocolError
from tactile_bt.defaults import COLS, ROWS
from tactile_bt.sense.hardware.framing import (  # noqa: F401 - re-exported
    CMD_CONFIG_REQUEST,
    CMD_SET_PERIOD,
    CMD_START_STREAM,
    CMD_STOP_STREAM,
    DID_ERROR,
    DID_MASTER,
    EMULATED_SENSOR_TYPE,
    ERR_CHECKSUM,
    ERR_UNKNOWN,
    ERR_UNKNOWN_COMMAND,
    ERR_UNKNOWN_SENSOR,
    ERROR_CODES,
    HDR1,
    HDR2,
    HEADER,
    LID_MAX,
    LID_MIN,
    PERIOD_UNIT_S,
    PROTOCOL_VERSION,
    TIMESTAMP_LEN,
    VALUE_MASK,
    checksum,
)
from tactile_bt.sense.hardware.parser import (  # noqa: F401 - re-exported
    Command,
    CommandParser,
    ConfigAnswer,
    DataDatagram,
    DatagramParser,
    DeviceError,
    ParserStats,
)


def _seal(body: bytes) -> bytes:
    """``body`` with its XOR checksum byte appended."""
    return body + bytes((checksum(body),))


# --------------------------------------------------------------------------- builders
def build_command(destination: int, command: int, data: bytes = b"", count: int | None = None) -> bytes:
    """Host command ``F0 C4 <dst> <cmd> [<count u16> <data>] <xor>``.

    ``count`` is the protocol's item count (defaults to ``len(data)``); the reference
    implementation sends the number of 3-byte items for the master period command.
    """
    body = HEADER + bytes((destination & 0xFF, command & 0xFF))
    if data:
        body += struct.pack("<H", len(data) if count is None else count) + bytes(data)
    return _seal(body)


def stop_stream_command() -> bytes:
    """Stop streaming of all sensors (``F0 C4 00 00 34``)."""
    return build_command(DID_MASTER, CMD_STOP_STREAM)


def config_request_command() -> bytes:
    """Ask the device for its configuration (``F0 C4 00 C0 F4``)."""
    return build_command(DID_MASTER, CMD_CONFIG_REQUEST)


def start_stream_command() -> bytes:
    """Start continuous streaming of all sensors (``F0 C4 00 F1 C5``)."""
    return build_command(DID_MASTER, CMD_START_STREAM)


def period_units(period_s: float) -> int:
    """Period in seconds -> device units of 100 us, clamped to 1..65535."""
    return int(min(65535, max(1, round(period_s / PERIOD_UNIT_S))))


def set_period_command(sensor_id: int, period_s: float) -> bytes:
    """Set the sampling period of one logical sensor, in seconds (100 us resolution)."""
    return build_command(sensor_id, CMD_SET_PERIOD, struct.pack("<H", period_units(period_s)))


def build_config_answer(device_id: int, sensors: Sequence[tuple[int, int]], version: int = PROTOCOL_VERSION) -> bytes:
    """Device configuration answer; ``sensors`` lists ``(sensor type, data length in bytes)``."""
    body = HEADER + bytes((DID_MASTER, version & 0xFF, device_id & 0xFF, len(sensors)))
    for stype, length in sensors:
        body += struct.pack("<HH", stype, length)
    return _seal(body)


def build_error(code: int) -> bytes:
    """Device error datagram ``F0 C4 FE <code> <xor>``."""
    return _seal(HEADER + bytes((DID_ERROR, code & 0xFF)))


def build_data_datagram(sensor_id: int, timestamp: int, payload: bytes) -> bytes:
    """Data datagram of logical sensor ``sensor_id`` with a raw 32-bit device timestamp."""
    if not LID_MIN <= sensor_id <= LID_MAX:
        raise ProtocolError(f"sensor id {sensor_id} outside {LID_MIN}..{LID_MAX}")
    return _seal(HEADER + bytes((sensor_id,)) + struct.pack("<I", timestamp & 0xFFFFFFFF) + bytes(payload))


# --------------------------------------------------------------------------- cell order
def cell_permutation(cell_order: Sequence[int] | np.ndarray | None, rows: int = ROWS, cols: int = COLS) -> np.ndarray:
    """Validate a cell-order table.

    ``cell_order[k]`` is the row-major flat index ``row * cols + col`` of the tactel the device
    sends as its k-th word.  ``None`` means the device sends row-major order (row 0 first).
    """
    n = rows * cols
    if cell_order is None:
        return np.arange(n, dtype=np.intp)
    order = np.asarray(cell_order, dtype=np.intp).ravel()
    if order.shape != (n,) or not np.array_equal(np.sort(order), np.arange(n)):
        raise ProtocolError(f"cell_order must be a permutation of 0..{n - 1} ({rows}x{cols} tactels)")
    return order


def encode_values(values: np.ndarray, order: np.ndarray, high_bits: np.ndarray | None = None) -> bytes:
    """(rows, cols) raw counts -> payload bytes in device cell order.

    ``high_bits`` optionally sets the 4 non-data bits of each word (device order).
    """
    words = np.asarray(values, dtype=np.uint16).ravel()[order]
    if high_bits is not None:
        words = (words & VALUE_MASK) | (np.asarray(high_bits, dtype=np.uint16) << 12)
    return words.astype("<u2").tobytes()


def decode_values(payload: bytes, inverse: np.ndarray, rows: int = ROWS, cols: int = COLS) -> np.ndarray:
    """Payload -> (rows, cols) uint16 raw counts; ``inverse`` is ``argsort(order)``."""
    words = np.frombuffer(payload, dtype="<u2")
    return (words[inverse] & VALUE_MASK).astype(np.uint16).reshape(rows, cols)


# --------------------------------------------------------------------------- frames
@dataclass(frozen=True, eq=False, slots=True)
class TactileFrame:
    """One tactile image as delivered by the driver, a recording or the emulator's log.

    Attributes
    ----------
    values
        ``(rows, cols)`` uint16 raw ADC counts (12 bit), row-major, row = sensor y, col = x.
    timestamp
        Seconds.  Driver: host ``time.monotonic()`` when the bytes arrived; recording/replay:
        the recorded value.
    sensor_id
        Logical sensor id of the datagram (1..201).
    device_timestamp
        Raw 32-bit timestamp counter of the datagram (device units; the emulator counts us).
    """

    values: np.ndarray
    timestamp: float
    sensor_id: int = 1
    device_timestamp: int = 0
