"""A tactile module emulated behind a pseudo-terminal pair, with fault injection.

The emulator opens a pty pair with :func:`os.openpty`; a driver opens the slave path
(:attr:`DeviceEmulator.port`) exactly as it would open ``/dev/ttyACM0``.  A thread reads host
commands from the master side, answers the configuration request, and while streaming writes
one data datagram per period from its frame source.  :meth:`DeviceEmulator.push` sends one
given frame immediately (the closed-loop mission renders a frame, pushes it, and reads it back).

Faults (:class:`FaultConfig`) damage the byte stream the way real lines do.  Everything sent is
logged in :attr:`DeviceEmulator.log`, so tests can check the driver's frames and counters
against the ground truth.  The faults, the damage they do and the log are
:mod:`tactile_bt.sense.hardware.faults` (re-exported here), which also says how the ground truth is
kept exact.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import os
import select
import sys
import threading
import time
import tty
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from tactile_bt.defaults import ADC_MAX, COLS, MAX_SENSOR_RATE_HZ, ROWS
from tactile_bt.errors import SensorModuleError
from tactile_bt.sense.hardware import protocol as P
from tactile_bt.sense.hardware.modules import DEFAULT_MODULE, get_module
from tactile_bt.sense.hardware.framing import HEADER
from tactile_bt.sense.hardware.faults import GARBAGE_ALPHABET  # noqa: F401 - re-exported
from tactile_bt.sense.hardware.faults import (
    EmulatorLog,
    FaultConfig,
    SentFrame,
    choose_fault,
    flip_bit,
    garbage_burst,
    plant_header,
    tear,
)

FrameSource = Callable[[], np.ndarray] | Iterable[np.ndarray] | str | Path | None


def synthetic_source(rows: int = ROWS, cols: int = COLS, rate_hz: float = MAX_SENSOR_RATE_HZ,
                     seed: int = 0) -> Iterator[np.ndarray]:
    """Endless raw-count frames: a noisy contact blob circling the pad centre every 4 s."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:rows, 0:cols].astype(float)
    k = 0
    while True:
        t = k / rate_hz
        cx = (cols - 1) / 2 + 0.25 * cols * np.cos(0.5 * np.pi * t)
        cy = (rows - 1) / 2 + 0.25 * rows * np.sin(0.5 * np.pi * t)
        img = 40.0 + 2500.0 * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / 4.5) + rng.normal(0.0, 8.0, (rows, cols))
        yield np.clip(np.rint(img), 0, ADC_MAX).astype(np.uint16)
        k += 1


def _recording_source(path: str | Path, loop: bool) -> Iterator[np.ndarray]:
    from tactile_bt.sense.hardware.recording import iter_chunks

    while True:
        n = 0
        for chunk in iter_chunks(path):
            n += len(chunk.values)
            yield from chunk.values
        if not loop or n == 0:
            return


def as_counts(values: object, rows: int, cols: int) -> np.ndarray:
    """Validate a frame: (rows, cols) integers in 0..4095 -> uint16 array (a copy)."""
    arr = np.asarray(getattr(values, "values", values))
    if arr.shape != (rows, cols):
        raise ValueError(f"frame shape {arr.shape}, expected ({rows}, {cols})")
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)):
            raise ValueError("frame contains NaN or infinite values")
        arr = np.rint(arr)
    if arr.size and (arr.min() < 0 or arr.max() > ADC_MAX):
        raise ValueError(f"raw counts must lie in 0..{ADC_MAX}, got {arr.min()}..{arr.max()}")
    return arr.astype(np.uint16)


class DeviceEmulator:
    """An emulated tactile module on a pseudo-terminal; open :attr:`port` with the driver.

    Parameters
    ----------
    source
        Frames to stream: a callable returning a (rows, cols) raw-count array, an iterable of
        arrays, the path of a recording (looped when ``loop``), or ``None`` for push only.
    rate_hz
        Streaming rate in Hz until the host sets a period.
    rows, cols, cell_order
        Array shape and device cell order (as for the driver).
    module
        Name of the tactile module emulated (:mod:`tactile_bt.sense.hardware.modules`): its words
        go out in that module's cell order; not with ``cell_order``. Default: row-major.
    sensor_id, device_id, sensor_type
        Identity announced in the configuration answer.
    faults
        Fault injection (:class:`FaultConfig` or a spec string); ``None`` for a clean line.
    seed
        Seed of the fault generator (same seed, same faults for the same frames).
    keep_log
        Keep the ground truth of every frame in :attr:`log` (off for long CLI runs).
    """

    def __init__(self, source: FrameSource = None, *, rate_hz: float = MAX_SENSOR_RATE_HZ, rows: int = ROWS,
                 cols: int = COLS, cell_order: Iterable[int] | None = None, sensor_id: int = 1,
                 device_id: int = 1, sensor_type: int = P.EMULATED_SENSOR_TYPE,
                 faults: FaultConfig | str | None = None, seed: int = 0, loop: bool = True,
                 keep_log: bool = True, module: str | None = None) -> None:
        self.rows, self.cols, self.sensor_id, self.device_id = rows, cols, sensor_id, device_id
        if module is not None:
            if cell_order is not None:
                raise SensorModuleError(f"give the module ({module}) or a cell order, not both")
            cell_order = get_module(module).cell_order(rows, cols)
        #: The module emulated (None: the ``cell_order`` given).
        self.module = module if module is not None else (DEFAULT_MODULE if cell_order is None else None)
        self.sensor_type = sensor_type
        self.period = 1.0 / float(rate_hz)
        self._order = P.cell_permutation(cell_order, rows, cols)
        #: Fault injection in force; assigning a new :class:`FaultConfig` from another thread is
        #: safe: each frame reads it once when it starts, so the frame being sent meanwhile may
        #: still carry an old fault and every later one has the new faults.
        self.faults = FaultConfig.parse(faults) if isinstance(faults, (str, type(None))) else faults
        self._lock = threading.RLock()
        self.keep_log = keep_log
        self.log = EmulatorLog()
        self.frames_sent = 0
        self.bytes_sent = 0
        self.error: BaseException | None = None
        self._rng = np.random.default_rng(seed)
        self._next_values = self._make_source(source, loop)
        self._datagram_len = 3 + P.TIMESTAMP_LEN + 2 * rows * cols + 1
        self._open: list[tuple[int, int]] = []  # torn datagrams' parser candidates: (bytes missing, XOR so far)
        self._tail = b""  # last bytes written
        self._streaming = threading.Event()
        self._restart = False
        self._stop = threading.Event()
        self._commands = P.CommandParser()
        self._t0 = time.monotonic()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self._wake_r, self._wake_w = os.pipe()
        self.port = os.ttyname(self._slave)
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=f"tactile-emulator {self.port}", daemon=True)
        self._thread.start()

    def _make_source(self, source: FrameSource, loop: bool) -> Callable[[], np.ndarray] | None:
        if source is None:
            return None
        if isinstance(source, (str, Path)):
            source = _recording_source(source, loop)
        if callable(source) and not hasattr(source, "__next__"):
            return source  # type: ignore[return-value]
        iterator = iter(source)  # type: ignore[arg-type]
        return lambda: next(iterator)

    # ------------------------------------------------------------------ properties
    @property
    def streaming(self) -> bool:
        """True while the host has streaming switched on."""
        return self._streaming.is_set()

    @property
    def rate_hz(self) -> float:
        """Current streaming rate in Hz."""
        return 1.0 / self.period

    # ------------------------------------------------------------------ output
    def _write(self, data: bytes, timeout: float = 0.5) -> int:
        view, sent = memoryview(data), 0
        deadline = time.monotonic() + timeout
        while sent < len(data):
            try:
                sent += os.write(self._master, view[sent:])
            except BlockingIOError:
                if self._stop.is_set() or time.monotonic() > deadline:
                    break
                select.select([], [self._master], [], 0.02)
        return sent

    def _send(self, data: bytes, *, junk: bool = False) -> int:
        """Write ``data`` keeping the ground truth exact; return how many of its bytes went out.

        A torn datagram is a parser candidate that the following bytes complete; with an
        8-bit XOR it would pass in 1 of 256 cases and be delivered or arbitrated as if it
        were valid.  So when ``data`` would complete an open candidate with a zero XOR, one
        filler byte (logged as garbage) goes out first, chosen so that every candidate it
        completes fails.  Garbage (``junk``) and fillers never continue a header pattern
        begun by the bytes before them.
        """
        out = bytearray(data)
        if junk and out and not self._may_follow(out[0]):
            out[0] = next(int(v) for v in GARBAGE_ALPHABET if self._may_follow(v))
        filler = self._filler(bytes(out)) if self._open else b""
        if filler and self._write(filler):
            self._track(filler, 1)
            self._log_event("garbage", 1)
            self.log.garbage_bytes += 1
        sent = self._write(bytes(out))
        self._track(bytes(out), sent)
        return sent

    def _may_follow(self, value: int) -> bool:
        """False if ``value`` after the bytes written so far would complete ``F0 C4 <id>``."""
        if self._tail.endswith(HEADER):
            return not (value in (P.DID_MASTER, P.DID_ERROR) or P.LID_MIN <= value <= P.LID_MAX)
        return not (self._tail.endswith(HEADER[:1]) and value == HEADER[1])

    def _completes_with_zero_xor(self, stream: bytes) -> bool:
        return any(missing <= len(stream) and acc ^ P.checksum(stream[:missing]) == 0
                   for missing, acc in self._open)

    def _filler(self, data: bytes) -> bytes:
        if not self._completes_with_zero_xor(data):
            return b""
        for value in GARBAGE_ALPHABET:  # each open candidate rules out at most one value
            if self._may_follow(value) and not self._completes_with_zero_xor(bytes([value]) + data):
                return bytes([int(value)])
        raise RuntimeError("no filler byte breaks every torn datagram")  # pragma: no cover

    def _track(self, data: bytes, sent: int) -> None:
        """Account ``data[:sent]`` written: byte count, tail, open candidates."""
        if sent <= 0:
            return
        done = data[:sent]
        self.bytes_sent += sent
        self._tail = (self._tail + done)[-2:]
        acc = P.checksum(done)
        self._open = [(missing - sent, a ^ acc) for missing, a in self._open if missing > sent]

    def _device_time(self, t: float | None = None) -> int:
        """Device clock in microseconds at monotonic time ``t`` (default: now)."""
        return int(((time.monotonic() if t is None else t) - self._t0) * 1e6) & 0xFFFFFFFF

    def _datagram(self, values: np.ndarray, high: np.ndarray | None, sampled: float | None) -> tuple[bytes, int]:
        """The data datagram of ``values`` stamped at ``sampled`` (default now), and its timestamp.

        A timestamp whose bytes would put a header pattern inside the datagram (besides a
        planted one) is moved on by a few microseconds: an accidental ``F0 C4 <id>`` followed
        by garbage would make the parser drop an intact frame.
        """
        payload = P.encode_values(values, self._order, high)
        patterns = 1 if high is None else 2
        ts = self._device_time(sampled)
        for _ in range(64):
            datagram = P.build_data_datagram(self.sensor_id, ts, payload)
            if datagram.count(HEADER) == patterns:
                break
            ts = (ts + 1) & 0xFFFFFFFF
        return datagram, ts

    def _emit(self, values: np.ndarray, pushed: bool = False, sampled: float | None = None) -> float:
        """Send one frame with the configured faults; return the pause to add (s).

        ``sampled`` is the monotonic time the frame was sampled at (default: now).  A streamed
        frame is stamped with the time its period falls due, not the time the thread gets to
        send it: a real device samples on its own clock, and a late thread sends a few frames
        at once without bunching their timestamps.
        """
        with self._lock:
            f, rng = self.faults, self._rng
            index = self.frames_sent
            kind = choose_fault(f, rng)
            high = None
            if kind == "header":
                values, high = plant_header(values, self._order, self.sensor_id, rng)
            datagram, ts = self._datagram(values, high, sampled)
            if kind == "bitflip":
                datagram = flip_bit(datagram, rng)
            elif kind == "tear":
                datagram = tear(datagram, rng)
            sent = self._send(datagram)
            fault = kind if kind in ("bitflip", "tear") else None
            if sent < len(datagram):
                fault = "tear"  # the line stalled (the host stopped reading): a torn datagram
            if 0 < sent < 3:  # not even header and id: the parser skips it like garbage
                self._log_event("garbage", sent)
                self.log.garbage_bytes += sent
                sent = 0
            elif 0 < sent < self._datagram_len:
                self._open.append((self._datagram_len - sent, P.checksum(datagram[:sent])))
            if sent:
                self.frames_sent += 1
                if self.keep_log:
                    self.log.frames.append(SentFrame(index, values, ts, fault, kind == "header", pushed))
                    self._log_event("frame", index)
            if f.garbage and rng.random() < f.garbage and kind != "header":
                junk = garbage_burst(f, rng)
                sent_junk = self._send(junk, junk=True)
                if sent_junk:
                    self._log_event("garbage", sent_junk)
                    self.log.garbage_bytes += sent_junk
            pause = f.pause_s if (f.pause and rng.random() < f.pause) else 0.0
            if pause:
                self._log_event("pause", pause)
            return pause

    def _log_event(self, kind: str, value: float) -> None:
        if self.keep_log:
            self.log.events.append((kind, value))

    def push(self, values: np.ndarray, timeout: float = 1.0) -> None:
        """Send exactly this frame now (waits up to ``timeout`` s for the host to stream)."""
        counts = as_counts(values, self.rows, self.cols)
        if not self._streaming.wait(timeout):
            raise RuntimeError(f"emulator {self.port}: the host has not started streaming within {timeout:g} s")
        pause = self._emit(counts, pushed=True)
        if pause:
            time.sleep(pause)

    # ------------------------------------------------------------------ commands
    def _handle_commands(self, data: bytes) -> None:
        before = self._commands.checksum_errors
        commands = self._commands.feed(data)
        with self._lock:
            for _ in range(self._commands.checksum_errors - before):
                self._send(P.build_error(P.ERR_CHECKSUM))
            for cmd in commands:
                self._execute(cmd)

    def _execute(self, cmd: P.Command) -> None:
        if cmd.destination not in (P.DID_MASTER, self.sensor_id):
            self._send(P.build_error(P.ERR_UNKNOWN_SENSOR))
        elif cmd.command == P.CMD_STOP_STREAM:
            self._streaming.clear()
        elif cmd.command == P.CMD_START_STREAM:
            self._restart = True
            self._streaming.set()
        elif cmd.command == P.CMD_CONFIG_REQUEST:
            # A host asking for the configuration parses afresh (the driver drops its input
            # first): torn datagrams sent before can no longer combine with what follows.
            self._open.clear()
            self._send(P.build_config_answer(self.device_id, [(self.sensor_type, 2 * self.rows * self.cols)]))
        elif cmd.command == P.CMD_SET_PERIOD:
            if cmd.destination == self.sensor_id and len(cmd.data) == 2:
                units = int.from_bytes(cmd.data, "little")
            else:  # master form: (sensor id, period u16) items
                items = [cmd.data[k : k + 3] for k in range(0, len(cmd.data) - 2, 3)]
                units = next((int.from_bytes(it[1:], "little") for it in items if it[0] == self.sensor_id), 0)
            if units > 0:
                self.period = units * P.PERIOD_UNIT_S
                self._restart = True
        else:
            self._send(P.build_error(P.ERR_UNKNOWN_COMMAND))

    # ------------------------------------------------------------------ thread
    def _run(self) -> None:
        next_due = time.monotonic()
        while not self._stop.is_set():
            active = self._streaming.is_set() and self._next_values is not None
            timeout = max(0.0, next_due - time.monotonic()) if active else 0.05
            ready: list = []
            try:
                ready, _, _ = select.select([self._master, self._wake_r], [], [], timeout)
                if self._master in ready:
                    self._handle_commands(os.read(self._master, 65536))
            except (BlockingIOError, InterruptedError):
                pass
            except OSError:
                break  # pty gone
            if self._wake_r in ready:
                os.read(self._wake_r, 64)
            if self._restart:
                self._restart, next_due = False, time.monotonic()
            now = time.monotonic()
            while (now >= next_due and self._streaming.is_set() and self._next_values is not None
                   and not self._stop.is_set()):
                try:
                    values = as_counts(self._next_values(), self.rows, self.cols)
                except StopIteration:
                    self._next_values = None
                    break
                except Exception as exc:  # noqa: BLE001 - report, stop streaming, keep answering
                    self.error = exc
                    self._next_values = None
                    print(f"tactile emulator {self.port}: frame source failed: {exc!r}", file=sys.stderr)
                    break
                next_due += self.period + self._emit(values, sampled=next_due)
                if now - next_due > 0.1:
                    next_due = now  # fell far behind: resume the schedule instead of bursting

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Stop the thread and close both pty ends: a connected driver sees the port vanish."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        try:
            os.write(self._wake_w, b"x")
        except OSError:
            pass
        self._thread.join(timeout=2.0)
        for fd in (self._master, self._slave, self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self) -> "DeviceEmulator":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass
