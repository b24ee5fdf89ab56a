"""The device emulator over a pseudo-terminal: protocol answers, push mode, faults, lifetime."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import serial

from tactile_bt.sense.hardware import protocol as P
from tactile_bt.sense.hardware.driver import SerialTactileSensor
from tactile_bt.sense.hardware.emulator import DeviceEmulator, EmulatorLog, FaultConfig, SentFrame, synthetic_source
from tactile_bt.sense.hardware.recording import Recorder

#: Bound on waits that only fail a broken run (configuration answer, first frame): generous, so
#: that a loaded machine does not fail them.
T = 5.0


def raw_port(emu: DeviceEmulator) -> serial.Serial:
    return serial.Serial(emu.port, timeout=0.05)


def read_datagrams(ser: serial.Serial, parser: P.DatagramParser, seconds: float) -> list:
    """Everything that arrives within ``seconds`` (to check that nothing does)."""
    out, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        out += parser.feed(ser.read(max(1, ser.in_waiting)))
    return out


def read_until(ser: serial.Serial, parser: P.DatagramParser, done, timeout: float = 10.0) -> list:
    """Read until ``done(datagrams so far)`` holds; the timeout only bounds a broken run."""
    out, end = [], time.monotonic() + timeout
    while not done(out):
        assert time.monotonic() < end, f"timed out after {timeout} s with {len(out)} datagrams"
        out += parser.feed(ser.read(max(1, ser.in_waiting)))
    return out


def wait_until(condition, timeout: float = 10.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, f"timed out after {timeout} s"
        time.sleep(0.002)


def test_answers_configuration_request():
    with DeviceEmulator(device_id=9, sensor_type=0x1616) as emu, raw_port(emu) as ser:
        ser.write(P.config_request_command())
        (answer,) = read_until(ser, P.DatagramParser(), lambda got: got)
        assert answer == P.ConfigAnswer(version=1, device_id=9, sensors=((0x1616, 512),))


def test_unknown_command_bad_checksum_and_unknown_sensor_get_error_datagrams():
    with DeviceEmulator() as emu, raw_port(emu) as ser:
        ser.write(P.build_command(0, 0xC2))  # serial-number request: not emulated
        ser.write(b"\xf0\xc4\x00\xc0\x00")  # config request with a wrong checksum
        ser.write(P.build_command(7, P.CMD_STOP_STREAM))  # no sensor 7
        errors = read_until(ser, P.DatagramParser(), lambda got: len(got) >= 3)
        assert sorted(e.code for e in errors) == sorted([P.ERR_UNKNOWN_COMMAND, P.ERR_CHECKSUM, P.ERR_UNKNOWN_SENSOR])


def test_streams_at_the_period_the_host_sets_and_stops():
    with DeviceEmulator(synthetic_source(), rate_hz=1900) as emu, raw_port(emu) as ser:
        start = time.monotonic()
        ser.write(P.set_period_command(1, 0.01) + P.start_stream_command())
        frames = read_until(ser, P.DatagramParser({1: 512}), lambda got: len(got) >= 30)
        assert emu.period == pytest.approx(0.01)
        assert time.monotonic() - start >= 29 * 0.01  # 100 Hz, not the 1900 Hz it started with
        assert np.median(np.diff([f.timestamp for f in frames])) == pytest.approx(10_000, rel=0.1)
        ser.write(P.stop_stream_command())
        wait_until(lambda: not emu.streaming)
        ser.reset_input_buffer()
        assert read_datagrams(ser, P.DatagramParser({1: 512}), 0.1) == []


def test_device_timestamps_count_microseconds():
    with DeviceEmulator(synthetic_source(), rate_hz=500) as emu, SerialTactileSensor(emu.port, timeout=T) as sensor:
        frames = [f for f, _ in zip(sensor.frames(timeout=T), range(50))]
    steps = np.diff([f.device_timestamp for f in frames])
    assert np.median(steps) == pytest.approx(2000, rel=0.2)


def test_push_sends_exactly_the_given_frame():
    rng = np.random.default_rng(5)
    with DeviceEmulator() as emu, SerialTactileSensor(emu.port, timeout=T) as sensor:
        for _ in range(25):
            values = rng.integers(0, 4096, (16, 16))
            emu.push(values)
            frame = sensor.read(timeout=T)
            np.testing.assert_array_equal(frame.values, values)
            assert frame.values.dtype == np.uint16
        assert [f.pushed for f in emu.log.frames] == [True] * 25


def test_push_validates_and_needs_a_streaming_host():
    with DeviceEmulator() as emu:
        with pytest.raises(RuntimeError, match="not started streaming"):
            emu.push(np.zeros((16, 16)), timeout=0.05)
        with pytest.raises(ValueError, match="shape"):
            emu.push(np.zeros((4, 4)))
        with pytest.raises(ValueError, match="0..4095"):
            emu.push(np.full((16, 16), 4096))
        with pytest.raises(ValueError, match="NaN"):
            emu.push(np.full((16, 16), np.nan))


def test_streams_a_recording_in_a_loop(tmp_path):
    path = tmp_path / "rec.tbr"
    values = np.arange(5 * 256, dtype=np.uint16).reshape(5, 16, 16) % 4096
    with Recorder(path, chunk_frames=2) as rec:
        for k, v in enumerate(values):
            rec.write(v, timestamp=k * 0.004)
    with DeviceEmulator(path, rate_hz=1000) as emu, SerialTactileSensor(emu.port, timeout=T) as sensor:
        got = [f.values for f, _ in zip(sensor.frames(timeout=T), range(12))]
    for k, v in enumerate(got):
        np.testing.assert_array_equal(v, values[k % 5])


def test_fault_spec_parsing():
    cfg = FaultConfig.parse("garbage=0.1, tear=0.2,pause_s=0.5,garbage_max=9")
    assert (cfg.garbage, cfg.tear, cfg.pause_s, cfg.garbage_max, cfg.bitflip) == (0.1, 0.2, 0.5, 9, 0.0)
    assert FaultConfig.parse("all=0.01").header == 0.01
    assert FaultConfig.parse(None) == FaultConfig()
    with pytest.raises(ValueError, match="unknown fault"):
        FaultConfig.parse("lightning=1")
    with pytest.raises(ValueError, match="name=number"):
        FaultConfig.parse("tear=often")
    assert FaultConfig.parse("garbage_max=9.0").garbage_max == 9


@pytest.mark.parametrize("spec, message", [
    ("garbage=2", r"garbage=2: a probability must lie in 0\.\.1"),
    ("tear=-0.1", r"tear=-0.1: a probability"),
    ("pause=nan", r"pause=nan: a probability"),
    ("bitflip=inf", r"bitflip=inf: a probability"),
    ("all=0.5", r"bitflip=0.5 \+ tear=0.5 \+ header=0.5 = 1.5 exceed 1"),
    ("garbage_max=0", r"garbage_max=0: expected an integer"),
    ("garbage_max=2.5", r"garbage_max=2.5: expected an integer"),
    ("garbage_max=1e9", r"garbage_max=1000000000: expected an integer"),
    ("pause_s=-1", r"pause_s=-1.0: expected a finite number"),
    ("pause_s=inf", r"pause_s=inf: expected a finite number"),
    ("tear", r"'tear': expected name=number"),
    ("tear=", r"'tear=': expected name=number"),
    ("=0.1", r"unknown fault ''"),
])
def test_fault_spec_out_of_range_is_rejected(spec, message):
    with pytest.raises(ValueError, match=message):
        FaultConfig.parse(spec)


def test_fault_config_checks_direct_construction():
    with pytest.raises(ValueError, match="garbage=1.5"):
        FaultConfig(garbage=1.5)


def test_fault_injection_ground_truth_matches_the_raw_byte_stream():
    faults = FaultConfig(garbage=0.1, bitflip=0.1, tear=0.1, header=0.1, pause=0.02, pause_s=0.002)
    with DeviceEmulator(synthetic_source(), rate_hz=1900, faults=faults, seed=3) as emu, raw_port(emu) as ser:
        parser = P.DatagramParser({1: 512}, accept_config=False)
        datagrams = stream_and_stop(emu, ser, parser, 700)
    log = emu.log
    assert not log.frames[-1].fault and parser.pending == 0
    kinds = {f.fault for f in log.frames} | {"header" if f.header_pattern else None for f in log.frames}
    assert {"bitflip", "tear", "header", None} <= kinds
    assert any(k == "garbage" for k, _ in log.events) and any(k == "pause" for k, _ in log.events)
    intact = log.intact()
    assert [d.timestamp for d in datagrams] == [f.device_timestamp for f in intact]
    inverse = np.argsort(P.cell_permutation(None))
    for d, f in zip(datagrams, intact):
        np.testing.assert_array_equal(P.decode_values(d.payload, inverse), f.values)
    assert parser.stats.checksum_errors + parser.stats.overlaps == len(log.damaged())
    assert parser.stats.resyncs == log.expected_resyncs()


def stream_and_stop(emu: DeviceEmulator, ser: serial.Serial, parser: P.DatagramParser, frames: int) -> list:
    """Stream ``frames`` frames, then clean ones until a fault-free frame went out, stop, and
    read every byte sent: the datagrams, decided from the whole stream."""
    ser.write(P.start_stream_command())
    datagrams = read_until(ser, parser, lambda got: emu.frames_sent >= frames)
    # End on a clean line, so that a later intact frame resolves every fault: the frame
    # being sent now may still be damaged, the next one is clean and must have gone out.
    emu.faults = FaultConfig()
    first_clean = emu.frames_sent + 1
    datagrams += read_until(ser, parser, lambda got: emu.frames_sent > first_clean)
    ser.write(P.stop_stream_command())
    # Once the emulator has stopped, read every byte it sent, however late it arrives.
    datagrams += read_until(ser, parser, lambda got: not emu.streaming and parser.stats.bytes_in == emu.bytes_sent)
    return datagrams + parser.feed(b"", settle=True)


def test_torn_datagrams_never_pass_the_checksum_with_the_bytes_after_them():
    # Many tears followed by long garbage: without care, 1 in 256 torn datagrams would pass the
    # 8-bit XOR together with what follows and be delivered (or dropped with its neighbours).
    faults = FaultConfig(tear=0.4, bitflip=0.1, garbage=0.4, header=0.1, garbage_max=600)
    with DeviceEmulator(synthetic_source(), rate_hz=5000, faults=faults, seed=8) as emu, raw_port(emu) as ser:
        parser = P.DatagramParser({1: 512}, accept_config=False)
        datagrams = stream_and_stop(emu, ser, parser, 1500)
    log = emu.log
    assert [d.timestamp for d in datagrams] == [f.device_timestamp for f in log.intact()]
    assert parser.stats.checksum_errors == len(log.damaged()) > 500 and parser.stats.overlaps == 0
    assert parser.stats.resyncs == log.expected_resyncs()


def test_expected_resyncs_counts_runs_of_damage():
    frames = [SentFrame(k, np.zeros((1, 1)), k, fault) for k, fault in enumerate([None, "tear", "bitflip", None, None])]
    events = [("frame", 0), ("garbage", 3), ("frame", 1), ("frame", 2), ("frame", 3), ("garbage", 1), ("frame", 4)]
    assert EmulatorLog(frames, events).expected_resyncs() == 2


def test_close_releases_file_descriptors_and_threads():
    fds, threads = set(os.listdir("/proc/self/fd")), set(threading.enumerate())
    for _ in range(3):
        with DeviceEmulator(synthetic_source()) as emu, SerialTactileSensor(emu.port, timeout=T) as sensor:
            sensor.read(timeout=T)
    # Nothing this test opened stays open (compared as sets: earlier tests' fds may close meanwhile).
    assert set(os.listdir("/proc/self/fd")) <= fds
    assert not [t for t in threading.enumerate() if t not in threads]


def test_a_failing_source_is_reported_and_the_device_keeps_answering():
    def source():
        raise RuntimeError("simulator exploded")

    with DeviceEmulator(source) as emu, raw_port(emu) as ser:
        ser.write(P.start_stream_command())
        wait_until(lambda: emu.error is not None)
        assert isinstance(emu.error, RuntimeError)
        ser.write(P.config_request_command())
        read_until(ser, P.DatagramParser(), lambda got: any(isinstance(d, P.ConfigAnswer) for d in got))


def test_cli_emulate_prints_a_port_a_driver_can_open():
    proc = subprocess.Popen([sys.executable, "-m", "tactile_bt.sense.hardware.cli", "sensor", "emulate", "--duration", "20"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = proc.stdout.readline().strip()
        assert port.startswith("/dev/")
        with SerialTactileSensor(port, timeout=T) as sensor:
            assert sensor.read(timeout=T).values.shape == (16, 16)
        proc.terminate()
        assert proc.wait(timeout=5) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=5)
        proc.stdout.close()
        proc.stderr.close()
