"""Wire constants of the AGNI serial protocol subset: header, ids, commands, error codes, checksum.

The shared vocabulary of the datagram builders (:mod:`tactile_bt.sense.hardware.protocol`) and the
incremental parsers (:mod:`tactile_bt.sense.hardware.parser`); ``protocol`` re-exports all of it.
Framing (see ``docs/hardware.md`` for the byte tables)::

    data datagram     F0 C4 <lid 0x01..0xC9> <timestamp u32 LE> <payload> <xor>
    config answer     F0 C4 00 <version> <device id> <n> n x (<type u16 LE> <length u16 LE>) <xor>
    device error      F0 C4 FE <code> <xor>
    host command      F0 C4 <destination> <command> [<count u16 LE> <data>] <xor>

``xor`` is the XOR of every byte before it, header included, so the XOR over a whole valid
datagram is zero (:func:`checksum`).

Layer: sense (the serial sensor).
"""

from __future__ import annotations

from functools import reduce
from operator import xor

import numpy as np

from tactile_bt.defaults import ADC_MAX

HEADER = b"\xf0\xc4"
HDR1, HDR2 = 0xF0, 0xC4
PROTOCOL_VERSION = 1
DID_MASTER = 0x00
LID_MIN, LID_MAX = 0x01, 0xC9
DID_ERROR = 0xFE
CMD_STOP_STREAM = 0x00
CMD_CONFIG_REQUEST = 0xC0
CMD_SET_PERIOD = 0xD0
CMD_START_STREAM = 0xF1
ERR_UNKNOWN, ERR_CHECKSUM, ERR_UNKNOWN_COMMAND, ERR_UNKNOWN_SENSOR = 0x00, 0xF0, 0xF1, 0xF2
ERROR_CODES = frozenset({ERR_UNKNOWN, ERR_CHECKSUM, ERR_UNKNOWN_COMMAND, ERR_UNKNOWN_SENSOR})
#: Unit of the set-period command in seconds (the device counts in 100 us steps).
PERIOD_UNIT_S = 1e-4
#: Sensor type the emulator announces.  0x0000 is the reference implementation's "undefined"
#: type: the driver identifies the tactile array by its data length, not by this number.
EMULATED_SENSOR_TYPE = 0x0000
TIMESTAMP_LEN = 4
VALUE_MASK = ADC_MAX  # low 12 bits carry the tactel value


def checksum(data: bytes | bytearray | memoryview) -> int:
    """XOR of all bytes of ``data`` (0..255); a valid datagram XORs to 0 as a whole."""
    if len(data) < 64:
        return reduce(xor, bytes(data), 0)
    return int(np.bitwise_xor.reduce(np.frombuffer(bytes(data), dtype=np.uint8)))
