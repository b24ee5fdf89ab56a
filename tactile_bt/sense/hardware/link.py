"""A simulated pad behind a real serial link: each frame goes through the device emulator, a
pseudo-terminal and :class:`~tactile_bt.sense.hardware.driver.SerialTactileSensor`, byte for byte as a
real module's frames would come (``run_mission(..., via_emulator=True)``).

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import numpy as np

from tactile_bt.defaults import COLS, ROWS
from tactile_bt.sense.hardware.driver import SerialTactileSensor
from tactile_bt.sense.hardware.emulator import DeviceEmulator

__all__ = ["EmulatedSensorLink"]


class EmulatedSensorLink:
    """Push a frame into an emulated device, read it back through the serial driver.

    Parameters
    ----------
    rows, cols : int
        Frame shape.
    timeout : float
        Seconds to wait for each frame (s).
    """

    def __init__(self, rows: int = ROWS, cols: int = COLS, timeout: float = 2.0) -> None:
        self.timeout = float(timeout)
        self.emulator = DeviceEmulator(None, rows=rows, cols=cols, keep_log=False)
        try:
            self.sensor = SerialTactileSensor(self.emulator.port, rows=rows, cols=cols, timeout=timeout)
        except BaseException:
            self.emulator.close()
            raise

    def transfer(self, values: np.ndarray) -> np.ndarray:
        """Send ``values`` (raw counts) over the link and return what the driver delivered."""
        self.emulator.push(values, timeout=self.timeout)
        return self.sensor.read(self.timeout).values

    def close(self) -> None:
        try:
            self.sensor.close()
        finally:
            self.emulator.close()

    def __enter__(self) -> "EmulatedSensorLink":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
