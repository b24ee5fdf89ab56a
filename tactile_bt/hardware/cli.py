"""``tactile-bt sensor ...``: stream, record, emulate and replay on the command line.

:func:`add_sensor_subcommands` adds the ``sensor`` command to the main ``tactile-bt`` parser;
every leaf sets ``func`` (``args.func(args)`` returns the exit code).  ``python -m
tactile_bt.hardware.cli sensor ...`` runs the same commands stand-alone.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

import numpy as np

from tactile_bt.defaults import COLS, MAX_SENSOR_RATE_HZ, ROWS


def _interrupt(_signum: int, _frame: object) -> None:
    raise KeyboardInterrupt


def _on_terminate() -> None:
    """Make SIGTERM end a command like Ctrl-C (files are closed, counts printed)."""
    signal.signal(signal.SIGTERM, _interrupt)


def _cell_order(path: str | None) -> np.ndarray | None:
    if not path:
        return None
    return np.load(path) if path.endswith(".npy") else np.loadtxt(path, dtype=int).ravel()


def _open_sensor(args: argparse.Namespace):
    from tactile_bt.hardware.driver import SerialTactileSensor

    return SerialTactileSensor(args.port, baudrate=args.baudrate, rows=args.rows, cols=args.cols,
                               cell_order=_cell_order(args.cell_order), timeout=args.timeout,
                               period=None if args.rate is None else 1.0 / args.rate)


def _print_stats(stats: object, file=sys.stderr) -> None:
    fields = ("frames", "checksum_errors", "overlaps", "resyncs", "bytes_skipped", "device_errors", "queue_dropped")
    print("stats: " + " ".join(f"{k}={getattr(stats, k)}" for k in fields), file=file, flush=True)


def cmd_stream(args: argparse.Namespace) -> int:
    """Print frame rate, peak and total counts once per ``--every`` seconds."""
    from tactile_bt.hardware.driver import SensorError

    _on_terminate()
    try:
        with _open_sensor(args) as sensor:
            print(f"streaming from {args.port}: sensor {sensor.sensor_id}, config {sensor.config}", file=sys.stderr)
            start = last = time.monotonic()
            count = 0
            try:
                for frame in sensor.frames(timeout=args.timeout):
                    count += 1
                    now = time.monotonic()
                    if now - last >= args.every:
                        print(f"t={now - start:7.2f} s  {count / (now - last):7.1f} Hz  max={int(frame.values.max()):4d}  "
                              f"sum={int(frame.values.sum()):7d}  dev_t={frame.device_timestamp}", flush=True)
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
    """Record every frame into a chunked file until Ctrl-C, SIGTERM or ``--duration``."""
    from tactile_bt.hardware.driver import SensorError
    from tactile_bt.hardware.recording import Recorder

    _on_terminate()
    code = 0
    try:
        with _open_sensor(args) as sensor:
            meta = {"port": args.port, "sensor_id": sensor.sensor_id, "device_id": sensor.config.device_id,
                    "sensor_types": [t for t, _ in sensor.config.sensors], "source": "sensor record"}
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
    from tactile_bt.hardware.emulator import DeviceEmulator, FaultConfig, synthetic_source

    _on_terminate()
    try:
        faults = FaultConfig.parse(args.faults)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.recording and not Path(args.recording).is_file():
        print(f"error: recording {args.recording} not found", file=sys.stderr)
        return 2
    source = args.recording or synthetic_source(args.rows, args.cols, args.rate, args.seed)
    with DeviceEmulator(source, rate_hz=args.rate, rows=args.rows, cols=args.cols, faults=faults,
                        seed=args.seed, keep_log=False) as emu:
        print(emu.port, flush=True)
        print(f"emulating a {args.rows}x{args.cols} tactile module at {args.rate:g} Hz on {emu.port} "
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


def cmd_replay(args: argparse.Namespace) -> int:
    """Replay a recording: a summary, or one line per frame with ``--frames``."""
    from tactile_bt.hardware.recording import RecordingError, read_header, replay

    try:
        rows, cols, meta, _ = read_header(args.file)
        print(f"{args.file}: {rows}x{cols}, metadata {meta}", file=sys.stderr)
        n, first, last = 0, None, None
        for frame in replay(args.file, speed=args.speed):
            first = frame.timestamp if first is None else first
            last = frame.timestamp
            n += 1
            if args.frames:
                print(f"{n - 1:7d} t={frame.timestamp:.6f} max={int(frame.values.max()):4d} "
                      f"sum={int(frame.values.sum()):7d}", flush=True)
    except (RecordingError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    span = (last - first) if n > 1 else 0.0
    rate = f", {(n - 1) / span:.1f} Hz" if span > 0 else ""
    print(f"replayed {n} frames over {span:.3f} s recorded time{rate}", flush=True)
    return 0


def _sensor_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", metavar="PORT", help="serial device path (/dev/ttyACM0, a pty) or pyserial URL")
    p.add_argument("--baudrate", type=int, default=1_000_000, help="line rate (ignored by USB CDC devices)")
    p.add_argument("--rows", type=int, default=ROWS)
    p.add_argument("--cols", type=int, default=COLS)
    p.add_argument("--cell-order", metavar="FILE", help="device cell order: rows*cols ints (text or .npy)")
    p.add_argument("--rate", type=float, default=None, help="set the sensor's frame rate in Hz (100 us steps)")
    p.add_argument("--timeout", type=float, default=1.0, help="seconds to wait for the device (default 1)")
    p.add_argument("--duration", type=float, default=None, help="stop after this many seconds")


def add_sensor_subcommands(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``sensor {stream,record,emulate,replay}`` to a ``tactile-bt`` subparsers object."""
    sensor = subparsers.add_parser("sensor", help="tactile array over serial: stream, record, emulate, replay",
                                   description="Tactile array over serial (AGNI serial protocol).")
    sub = sensor.add_subparsers(dest="sensor_command", metavar="{stream,record,emulate,replay}")
    sub.required = True

    p = sub.add_parser("stream", help="print live frame statistics of a sensor")
    _sensor_options(p)
    p.add_argument("--every", type=float, default=1.0, help="print interval in s")
    p.set_defaults(func=cmd_stream)

    p = sub.add_parser("record", help="record frames into a chunked file (see docs/hardware.md)")
    _sensor_options(p)
    p.add_argument("--out", required=True, metavar="FILE", help="output recording")
    p.add_argument("--chunk-frames", type=int, default=256, help="frames per chunk (default 256)")
    p.set_defaults(func=cmd_record)

    p = sub.add_parser("emulate", help="emulate a sensor on a pseudo-terminal; prints the port path")
    p.add_argument("--rate", type=float, default=MAX_SENSOR_RATE_HZ, help="frame rate in Hz (default 1900)")
    p.add_argument("--recording", metavar="FILE", help="stream this recording (looped) instead of a synthetic blob")
    p.add_argument("--faults", default="", metavar="SPEC",
                   help="fault probabilities per frame, e.g. 'garbage=0.01,bitflip=0.01,tear=0.01,pause=0.001,"
                        "header=0.05' or 'all=0.01'")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--rows", type=int, default=ROWS)
    p.add_argument("--cols", type=int, default=COLS)
    p.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    p.set_defaults(func=cmd_emulate)

    p = sub.add_parser("replay", help="replay a recording at recorded or faster speed")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--speed", type=float, default=None, help="1 = recorded speed, 2 = twice as fast (default: max)")
    p.add_argument("--frames", action="store_true", help="print one line per frame")
    p.set_defaults(func=cmd_replay)
    return sensor


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m tactile_bt.hardware.cli sensor ...``."""
    parser = argparse.ArgumentParser(prog="tactile-bt")
    sub = parser.add_subparsers(dest="command", metavar="{sensor}")
    sub.required = True
    add_sensor_subcommands(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
