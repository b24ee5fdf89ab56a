"""Careless input to the replay and sensor commands: one ``error:`` line naming the option or
file, no traceback, no file overwritten unasked; warnings for what a replay has to leave out."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.cli import main
from tactile_bt.sense.hardware.recording import Recorder, iter_chunks, read_header, read_recording
from tactile_bt.errors import RecordingWarning
from tactile_bt.mission.replay import replay_mission

ROOT = Path(__file__).resolve().parents[2]
TREE = str(ROOT / "trees" / "cable_follow.yaml")
SCENE = str(ROOT / "sim" / "cable.yaml")
NO_PORT = "/nonexistent/tactile-port"  # a command that opened it would fail with a port error


def make_recording(path: Path, n: int = 40, chunk_frames: int = 8, rows: int = 16, cols: int = 16) -> Path:
    """``n`` contact-free frames at 250 Hz in chunks of ``chunk_frames``."""
    values = np.full((rows, cols), 100, dtype=np.uint16)
    with Recorder(path, rows, cols, metadata={"rate_hz": 250}, chunk_frames=chunk_frames, chunk_seconds=1e9) as rec:
        for k in range(n):
            rec.write(values, pose=np.eye(4), timestamp=0.004 * k)
    return path


def cli(argv: list[str], capsys) -> tuple[int, str, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse
        rc = exc.code
    out, err = capsys.readouterr()
    return rc, out, err


def single_error(rc: int, err: str) -> str:
    """The one error line of a failed command (argparse's is ``PROG: error: ...``)."""
    assert rc not in (0, None), err
    assert "Traceback" not in err
    lines = err.splitlines()
    errors = [line for line in lines if line.startswith("error:") or ": error: " in line]
    assert len(errors) == 1, err
    assert lines[-1] == errors[0], err
    return errors[0]


# ---------------------------------------------------------------- option values (argparse)
REPLAY = ["replay", "rec.tbr", "--tree", TREE]
SENSOR_REPLAY = ["sensor", "replay", "rec.tbr"]
EMULATE = ["sensor", "emulate"]
STREAM = ["sensor", "stream", NO_PORT]
RECORD = ["sensor", "record", NO_PORT, "--out", "out.tbr"]

BAD_OPTIONS = [
    (REPLAY, "--speed", "0"),
    (REPLAY, "--speed", "-1"),
    (REPLAY, "--speed", "nan"),
    (REPLAY, "--speed", "inf"),
    (REPLAY, "--speed", "fast"),
    (SENSOR_REPLAY, "--speed", "0"),
    (SENSOR_REPLAY, "--speed", "-1"),
    (EMULATE, "--rate", "0"),
    (EMULATE, "--rate", "-5"),
    (EMULATE, "--rate", "nan"),
    (EMULATE, "--rate", "20000"),
    (EMULATE, "--faults", "garbage=2"),
    (EMULATE, "--faults", "lightning=0.1"),
    (EMULATE, "--faults", "tear=often"),
    (EMULATE, "--faults", "tear=-0.1"),
    (EMULATE, "--faults", "all=0.5"),
    (EMULATE, "--faults", "garbage_max=-1"),
    (EMULATE, "--faults", "pause_s=inf"),
    (EMULATE, "--seed", "-1"),
    (EMULATE, "--rows", "0"),
    (EMULATE, "--cols", "-3"),
    (EMULATE, "--duration", "0"),
    (EMULATE, "--duration", "-1"),
    (STREAM, "--rate", "0"),
    (STREAM, "--rate", "-5"),
    (STREAM, "--timeout", "0"),
    (STREAM, "--timeout", "nan"),
    (STREAM, "--every", "0"),
    (STREAM, "--every", "-2"),
    (STREAM, "--duration", "inf"),
    (STREAM, "--baudrate", "0"),
    (STREAM, "--baudrate", "9.6"),
    (STREAM, "--rows", "0"),
    (STREAM, "--cols", "x"),
    (RECORD, "--chunk-frames", "0"),
    (RECORD, "--rate", "-1"),
    (RECORD, "--duration", "-1"),
    (RECORD, "--timeout", "-1"),
    (RECORD, "--rows", "-16"),
]


@pytest.mark.parametrize("command, option, value", BAD_OPTIONS,
                         ids=[f"{' '.join(c[:2])} {o} {v}" for c, o, v in BAD_OPTIONS])
def test_bad_option_values_are_rejected_up_front(command, option, value, capsys):
    rc, out, err = cli([*command, option, value], capsys)
    line = single_error(rc, err)
    assert f"argument {option}:" in line and value.split("=")[-1] in line
    assert rc == 2 and out == ""


# ---------------------------------------------------------------- files
def _corrupt(tmp: Path) -> tuple[Path, str]:
    path = make_recording(tmp / "corrupt.tbr")
    second = [c.offset for c in iter_chunks(path)][1]
    data = bytearray(path.read_bytes())
    data[second + 100] ^= 0xFF
    path.write_bytes(data)
    return path, f"byte offset {second}: chunk payload CRC mismatch"


def _junk(tmp: Path) -> tuple[Path, str]:
    path = tmp / "junk.tbr"
    path.write_bytes(b"not a recording at all")
    return path, "byte offset 0"


def _missing(tmp: Path) -> tuple[Path, str]:
    return tmp / "missing.tbr", "No such file"


def _directory(tmp: Path) -> tuple[Path, str]:
    (tmp / "dir.tbr").mkdir()
    return tmp / "dir.tbr", "directory"


@pytest.mark.parametrize("make", [_corrupt, _junk, _missing, _directory])
@pytest.mark.parametrize("command", ["replay", "sensor replay"])
def test_both_replays_report_a_bad_recording_in_one_line(command, make, tmp_path, capsys):
    path, what = make(tmp_path)
    argv = ["replay", path, "--tree", TREE] if command == "replay" else ["sensor", "replay", path]
    rc, _out, err = cli(argv, capsys)
    line = single_error(rc, err)
    assert line.startswith("error:") and str(path) in line and what in line


def _empty(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "empty.tbr", n=0)
    return ["replay", path, "--tree", TREE], [str(path), "no complete chunk"]


def _only_torn(tmp: Path) -> tuple[list, list]:
    full = make_recording(tmp / "full.tbr", n=8, chunk_frames=8)
    path = tmp / "torn.tbr"
    path.write_bytes(full.read_bytes()[:-100])
    offset = next(iter_chunks(full)).offset
    return ["replay", path, "--tree", TREE], [str(path), f"chunk at byte {offset} is torn"]


def _calibration_not_npz(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "r.tbr")
    return ["replay", path, "--tree", TREE, "--calibration", TREE], [TREE, "not a readable .npz"]


def _calibration_missing(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "r.tbr")
    return ["replay", path, "--tree", TREE, "--calibration", tmp / "nope.npz"], [str(tmp / "nope.npz")]


def _calibration_wrong_shape(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "r.tbr")
    TactelCalibration.nominal(8, 8).save(tmp / "small.npz")
    return ["replay", path, "--tree", TREE, "--calibration", tmp / "small.npz"], [str(tmp / "small.npz"), "8x8", "16x16"]


def _side_calibration_wrong_shape(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "r.tbr")
    TactelCalibration.nominal(8, 8).save(tmp / "r.tbr.calibration.npz")
    return ["replay", path, "--tree", TREE], [str(tmp / "r.tbr.calibration.npz"), "8x8"]


def _replay_out_is_a_file(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "r.tbr")
    TactelCalibration.nominal().save(tmp / "r.tbr.calibration.npz")
    (tmp / "out").write_text("a file")
    return ["replay", path, "--tree", TREE, "--out", tmp / "out"], [str(tmp / "out")]


def _emulate_missing_recording(tmp: Path) -> tuple[list, list]:
    return ["sensor", "emulate", "--recording", tmp / "nope.tbr"], ["--recording", str(tmp / "nope.tbr")]


def _emulate_corrupt_recording(tmp: Path) -> tuple[list, list]:
    path, what = _corrupt(tmp)
    return ["sensor", "emulate", "--recording", path], [str(path), what]


def _emulate_empty_recording(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "empty.tbr", n=0)
    return ["sensor", "emulate", "--recording", path], ["--recording", str(path), "no complete frame"]


def _emulate_shape_contradicts_recording(tmp: Path) -> tuple[list, list]:
    path = make_recording(tmp / "r.tbr")
    return ["sensor", "emulate", "--recording", path, "--rows", 8], ["--rows 8", str(path), "16x16"]


def _too_many_tactels(tmp: Path) -> tuple[list, list]:
    return ["sensor", "stream", NO_PORT, "--rows", 200, "--cols", 200], ["--rows 200 --cols 200", "32767"]


def _cell_order_not_numbers(tmp: Path) -> tuple[list, list]:
    return ["sensor", "stream", NO_PORT, "--cell-order", TREE], ["--cell-order", TREE]


def _cell_order_not_a_permutation(tmp: Path) -> tuple[list, list]:
    (tmp / "order.txt").write_text(" ".join(["0"] * 256))
    return ["sensor", "record", NO_PORT, "--out", tmp / "x.tbr", "--cell-order", tmp / "order.txt"], \
        ["--cell-order", str(tmp / "order.txt"), "permutation"]


def _record_out_is_a_directory(tmp: Path) -> tuple[list, list]:
    return ["sensor", "record", NO_PORT, "--out", tmp], [str(tmp), "is a directory"]


def _record_out_under_a_file(tmp: Path) -> tuple[list, list]:
    (tmp / "file").write_text("x")
    return ["sensor", "record", NO_PORT, "--out", tmp / "file" / "r.tbr"], [str(tmp / "file"), "not a directory"]


def _record_out_in_missing_directory(tmp: Path) -> tuple[list, list]:
    return ["sensor", "record", NO_PORT, "--out", tmp / "no" / "r.tbr"], [str(tmp / "no"), "does not exist"]


def _run_record_is_a_directory(tmp: Path) -> tuple[list, list]:
    return ["run", TREE, "--scene", SCENE, "--record", tmp, "--out", tmp / "out"], [str(tmp), "is a directory"]


@pytest.mark.parametrize("case", [
    _empty, _only_torn, _calibration_not_npz, _calibration_missing, _calibration_wrong_shape,
    _side_calibration_wrong_shape, _replay_out_is_a_file, _emulate_missing_recording,
    _emulate_corrupt_recording, _emulate_empty_recording, _emulate_shape_contradicts_recording,
    _too_many_tactels, _cell_order_not_numbers, _cell_order_not_a_permutation, _record_out_is_a_directory,
    _record_out_under_a_file, _record_out_in_missing_directory, _run_record_is_a_directory,
], ids=lambda f: f.__name__.strip("_"))
def test_bad_files_end_in_one_error_line(case, tmp_path, capsys):
    argv, names = case(tmp_path)
    rc, _out, err = cli(argv, capsys)
    line = single_error(rc, err)
    assert line.startswith("error:")
    for name in names:
        assert name in line
    assert NO_PORT not in err  # no port was opened
    assert not (tmp_path / "out").is_dir()  # no mission ran


# ---------------------------------------------------------------- no overwriting unasked
@pytest.mark.parametrize("target", ["recording", "calibration"])
def test_run_record_refuses_to_overwrite(target, tmp_path, capsys):
    record = tmp_path / "cable.yaml"  # e.g. a scene file given by mistake
    existing = record if target == "recording" else Path(f"{record}.calibration.npz")
    existing.write_bytes(b"precious: scene\n")
    rc, out, err = cli(["run", TREE, "--scene", SCENE, "--record", record, "--out", tmp_path / "out"], capsys)
    line = single_error(rc, err)
    assert line == f"error: {existing} exists (use --force to overwrite)"
    assert existing.read_bytes() == b"precious: scene\n"
    assert not (tmp_path / "out").exists() and out == ""  # the mission never started
    assert [p.name for p in tmp_path.iterdir()] == [existing.name]


def test_run_record_force_overwrites_recording_and_calibration(tmp_path, capsys):
    record = tmp_path / "r.tbr"
    make_recording(record, n=1001)
    Path(f"{record}.calibration.npz").write_bytes(b"old")
    rc, _out, err = cli(["run", TREE, "--scene", SCENE, "--duration", "1", "--record", record, "--force",
                         "--out", tmp_path / "out"], capsys)
    assert rc == 0, err
    assert len(read_recording(record)) == 250  # 1 s at 250 Hz: the new recording, nothing of the old
    TactelCalibration.load(f"{record}.calibration.npz")


def test_sensor_record_refuses_to_overwrite_before_opening_the_port(tmp_path, capsys):
    out = make_recording(tmp_path / "r.tbr", n=1001)
    before = out.read_bytes()
    rc, _out, err = cli(["sensor", "record", NO_PORT, "--out", out], capsys)
    assert single_error(rc, err) == f"error: {out} exists (use --force to overwrite)"
    assert out.read_bytes() == before


def test_sensor_record_force_overwrites(tmp_path):
    from tactile_bt.sense.hardware.emulator import DeviceEmulator, synthetic_source

    out = make_recording(tmp_path / "r.tbr", n=1001)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with DeviceEmulator(synthetic_source(), rate_hz=1900, keep_log=False) as emu:
        done = subprocess.run([sys.executable, "-m", "tactile_bt.cli", "sensor", "record", emu.port, "--out", str(out),
                               "--force", "--duration", "0.2"], capture_output=True, text=True, timeout=60, env=env)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    _rows, _cols, meta, _off = read_header(out)
    assert meta["source"] == "sensor record"  # a new recording, whatever its length


# ---------------------------------------------------------------- warnings of a replay
def test_missing_calibration_warns_in_one_line_and_in_the_report(tmp_path, capsys):
    path = make_recording(tmp_path / "r.tbr")
    side = f"{path}.calibration.npz"
    rc, out, err = cli(["replay", path, "--tree", TREE], capsys)
    assert rc == 1 and "Traceback" not in err  # the frames hold no contact: like a mission, a failure
    warned = [line for line in err.splitlines() if line.startswith("warning:")]
    assert len(warned) == 1 and side in warned[0] and "nominal" in warned[0] and "--calibration FILE" in warned[0]
    assert "failure: no contact was made after 40 frames" in out
    with pytest.warns(RecordingWarning, match="nominal"):
        result = replay_mission(TREE, path)
    assert len(result.report["warnings"]) == 1 and side in result.report["warnings"][0]
    TactelCalibration.nominal().save(tmp_path / "cal.npz")
    rc, _out, err = cli(["replay", path, "--tree", TREE, "--calibration", tmp_path / "cal.npz"], capsys)
    assert rc == 1 and "warning" not in err
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert replay_mission(TREE, path, calibration=tmp_path / "cal.npz").report["warnings"] == []


@pytest.mark.parametrize("command", ["replay", "sensor replay"])
def test_a_torn_tail_is_replayed_up_to_the_last_complete_chunk_with_a_warning(command, tmp_path, capsys):
    full = make_recording(tmp_path / "full.tbr", n=40, chunk_frames=8)  # 5 chunks of 8 frames
    last = [c.offset for c in iter_chunks(full)][-1]
    path = tmp_path / "cut.tbr"
    path.write_bytes(full.read_bytes()[: last + 1000])  # half of the last chunk
    TactelCalibration.nominal().save(f"{path}.calibration.npz")
    argv = ["replay", path, "--tree", TREE] if command == "replay" else ["sensor", "replay", path]
    rc, out, err = cli(argv, capsys)
    assert rc == (1 if command == "replay" else 0) and "Traceback" not in err  # replay: no contact was made
    expected = f"warning: {path}: the recording ends in a torn chunk at byte {last}; replaying the 32 complete frames"
    assert [line for line in err.splitlines() if line.startswith("warning:")] == [expected]
    assert ("no contact was made after 32 frames" if command == "replay" else "replayed 32 frames") in out
    with pytest.warns(RecordingWarning, match=f"torn chunk at byte {last}"):
        report = replay_mission(TREE, path).report
    assert report["ticks"] == 32 and report["warnings"] == [expected.removeprefix("warning: ")]


def test_a_failed_replay_gives_the_reason_like_a_mission(tmp_path, capsys):
    tree = tmp_path / "approach.yaml"
    tree.write_text("name: approach_only\nroot:\n  approach: {speed_mps: 0.01, pressure_pa: 800, timeout_s: 0.05}\n")
    path = make_recording(tmp_path / "r.tbr")  # no contact: the approach times out
    TactelCalibration.nominal().save(f"{path}.calibration.npz")
    report = replay_mission(tree, path).report
    assert report["status"] == "failure"
    assert report["reason"].endswith("no contact within 0.05 s")
    rc, out, _err = cli(["replay", path, "--tree", tree], capsys)
    assert rc == 1 and out.startswith(f"failure: {report['reason']} after ")


# ---------------------------------------------------------------- one vocabulary for two replays
def _help(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit):
        main(argv)
    return " ".join(capsys.readouterr().out.split())


def test_the_two_replay_commands_use_the_same_words(capsys):
    top, sensor = _help(["--help"], capsys), _help(["sensor", "--help"], capsys)
    assert "('sensor replay' only prints the frames)" in top
    assert "('tactile-bt replay' runs a tree on them)" in sensor
    replay, sensor_replay = _help(["replay", "--help"], capsys), _help(["sensor", "replay", "--help"], capsys)
    for text in ("1 = the recorded pace, 2 = twice as fast (default: as fast as possible)",
                 "RECORDING a recording made by 'run --record' or 'sensor record'"):
        assert text in replay and text in sensor_replay
