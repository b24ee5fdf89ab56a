"""Real tactile sensors over serial: the AGNI serial protocol, a device emulator, record/replay.

Public names (imported lazily, so ``import tactile_bt.sense.hardware`` stays cheap)::

    SerialTactileSensor, TactileFrame, SensorStats, SensorError, SensorConnectionError,
    SensorDisconnectedError                                    (driver, protocol)
    TactileModule, get_module, load_registration               (modules: cell orders)
    DeviceEmulator, FaultConfig                                (emulator)
    Recorder, read_recording, replay, RecordingError,
    RecordingWarning                                           (recording)

Raw counts only: converting counts to newtons is :mod:`tactile_bt.sense.calibration`'s job.
See ``docs/hardware.md`` for the protocol subset, connecting a sensor and the file format.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "SerialTactileSensor": "driver",
    "SensorStats": "driver",
    "SensorError": "driver",
    "SensorConnectionError": "driver",
    "SensorDisconnectedError": "driver",
    "TactileFrame": "protocol",
    "DatagramParser": "protocol",
    "TactileModule": "modules",
    "get_module": "modules",
    "load_registration": "modules",
    "DeviceEmulator": "emulator",
    "FaultConfig": "emulator",
    "Recorder": "recording",
    "Recording": "recording",
    "RecordingError": "recording",
    "RecordingWarning": "recording",
    "read_recording": "recording",
    "iter_chunks": "recording",
    "replay": "recording",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'tactile_bt.sense.hardware' has no attribute {name!r}")
    return getattr(importlib.import_module(f"tactile_bt.sense.hardware.{module}"), name)


def __dir__() -> list[str]:
    return __all__
