"""``tactile-bt sensor ...``: stream, record, emulate and replay on the command line.

:func:`add_sensor_subcommands` adds the ``sensor`` command to the main ``tactile-bt`` parser;
every leaf sets ``func`` (``args.func(args)`` returns the exit code).  ``python -m
tactile_bt.sense.hardware.cli sensor ...`` runs the same commands stand-alone.

Bad input ends a command with one line ``error: ...`` naming the option or file, before any
port is opened or file written: argparse rejects bad numbers (``type=`` validators of
:mod:`tactile_bt.sense.hardware.options`), the commands check files, shapes and the output.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

import numpy as np

from tactile_bt.errors import CommandLineError
from tactile_bt.defaults import COLS, MAX_SENSOR_RATE_HZ, ROWS
from tactile_bt.arguments import (OneLineParser, check_output, nonnegative_int, one_line_warnings, positive_float,
                                  positive_int)
from tactile_bt.sense.hardware.framing import EMULATED_SENSOR_TYPE
from tactile_bt.sense.hardware.options import device_rate, fault_spec, module_name, sensor_type
from tactile_bt.errors import OutputPathError

#: Largest array the protocol carries: the configuration announces 2 * rows * cols as a u16.
MAX_TACTELS = 0xFFFF // 2


def _interrupt(_signum: int, _frame: object) -> None:
    raise KeyboardInterrupt


def _on_terminate() -> None:
    """Make SIGTERM end a command like Ctrl-C (files are closed, counts printed)."""
    signal.signal(signal.SIGTERM, _interrupt)


def _check_shape(rows: int, cols: int) -> None:
    if rows * cols > MAX_TACTELS:
        raise CommandLineError(f"--rows {rows} --cols {cols}: {rows * cols} tactels, the protocol carries at most "
                          f"{MAX_TACTELS}")


def _cell_order(path: str | None, rows: int, cols: int) -> np.ndarray | None:
    """The ``--cell-order`` table, checked to be a permutation of the rows x cols tactels."""
    if not path:
        return None
    from tactile_bt.sense.hardware.protocol import cell_permutation

    try:
        order = np.load(path) if path.endswith(".npy") else np.loadtxt(path, dtype=int, ndmin=1).ravel()
        cell_permutation(order, rows, cols)
    except (OSError, ValueError) as exc:
        raise CommandLineError(f"--cell-order {path}: {exc}") from None
    return order


def _open_sensor(args: argparse.Namespace, cell_order: np.ndarray | None, registration: dict | None):
    from tactile_bt.sense.hardware.driver import SerialTactileSensor

    return SerialTactileSensor(args.port, baudrate=args.baudrate, rows=args.rows, cols=args.cols,
                               cell_order=cell_order, timeout=args.timeout,
                               period=None if args.rate is None else 1.0 / args.rate,
                               module=args.module, registration=registration)


def _sensor_input(args: argparse.Namespace) -> tuple[np.ndarray | None, dict | None]:
    """Check the options of stream/record that argparse cannot; return the cell order and the
    registration (sensor type numbers -> module names)."""
    _check_shape(args.rows, args.cols)
    _check_module(args)
    if args.module and args.cell_order:
        raise CommandLineError(f"--module {args.module} --cell-order {args.cell_order}: give one of them")
    registration = None
    if args.registration:
        from tactile_bt.errors import YamlError
        from tactile_bt.sense.hardware.modules import load_registration

        try:
            registration = load_registration(args.registration)
        except YamlError as exc:
            raise CommandLineError(f"--registration {exc}") from None
    return _cell_order(args.cell_order, args.rows, args.cols), registration


def _check_module(args: argparse.Namespace) -> None:
    """``--module`` against the array shape of ``--rows``/``--cols``."""
    if args.module:
        from tactile_bt.errors import SensorModuleError
        from tactile_bt.sense.hardware.modules import get_module

        try:
            get_module(args.module).check_shape(args.rows, args.cols)
        except SensorModuleError as exc:
            raise CommandLineError(f"--module {args.module} --rows {args.rows} --cols {args.cols}: {exc}") from None


def _peak(values: np.ndarray) -> str:
    """Where a frame's largest count is: ``row R col C`` (row = sensor y, col = sensor x)."""
    row, col = np.unravel_index(int(np.argmax(values)), values.shape)
    return f"row {row:2d} col {col:2d}"


def _print_stats(stats: object, file=sys.stderr) -> None:
    fields = ("frames", "checksum_errors", "overlaps", "resyncs", "bytes_skipped", "device_errors", "queue_dropped")
    print("stats: " + " ".join(f"{k}={getattr(stats, k)}" for k in fields), file=file, flush=True)


def cmd_stream(args: argparse.Namespace) -> int:
    """Print frame rate, peak and total counts once per ``--every`` seconds."""
    from tactile_bt.errors import SensorError

    try:
        cell_order, registration = _sensor_input(args)
    except CommandLineError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    _on_terminate()
    try:
        with _open_sensor(args, cell_order, registration) as sensor:
            print(f"streaming from {args.port}: sensor {sensor.sensor_id}, config {sensor.config}, "
                  f"module {sensor.module or 'with --cell-order ' + args.cell_order}", file=sys.stderr)
            start = last = time.monotonic()
            count = 0
            try:
                for frame in sensor.frames(timeout=args.timeout):
                    count += 1
                    now = time.monotonic()
                    if now - last >= args.every:
                        print(f"t={now - start:7.2f} s  {count / (now - last):7.1f} Hz  max={int(frame.values.max()):4d}  "
                              f"at {_peak(frame.values)}  sum={int(frame.values.sum()):7d}  dev_t={frame.device_timestamp}",
                              flush=True)
                        count, last = 0, now
                    if args.duration and now - start >= args.duration:
                        break
                else:
                    print(f"no frame from {args.port} for {args.timeout:g} s", file=sys.stderr)
            except KeyboardInterrupt:
                pass
            _print_stats(sensor.stats)
    except SensorError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


def cmd_record(args: argparse.Namespace) -> int:
    """Record every frame into a chunked file until Ctrl-C, SIGTERM or ``--duration``.

    An existing ``--out`` file is kept unless ``--force``; the check comes before the port opens.
    """
    from tactile_bt.errors import SensorError
    from tactile_bt.sense.hardware.recording import Recorder

    try:
        check_output(args.out, args.force)
        cell_order, registration = _sensor_input(args)
    except (OutputPathError, CommandLineError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    _on_terminate()
    code = 0
    try:
        with _open_sensor(args, cell_order, registration) as sensor:
            meta = {"port": args.port, "sensor_id": sensor.sensor_id, "device_id": sensor.config.device_id,
                    "sensor_types": [t for t, _ in sensor.config.sensors], "module": sensor.module,
                    "source": "sensor record"}
            with Recorder(args.out, rows=args.rows, cols=args.cols, metadata=meta,
                          chunk_frames=args.chunk_frames) as rec:
                print(f"recording {args.port} -> {args.out}", file=sys.stderr, flush=True)
                start = time.monotonic()
                try:
                    while not (args.duration and time.monotonic() - start >= args.duration):
                        for frame in sensor.frames(timeout=min(args.timeout, 0.5)):
                            rec.write(frame)
                            if args.duration and time.monotonic() - start >= args.duration:
                                break
                except KeyboardInterrupt:
                    pass
                except SensorError as exc:
                    print(f"error: {exc}", file=sys.stderr)
                    code = 1
            print(f"recorded {rec.frames_written} frames in {rec.chunks_written} chunks to {args.out}",
                  file=sys.stderr, flush=True)
            _print_stats(sensor.stats)
    except SensorError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return code


def cmd_emulate(args: argparse.Namespace) -> int:
    """Open a pty pair, print the slave path on stdout, serve until Ctrl-C/SIGTERM/``--duration``."""
    from tactile_bt.sense.hardware.emulator import DeviceEmulator, synthetic_source
    from tactile_bt.errors import RecordingError

    try:
        rows, cols = _emulated_shape(args)
        _check_module(argparse.Namespace(module=args.module, rows=rows, cols=cols))
    except (CommandLineError, RecordingError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    _on_terminate()
    source = args.recording or synthetic_source(rows, cols, args.rate, args.seed)
    with DeviceEmulator(source, rate_hz=args.rate, rows=rows, cols=cols, faults=args.faults,
                        seed=args.seed, keep_log=False, module=args.module, sensor_type=args.sensor_type) as emu:
        print(emu.port, flush=True)
        print(f"emulating a {rows}x{cols} tactile module ({emu.module}) at {args.rate:g} Hz on {emu.port} "
              f"(Ctrl-C to stop)", file=sys.stderr, flush=True)
        start = time.monotonic()
        try:
            while not (args.duration and time.monotonic() - start >= args.duration):
                time.sleep(0.05)
        except KeyboardInterrupt:
            pass
        print(f"sent {emu.frames_sent} frames", file=sys.stderr, flush=True)
        if emu.error is not None:
            print(f"error: frame source failed: {emu.error}", file=sys.stderr)
            return 1
    return 0


def _emulated_shape(args: argparse.Namespace) -> tuple[int, int]:
    """The array shape to emulate: ``--rows``/``--cols``, or the shape of ``--recording``
    (whose every chunk is checked now, so a bad file fails before the port opens)."""
    from tactile_bt.sense.hardware.recording import iter_chunks, read_header

    if not args.recording:
        rows, cols = args.rows or ROWS, args.cols or COLS
    else:
        if not Path(args.recording).is_file():
            raise CommandLineError(f"--recording {args.recording}: no such file")
        rows, cols, _meta, _off = read_header(args.recording)
        given = " ".join(f"--{k} {v}" for k, v in (("rows", args.rows), ("cols", args.cols)) if v is not None)
        if (args.rows or rows, args.cols or cols) != (rows, cols):
            raise CommandLineError(f"{given}: the frames of --recording {args.recording} are {rows}x{cols}")
        if sum(len(c.timestamps) for c in iter_chunks(args.recording)) == 0:
            raise CommandLineError(f"--recording {args.recording}: the recording holds no complete frame")
    _check_shape(rows, cols)
    return rows, cols


def cmd_replay(args: argparse.Namespace) -> int:
    """Print a recording's frames (a summary, or one line per frame with ``--frames``), no tree."""
    from tactile_bt.sense.hardware.recording import read_header, replay
    from tactile_bt.errors import RecordingError

    try:
        rows, cols, meta, _ = read_header(args.recording)
        print(f"{args.recording}: {rows}x{cols}, metadata {meta}", file=sys.stderr)
        n, first, last = 0, None, None
        with one_line_warnings():
            for frame in replay(args.recording, speed=args.speed):
                first = frame.timestamp if first is None else first
                last = frame.timestamp
                n += 1
                if args.frames:
                    print(f"{n - 1:7d} t={frame.timestamp:.6f} max={int(frame.values.max()):4d} "
                          f"sum={int(frame.values.sum()):7d}", flush=True)
    except (RecordingError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    span = (last - first) if n > 1 else 0.0
    rate = f" ({(n - 1) / span:.1f} Hz)" if span > 0 else ""
    print(f"replayed {n} frames, {span:.3f} s of recorded time{rate}", flush=True)
    return 0


_RATE_HELP = "frame rate in Hz, 0.153 to 10000 (the device period: 100 us steps)"
_DURATION_HELP = "stop after this many seconds (default: at Ctrl-C or SIGTERM)"
_SHAPE_HELP = "tactel {} of the array (default {})"
_RECORDING_HELP = "a recording made by 'run --record' or 'sensor record'"
_MODULE_HELP = ("tactile module whose cell order the device sends: tactile_module_16x16_v2, or row_major "
                "(default: row_major, unless --registration names the device's module)")
_SPEED_HELP = "1 = the recorded pace, 2 = twice as fast (default: as fast as possible)"


def _sensor_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", metavar="PORT", help="serial device path (/dev/ttyACM0, a pty) or pyserial URL")
    p.add_argument("--baudrate", type=positive_int, default=1_000_000,
                   help="line rate in baud (default 1000000; ignored by USB CDC devices)")
    p.add_argument("--rows", type=positive_int, default=ROWS, help=_SHAPE_HELP.format("rows", ROWS))
    p.add_argument("--cols", type=positive_int, default=COLS, help=_SHAPE_HELP.format("columns", COLS))
    p.add_argument("--cell-order", metavar="FILE", help="device cell order: rows*cols ints (text or .npy)")
    p.add_argument("--module", type=module_name, default=None, metavar="NAME", help=_MODULE_HELP)
    p.add_argument("--registration", metavar="FILE",
                   help="the reference driver's registred_devices.yaml: names the module from the sensor type "
                        "in the device's configuration when neither --module nor --cell-order is given")
    p.add_argument("--rate", type=device_rate, default=None,
                   help=_RATE_HELP + "; sets the sensor's rate (default: as the sensor runs)")
    p.add_argument("--timeout", type=positive_float, default=1.0, help="seconds to wait for the device (default 1)")
    p.add_argument("--duration", type=positive_float, default=None, help=_DURATION_HELP)


def add_sensor_subcommands(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``sensor {stream,record,emulate,replay}`` to a ``tactile-bt`` subparsers object."""
    sensor = subparsers.add_parser("sensor", help="tactile array over serial: stream, record, emulate, replay",
                                   description="Tactile array over serial (AGNI serial protocol).")
    sub = sensor.add_subparsers(dest="sensor_command", metavar="{stream,record,emulate,replay}")
    sub.required = True

    p = sub.add_parser("stream", help="print live frame statistics of a sensor")
    _sensor_options(p)
    p.add_argument("--every", type=positive_float, default=1.0, help="print interval in s (default 1)")
    p.set_defaults(func=cmd_stream)

    p = sub.add_parser("record", help="record frames into a chunked file (see docs/hardware.md)")
    _sensor_options(p)
    p.add_argument("--out", required=True, metavar="FILE", help="output recording (refused if it exists, unless --force)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out FILE")
    p.add_argument("--chunk-frames", type=positive_int, default=256, help="frames per chunk (default 256)")
    p.set_defaults(func=cmd_record)

    p = sub.add_parser("emulate", help="emulate a sensor on a pseudo-terminal; prints the port path")
    p.add_argument("--rate", type=device_rate, default=MAX_SENSOR_RATE_HZ,
                   help=_RATE_HELP + f"; until the host sets one (default {MAX_SENSOR_RATE_HZ:g})")
    p.add_argument("--recording", metavar="RECORDING",
                   help=_RECORDING_HELP + ": stream its frames (looped) instead of a synthetic blob")
    p.add_argument("--faults", type=fault_spec, default="", metavar="SPEC",
                   help="fault probabilities per frame (0..1) of garbage, bitflip, tear, pause, header, or all "
                        "five, e.g. 'garbage=0.01,tear=0.01' or 'all=0.01' (bitflip + tear + header at most 1); "
                        "also garbage_max=BYTES, pause_s=SECONDS")
    p.add_argument("--seed", type=nonnegative_int, default=0, help="seed of the frames and faults (default 0)")
    p.add_argument("--module", type=module_name, default=None, metavar="NAME",
                   help="tactile module to emulate: its words go out in its cell order (default row_major)")
    p.add_argument("--sensor-type", type=sensor_type, default=EMULATED_SENSOR_TYPE, metavar="N",
                   help="sensor type number the configuration answer announces, e.g. 0x1234 (default "
                        f"{EMULATED_SENSOR_TYPE}, the reference driver's 'undefined')")
    p.add_argument("--rows", type=positive_int, default=None,
                   help=_SHAPE_HELP.format("rows", f"{ROWS}, or the recording's"))
    p.add_argument("--cols", type=positive_int, default=None,
                   help=_SHAPE_HELP.format("columns", f"{COLS}, or the recording's"))
    p.add_argument("--duration", type=positive_float, default=None, help=_DURATION_HELP)
    p.set_defaults(func=cmd_emulate)

    p = sub.add_parser("replay", help="print a recording's frames, no tree ('tactile-bt replay' runs a tree on them)")
    p.add_argument("recording", metavar="RECORDING", help=_RECORDING_HELP)
    p.add_argument("--speed", type=positive_float, default=None, help=_SPEED_HELP)
    p.add_argument("--frames", action="store_true", help="print one line per frame")
    p.set_defaults(func=cmd_replay)
    return sensor


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m tactile_bt.sense.hardware.cli sensor ...``."""
    parser = OneLineParser(prog="tactile-bt")
    sub = parser.add_subparsers(dest="command", metavar="{sensor}")
    sub.required = True
    add_sensor_subcommands(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
