"""Soak test of driver + emulator through a pseudo-terminal, against the emulator's ground truth.

Run ``python -m tactile_bt.sense.hardware.soak --seconds 10 --rate 1900``: a clean phase (every frame
must arrive intact) and a faulted phase (every undamaged frame must arrive, every damaged one
must be dropped, and the driver's counters must match what the emulator injected).  Exit code
0 when both phases pass.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict, dataclass
from typing import Callable

import numpy as np

from tactile_bt.defaults import MAX_SENSOR_RATE_HZ
from tactile_bt.sense.hardware.driver import SensorStats, SerialTactileSensor
from tactile_bt.sense.hardware.emulator import DeviceEmulator, FaultConfig, synthetic_source

#: Faults of the soak's faulted phase (per-frame probabilities).
DEFAULT_FAULTS = "garbage=0.01,bitflip=0.01,tear=0.01,pause=0.002,header=0.02"


@dataclass
class SoakResult:
    """Outcome of one soak phase: what was sent, what arrived, and whether they agree."""

    seconds: float
    rate_hz: float  #: achieved emulator rate (device clock)
    sent: int
    damaged: int
    delivered: int
    contents_match: bool
    expected_resyncs: int
    stats: SensorStats

    @property
    def ok(self) -> bool:
        """All undamaged frames delivered intact, all damaged dropped and counted."""
        s = self.stats
        return (self.contents_match and s.frames == self.delivered == self.sent - self.damaged
                and s.dropped == self.damaged and s.resyncs == self.expected_resyncs and s.queue_dropped == 0)

    def summary(self) -> str:
        """One line of counts."""
        s = self.stats
        return (f"{self.seconds:.1f} s at {self.rate_hz:.0f} Hz: sent {self.sent} (damaged {self.damaged}), "
                f"delivered {self.delivered}, intact={self.contents_match}; driver: frames={s.frames} "
                f"checksum_errors={s.checksum_errors} overlaps={s.overlaps} resyncs={s.resyncs} "
                f"(expected {self.expected_resyncs}) bytes_skipped={s.bytes_skipped} "
                f"queue_dropped={s.queue_dropped} -> {'PASS' if self.ok else 'FAIL'}")


def _wait_until(condition: Callable[[], bool], timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


def run_soak(seconds: float, rate_hz: float = MAX_SENSOR_RATE_HZ, faults: str | FaultConfig | None = None,
             seed: int = 0, min_frames: int = 0) -> SoakResult:
    """Stream ``seconds`` s at ``rate_hz`` through a pty and compare with the ground truth.

    With ``min_frames``, streaming goes on until that many frames were delivered too, so that
    a loaded machine, on which the emulator cannot keep its rate, still checks that many.
    """
    frames = []
    with DeviceEmulator(synthetic_source(rate_hz=rate_hz, seed=seed), rate_hz=rate_hz, faults=faults,
                        seed=seed) as emu:
        with SerialTactileSensor(emu.port, timeout=2.0) as sensor:
            end = time.monotonic() + seconds
            for frame in sensor.frames(timeout=2.0):
                frames.append(frame)
                if time.monotonic() >= end and len(frames) >= min_frames:
                    break
            # Finish on a clean line so that a later intact frame resolves every fault: the frame
            # being sent now may still be damaged, the next one is clean and must go out (waiting
            # some time instead is not enough on a loaded machine).
            emu.faults = FaultConfig()
            first_clean = emu.frames_sent + 1
            for frame in sensor.frames(timeout=2.0):
                frames.append(frame)
                if emu.frames_sent > first_clean:
                    break
            sensor.stop_streaming()
            _wait_until(lambda: not emu.streaming, 5.0)  # then the emulator's log is final
            expected = len(emu.log.intact())
            if len(frames) < expected:  # collect the rest, however long the line takes
                for frame in sensor.frames(timeout=2.0):
                    frames.append(frame)
                    if len(frames) >= expected:
                        break
            stats = sensor.stats
        log = emu.log
    intact = log.intact()
    match = len(intact) == len(frames) and all(
        a.device_timestamp == b.device_timestamp and np.array_equal(a.values, b.values)
        for a, b in zip(intact, frames)
    )
    span = (log.frames[-1].device_timestamp - log.frames[0].device_timestamp) * 1e-6 if len(log.frames) > 1 else 0
    rate = (len(log.frames) - 1) / span if span > 0 else 0.0
    return SoakResult(seconds, rate, len(log.frames), len(log.damaged()), len(frames), match,
                      log.expected_resyncs(), stats)


def main(argv: list[str] | None = None) -> int:
    """Command line entry point; returns the exit code."""
    ap = argparse.ArgumentParser(prog="python -m tactile_bt.sense.hardware.soak", description=__doc__.split("\n\n")[0])
    from tactile_bt.arguments import nonnegative_int, positive_float
    from tactile_bt.sense.hardware.options import device_rate, fault_spec

    ap.add_argument("--seconds", type=positive_float, default=10.0, help="duration of each phase in s (default 10)")
    ap.add_argument("--rate", type=device_rate, default=MAX_SENSOR_RATE_HZ, help="frame rate in Hz (default 1900)")
    ap.add_argument("--faults", type=fault_spec, default=DEFAULT_FAULTS,
                    help=f"faulted phase spec (default {DEFAULT_FAULTS!r})")
    ap.add_argument("--no-faults", action="store_true", help="run the clean phase only")
    ap.add_argument("--seed", type=nonnegative_int, default=0)
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    phases = [("clean", None)] + ([] if args.no_faults else [("faulted", args.faults)])
    ok = True
    for name, spec in phases:
        result = run_soak(args.seconds, args.rate, spec, args.seed)
        ok &= result.ok
        if args.json:
            import json

            print(json.dumps({"phase": name, "ok": result.ok, **{k: v for k, v in asdict(result).items()}}, default=str))
        else:
            print(f"{name:8s} {result.summary()}", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
