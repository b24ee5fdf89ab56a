"""Chunked recordings: round trip, torn tails, corruption errors, replay, SIGKILL mid-run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

from tactile_bt.sense.hardware.cli import main as cli_main
from tactile_bt.sense.hardware.emulator import DeviceEmulator, synthetic_source
from tactile_bt.sense.hardware.protocol import TactileFrame
from tactile_bt.sense.hardware.recording import Recorder, iter_chunks, read_recording, replay
from tactile_bt.errors import RecordingError, RecordingWarning


def make_recording(path, n=50, chunk_frames=8, poses=True) -> np.ndarray:
    values = np.random.default_rng(0).integers(0, 4096, (n, 16, 16), dtype=np.uint16)
    with Recorder(path, metadata={"rate_hz": 250}, chunk_frames=chunk_frames, chunk_seconds=1e9) as rec:
        for k, v in enumerate(values):
            pose = None
            if poses and k % 3 == 1:
                pose = np.eye(4) * (k + 1)
            elif poses and k % 3 == 2:
                pose = [0.1 * k, 0.0, 0.5, 0.0, 0.0, 0.0, 1.0]
            rec.write(TactileFrame(v, 10.0 + 0.004 * k, 1, 1000 * k), pose=pose)
    return values


def test_roundtrip_values_timestamps_poses_and_metadata(tmp_path):
    path = tmp_path / "r.tbr"
    values = make_recording(path)
    rec = read_recording(path)
    got_values, timestamps, poses = rec
    np.testing.assert_array_equal(got_values, values)
    np.testing.assert_allclose(timestamps, 10.0 + 0.004 * np.arange(50))
    assert rec.device_timestamps[7] == 7000 and set(rec.sensor_ids) == {1}
    assert np.isnan(poses[0]).all()
    np.testing.assert_array_equal(poses[1], np.eye(4) * 2)
    np.testing.assert_allclose(poses[2][:3, 3], [0.2, 0.0, 0.5])
    np.testing.assert_allclose(poses[2][:3, :3], np.eye(3))
    assert rec.metadata["rate_hz"] == 250 and (rec.rows, rec.cols) == (16, 16)
    assert rec.chunks == 7 and rec.torn_tail_bytes == 0 and len(rec) == 50


def test_raw_arrays_bad_shapes_and_bad_poses(tmp_path):
    with Recorder(tmp_path / "a.tbr") as rec:
        rec.write(np.zeros((16, 16)), timestamp=1.5)
        with pytest.raises(ValueError, match="shape"):
            rec.write(np.zeros((8, 8)))
        with pytest.raises(ValueError, match="pose"):
            rec.write(np.zeros((16, 16)), pose=[1, 2, 3])
    assert read_recording(tmp_path / "a.tbr").timestamps.tolist() == [1.5]
    with Recorder(tmp_path / "empty.tbr"):
        pass
    empty = read_recording(tmp_path / "empty.tbr")
    assert empty.values.shape == (0, 16, 16) and empty.poses.shape == (0, 4, 4)


def test_torn_tail_at_every_offset_keeps_every_complete_chunk(tmp_path):
    path = tmp_path / "r.tbr"
    values = make_recording(path, n=20, chunk_frames=8)  # chunks of 8, 8, 4 frames
    offsets = [c.offset for c in iter_chunks(path)]
    data = path.read_bytes()
    cut_path = tmp_path / "cut.tbr"
    for cut in range(offsets[1], len(data), 97):
        cut_path.write_bytes(data[:cut])
        rec = read_recording(cut_path)
        complete = sum(1 for o in offsets[1:] + [len(data)] if o <= cut)
        n = [8, 16, 20][complete - 1]
        end = [*offsets[1:], len(data)][complete - 1]
        np.testing.assert_array_equal(rec.values, values[:n])
        assert rec.torn_tail_bytes == cut - end
        assert rec.torn_tail_offset == (end if cut > end else None)
        if cut > end:
            with pytest.warns(RecordingWarning, match=f"torn chunk at byte {end}; replaying the {n} complete frames"):
                assert len(list(replay(cut_path))) == n
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                assert len(list(replay(cut_path))) == n


def test_corrupted_header_and_chunk_name_file_and_offset(tmp_path):
    path = tmp_path / "r.tbr"
    make_recording(path, n=20)
    data = bytearray(path.read_bytes())
    bad = tmp_path / "bad.tbr"
    bad.write_bytes(b"XX" + data[2:])
    with pytest.raises(RecordingError, match=rf"{bad}.*byte offset 0"):
        read_recording(bad)
    corrupt = bytearray(data)
    corrupt[30] ^= 0xFF  # inside the JSON metadata
    bad.write_bytes(corrupt)
    with pytest.raises(RecordingError, match=r"file header: CRC mismatch at byte offset \d+"):
        read_recording(bad)
    second = [c.offset for c in iter_chunks(path)][1]
    for where, what in ((second, "bad chunk magic"), (second + 100, "chunk payload CRC mismatch")):
        corrupt = bytearray(data)
        corrupt[where] ^= 0xFF
        bad.write_bytes(corrupt)
        with pytest.raises(RecordingError, match=rf"{bad}: corrupted chunk at byte offset {second}: {what}"):
            read_recording(bad)
        assert len(read_recording(bad, strict=False)) == 8  # the chunks before it
    bad.write_bytes(data[:10])
    with pytest.raises(RecordingError, match="truncated file header"):
        read_recording(bad)


class _InterruptedFrame:
    """A frame whose sensor id is read when a Ctrl-C (or the SIGTERM the CLI turns into one)
    arrives: the recorder is interrupted half-way through buffering it."""

    def __init__(self, values: np.ndarray, timestamp: float) -> None:
        self.values, self.timestamp, self.device_timestamp = values, timestamp, 9

    @property
    def sensor_id(self) -> int:
        raise KeyboardInterrupt


def test_an_interrupt_while_a_frame_is_buffered_leaves_a_readable_recording(tmp_path):
    path = tmp_path / "r.tbr"
    values = np.random.default_rng(1).integers(0, 4096, (5, 16, 16), dtype=np.uint16)
    with pytest.raises(KeyboardInterrupt):
        with Recorder(path, chunk_frames=64, chunk_seconds=1e9) as rec:
            for k, v in enumerate(values):
                rec.write(TactileFrame(v, 0.004 * k, 1, k))
            rec.write(_InterruptedFrame(values[0], 1.0))
    got, timestamps, _ = read_recording(path)  # the frames before the interrupt, none half-written
    np.testing.assert_array_equal(got, values)
    np.testing.assert_allclose(timestamps, 0.004 * np.arange(5))


def test_an_interrupt_while_a_chunk_is_written_leaves_each_frame_once(tmp_path):
    path = tmp_path / "r.tbr"
    values = np.random.default_rng(2).integers(0, 4096, (4, 16, 16), dtype=np.uint16)
    with pytest.raises(KeyboardInterrupt):
        with Recorder(path, chunk_frames=4, chunk_seconds=1e9) as rec:
            sync = rec._sync

            def interrupted_once():  # the chunk is in the file, not yet on disk
                rec._sync = sync
                raise KeyboardInterrupt

            rec._sync = interrupted_once
            for k, v in enumerate(values):  # the fourth frame fills the chunk and writes it
                rec.write(TactileFrame(v, 0.004 * k, 1, k))
    got, timestamps, _ = read_recording(path)  # written again on close, once
    np.testing.assert_array_equal(got, values)
    np.testing.assert_allclose(timestamps, 0.004 * np.arange(4))


def test_replay_is_deterministic_and_paced(tmp_path):
    path = tmp_path / "r.tbr"
    values = make_recording(path, n=40)  # 0.156 s of recorded time
    fast = list(replay(path))
    start = time.monotonic()
    paced = list(replay(path, speed=2.0, with_poses=True))
    elapsed = time.monotonic() - start
    assert 0.06 <= elapsed <= 0.5
    assert len(fast) == len(paced) == 40
    for a, (b, pose) in zip(fast, paced):
        assert a.timestamp == b.timestamp and a.device_timestamp == b.device_timestamp
        np.testing.assert_array_equal(a.values, b.values)
        assert pose.shape == (4, 4)
    np.testing.assert_array_equal(np.stack([f.values for f in fast]), values)
    with pytest.raises(ValueError, match="speed"):
        next(replay(path, speed=0))


def test_cli_replay_reports_and_fails_cleanly(tmp_path, capsys):
    path = tmp_path / "r.tbr"
    make_recording(path, n=10)
    assert cli_main(["sensor", "replay", str(path), "--frames"]) == 0
    out = capsys.readouterr().out
    assert "replayed 10 frames" in out and out.count("t=") == 10
    (tmp_path / "junk.tbr").write_bytes(b"not a recording")
    assert cli_main(["sensor", "replay", str(tmp_path / "junk.tbr")]) == 2
    assert "byte offset 0" in capsys.readouterr().err


def test_sigkill_mid_recording_leaves_every_completed_chunk_replayable(tmp_path):
    out = tmp_path / "killed.tbr"
    with DeviceEmulator(synthetic_source(), rate_hz=1900) as emu:
        proc = subprocess.Popen(
            [sys.executable, "-m", "tactile_bt.sense.hardware.cli", "sensor", "record", emu.port, "--out", str(out),
             "--chunk-frames", "100"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        try:
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and (not out.exists() or out.stat().st_size < 4 * 100 * 653):
                time.sleep(0.02)
            os.kill(proc.pid, signal.SIGKILL)
            assert proc.wait(timeout=5) == -signal.SIGKILL
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait(timeout=5)
        sent = emu.log.intact()
    rec = read_recording(out)
    assert rec.chunks >= 4 and len(rec) >= 4 * 100
    # the recording is a run of consecutive frames the emulator sent, contents intact
    first = [f.device_timestamp for f in sent].index(int(rec.device_timestamps[0]))
    for k in range(len(rec)):
        assert sent[first + k].device_timestamp == rec.device_timestamps[k]
        np.testing.assert_array_equal(sent[first + k].values, rec.values[k])
    assert sum(1 for _ in replay(out)) == len(rec)
