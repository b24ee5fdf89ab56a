"""pyserial driver of a tactile array that speaks the AGNI serial protocol.

A reader thread reads the port as fast as bytes arrive, parses them with the resynchronising
:class:`~tactile_bt.sense.hardware.protocol.DatagramParser`, and publishes every complete frame
twice: as the newest frame (what a control loop wants, :meth:`SerialTactileSensor.read`) and
into a bounded arrival-order queue (what a recorder wants, :meth:`SerialTactileSensor.frames`).

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import collections
import errno
import threading
import time
from dataclasses import dataclass
from typing import Iterator, Mapping, Sequence

import numpy as np
import serial

from tactile_bt.errors import SensorConnectionError, SensorDisconnectedError, SensorError, SensorModuleError
from tactile_bt.defaults import COLS, ROWS
from tactile_bt.sense.hardware import protocol as P
from tactile_bt.sense.hardware.modules import DEFAULT_MODULE, get_module, module_for_type
from tactile_bt.sense.hardware.protocol import TactileFrame

#: Default line rate in baud.  USB CDC devices (the tactile modules) ignore it; a real UART
#: link at 1.9 kHz x 522 bytes needs at least 10 Mbaud.
DEFAULT_BAUDRATE = 1_000_000
#: Default timeout in seconds for the configuration answer, read() and frames().
DEFAULT_TIMEOUT_S = 1.0
#: Frames kept in the arrival-order queue for frames() (about 2 s at 1.9 kHz).
DEFAULT_QUEUE_FRAMES = 4096
_POLL_S = 0.02  # reader thread: serial read timeout; an idle poll settles the parser


@dataclass(frozen=True, slots=True)
class SensorStats:
    """Snapshot of the driver's counters since streaming started.

    ``frames`` counts delivered frames of the tactile sensor; ``checksum_errors`` and
    ``overlaps`` count datagrams dropped as damaged (``dropped`` is their sum); ``resyncs``
    counts losses of synchronisation and ``bytes_skipped`` the bytes thrown away outside
    valid datagrams; ``queue_dropped`` counts frames pushed out of the frames() queue
    because nobody consumed them.
    """

    frames: int
    checksum_errors: int
    overlaps: int
    resyncs: int
    bytes_skipped: int
    bytes_received: int
    other_datagrams: int
    device_errors: int
    queue_dropped: int

    @property
    def dropped(self) -> int:
        """Damaged datagrams detected and discarded."""
        return self.checksum_errors + self.overlaps


class SerialTactileSensor:
    """A tactile array on a serial port (device path or pyserial URL).

    Opening stops any running stream, requests and checks the configuration, selects the
    logical sensor whose data length is ``2 * rows * cols`` bytes (or ``sensor_id``),
    optionally sets its period, starts streaming and starts the reader thread.

    Parameters
    ----------
    port
        Device path (``/dev/ttyACM0``, a pty slave) or pyserial URL.
    baudrate
        Line rate in baud (ignored by USB CDC devices and ptys).
    rows, cols
        Tactel array shape.
    cell_order
        Device cell order: ``cell_order[k]`` is the row-major index of the k-th word sent;
        ``None`` for the module's (below).
    module
        Name of the tactile module (:mod:`tactile_bt.sense.hardware.modules`, e.g.
        ``tactile_module_16x16_v2``), whose cell order the frames are decoded with; not with
        ``cell_order``. Default: the module the configuration answer's sensor type names in
        ``registration``, else row-major.
    registration
        Sensor type numbers -> module names
        (:func:`~tactile_bt.sense.hardware.modules.load_registration`).
    timeout
        Seconds to wait for the configuration answer, and the default of read()/frames().
    sensor_id
        Logical sensor id to use; default: the first sensor with the matching data length.
    period
        If given, sampling period in seconds sent to the sensor (100 us resolution).
    queue_frames
        Capacity of the frames() queue.

    Examples
    --------
    >>> with SerialTactileSensor("/dev/ttyACM0") as sensor:      # doctest: +SKIP
    ...     frame = sensor.read(timeout=0.1)
    ...     frame.values.shape
    (16, 16)
    """

    def __init__(
        self,
        port: str,
        baudrate: int = DEFAULT_BAUDRATE,
        rows: int = ROWS,
        cols: int = COLS,
        cell_order: Sequence[int] | np.ndarray | None = None,
        timeout: float = DEFAULT_TIMEOUT_S,
        sensor_id: int | None = None,
        period: float | None = None,
        queue_frames: int = DEFAULT_QUEUE_FRAMES,
        module: str | None = None,
        registration: Mapping[int, str] | None = None,
    ) -> None:
        self.port, self.rows, self.cols, self.timeout = port, rows, cols, float(timeout)
        use_config = module is None and cell_order is None
        if module is not None:
            if cell_order is not None:
                raise SensorModuleError(f"give the module ({module}) or a cell order, not both")
            cell_order = get_module(module).cell_order(rows, cols)
        #: Name of the module whose cell order decodes the frames (None: the ``cell_order`` given).
        self.module: str | None = module if module is not None else (DEFAULT_MODULE if use_config else None)
        self._inverse = np.argsort(P.cell_permutation(cell_order, rows, cols))
        self._registration = registration if use_config else None
        self._parser = P.DatagramParser()
        self._cond = threading.Condition()
        self._queue: collections.deque[TactileFrame] = collections.deque(maxlen=max(1, int(queue_frames)))
        self._latest: TactileFrame | None = None
        self._seq = self._read_seq = 0
        self._other = self._device_errors = self._queue_dropped = 0
        self._error: SensorError | None = None
        self._stop = threading.Event()
        self._closed = False
        self._thread: threading.Thread | None = None
        self.config: P.ConfigAnswer | None = None
        try:
            self._serial = serial.serial_for_url(port, baudrate=baudrate, timeout=_POLL_S, write_timeout=timeout)
        except (serial.SerialException, OSError, ValueError) as exc:
            hint = ""
            if getattr(exc, "errno", None) == errno.EACCES or "Permission denied" in str(exc):
                hint = " (permission denied: add yourself to the 'dialout' group or install the udev rule)"
            raise SensorConnectionError(f"cannot open tactile sensor port {port!r}: {exc}{hint}") from exc
        try:
            self.sensor_id = self._configure(sensor_id)
            self._choose_module()
            if period is not None:
                self._write(P.set_period_command(self.sensor_id, period))
            self._thread = threading.Thread(target=self._reader, name=f"tactile-reader {port}", daemon=True)
            self._thread.start()
            self.start_streaming()
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ setup
    def _write(self, data: bytes) -> None:
        try:
            self._serial.write(data)
            self._serial.flush()
        except (serial.SerialException, OSError) as exc:
            raise SensorDisconnectedError(f"tactile sensor port {self.port!r} vanished while writing: {exc}") from exc

    def _configure(self, sensor_id: int | None) -> int:
        ser = self._serial
        self._write(P.stop_stream_command())
        time.sleep(0.02)
        try:
            ser.reset_input_buffer()
            self._write(P.config_request_command())
            deadline = time.monotonic() + self.timeout
            answer = None
            while answer is None and time.monotonic() < deadline:
                data = ser.read(max(1, ser.in_waiting))
                answer = next((d for d in self._parser.feed(data) if isinstance(d, P.ConfigAnswer)), None)
        except (serial.SerialException, OSError) as exc:
            raise SensorDisconnectedError(f"tactile sensor port {self.port!r} vanished during configuration: {exc}") from exc
        if answer is None:
            raise SensorConnectionError(
                f"no configuration answer from tactile sensor on {self.port!r} within {self.timeout:g} s"
            )
        if answer.version != P.PROTOCOL_VERSION:
            raise SensorConnectionError(f"{self.port!r}: unsupported protocol version {answer.version}")
        self.config = answer
        lengths = {k + 1: length for k, (_type, length) in enumerate(answer.sensors)}
        want = 2 * self.rows * self.cols
        if sensor_id is None:
            sensor_id = next((sid for sid, length in lengths.items() if length == want), None)
            if sensor_id is None:
                raise SensorConnectionError(
                    f"{self.port!r}: no sensor with {want} data bytes ({self.rows}x{self.cols}) in the "
                    f"configuration {answer.sensors}"
                )
        elif lengths.get(sensor_id) != want:
            raise SensorConnectionError(
                f"{self.port!r}: sensor {sensor_id} has {lengths.get(sensor_id)} data bytes, expected {want}"
            )
        self._parser.lengths = lengths
        self._parser.accept_config = False
        self._parser.stats = P.ParserStats()  # count the stream only
        return sensor_id

    def _choose_module(self) -> None:
        """Decode with the module the configuration's sensor type names in the registration,
        when neither a module nor a cell order was given (row-major when it names none)."""
        if not self._registration:
            return
        found = module_for_type(self.config.sensors[self.sensor_id - 1][0], self._registration)
        if found is None:
            return
        try:
            order = found.cell_order(self.rows, self.cols)
        except SensorModuleError as exc:
            raise SensorConnectionError(f"{self.port!r}: the device's configuration names {exc}") from None
        self._inverse = np.argsort(P.cell_permutation(order, self.rows, self.cols))
        self.module = found.name

    # ------------------------------------------------------------------ reader thread
    def _reader(self) -> None:
        ser, parser = self._serial, self._parser
        try:
            while not self._stop.is_set():
                data = ser.read(max(1, ser.in_waiting))
                if data:
                    waiting = ser.in_waiting
                    if waiting:
                        data += ser.read(waiting)
                elif not parser.pending:
                    continue
                with self._cond:  # counters change together with the parser state
                    items = parser.feed(data, settle=not data)
                arrival = time.monotonic()
                if items:
                    self._publish(items, arrival)
        except Exception as exc:  # noqa: BLE001 - any failure of the port ends the stream
            if not self._stop.is_set():
                err = SensorDisconnectedError(f"tactile sensor port {self.port!r} vanished: {exc}")
                err.__cause__ = exc
                with self._cond:
                    self._error = err
        finally:
            with self._cond:
                self._cond.notify_all()

    def _publish(self, items: list, arrival: float) -> None:
        frames = []
        for d in items:
            if isinstance(d, P.DataDatagram) and d.sensor_id == self.sensor_id:
                values = P.decode_values(d.payload, self._inverse, self.rows, self.cols)
                frames.append(TactileFrame(values, arrival, d.sensor_id, d.timestamp))
            elif isinstance(d, P.DeviceError):
                self._device_errors += 1
            else:
                self._other += 1
        if not frames:
            return
        with self._cond:
            queue = self._queue
            for frame in frames:
                if len(queue) == queue.maxlen:
                    self._queue_dropped += 1
                queue.append(frame)
            self._latest = frames[-1]
            self._seq += len(frames)
            self._cond.notify_all()

    # ------------------------------------------------------------------ public API
    def start_streaming(self) -> None:
        """Send 'start continuous streaming of all sensors'."""
        self._write(P.start_stream_command())

    def stop_streaming(self) -> None:
        """Send 'stop streaming'; frames already on the line are still delivered."""
        self._write(P.stop_stream_command())

    def _check(self) -> None:
        if self._error is not None:
            raise self._error
        if self._closed:
            raise SensorError(f"tactile sensor on {self.port!r} is closed")

    def read(self, timeout: float | None = None) -> TactileFrame:
        """Newest complete frame not returned by read() before.

        Waits up to ``timeout`` seconds (default: the constructor's) for one; older frames
        are skipped.  Raises :class:`TimeoutError` when none comes,
        :class:`SensorDisconnectedError` as soon as the port has vanished and
        :class:`SensorError` once the sensor is closed, even if frames that arrived before
        that were never read (a control loop must not act on a stale frame of a dead link).
        """
        timeout = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + timeout
        with self._cond:
            self._check()
            while self._seq == self._read_seq:
                self._check()
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise TimeoutError(f"no tactile frame from {self.port!r} within {timeout:g} s")
                self._cond.wait(remaining)
            self._read_seq = self._seq
            assert self._latest is not None
            return self._latest

    def frames(self, timeout: float | None = None) -> Iterator[TactileFrame]:
        """Yield every frame in arrival order; stop after ``timeout`` s without a frame.

        Raises :class:`SensorDisconnectedError` (after the queued frames) if the port vanished.
        """
        timeout = self.timeout if timeout is None else timeout
        while True:
            with self._cond:
                deadline = time.monotonic() + timeout
                while not self._queue:
                    if self._error is not None:
                        raise self._error
                    remaining = deadline - time.monotonic()
                    if self._closed or remaining <= 0:
                        return
                    self._cond.wait(remaining)
                frame = self._queue.popleft()  # one at a time: breaking out loses nothing
            yield frame

    @property
    def stats(self) -> SensorStats:
        """Counters since streaming started (a consistent snapshot)."""
        with self._cond:
            s = self._parser.stats
            return SensorStats(
                frames=self._seq,
                checksum_errors=s.checksum_errors,
                overlaps=s.overlaps,
                resyncs=s.resyncs,
                bytes_skipped=s.bytes_skipped,
                bytes_received=s.bytes_in,
                other_datagrams=self._other,
                device_errors=self._device_errors,
                queue_dropped=self._queue_dropped,
            )

    def close(self) -> None:
        """Stop streaming, stop the reader thread and close the port (idempotent)."""
        if self._closed:
            return
        ser = getattr(self, "_serial", None)
        if ser is not None and self._error is None:
            try:
                ser.write(P.stop_stream_command())
            except Exception:  # noqa: BLE001 - the port may already be gone
                pass
        self._stop.set()
        if ser is not None and hasattr(ser, "cancel_read"):
            try:
                ser.cancel_read()
            except Exception:  # noqa: BLE001
                pass
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if ser is not None:
            try:
                ser.close()
            except Exception:  # noqa: BLE001
                pass
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def __enter__(self) -> "SerialTactileSensor":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # last resort; close() explicitly or use ``with``
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass
