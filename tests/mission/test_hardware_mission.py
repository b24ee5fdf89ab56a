"""Missions with a real serial link in the loop, recording during missions, and replay."""

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from tactile_bt import run_mission
from tactile_bt.sense.hardware.recording import read_recording
from tactile_bt.mission.replay import replay_mission

ROOT = Path(__file__).resolve().parents[2]
TREE = ROOT / "trees" / "cable_follow.yaml"
SCENE = ROOT / "sim" / "cable.yaml"


def test_mission_through_the_emulator_gives_the_same_features_as_direct_frames():
    direct = run_mission(TREE, SCENE, duration=1.5, seed=1)
    serial = run_mission(TREE, SCENE, duration=1.5, seed=1, via_emulator=True)
    for key in ("pressure_raw_pa", "cop_x_px", "cop_y_px", "orientation_raw_rad", "twist_s", "position_m"):
        assert_array_equal(serial.log[key], direct.log[key])
    assert serial.report["status"] == direct.report["status"] == "completed"


def test_a_recorded_mission_replays_deterministically(tmp_path):
    rec = tmp_path / "cable.tbr"
    mission = run_mission(TREE, SCENE, duration=1.5, seed=2, recording=rec)
    recording = read_recording(rec)
    assert len(recording) == mission.report["ticks"]
    assert_array_equal(recording.poses[:, :3, 3], mission.log["position_m"])
    first = replay_mission(TREE, rec)
    again = replay_mission(TREE, rec, speed=50.0)
    for key in ("pressure_raw_pa", "orientation_raw_rad", "twist_s", "error_pressure_pa"):
        assert_array_equal(first.log[key], mission.log[key])
        assert_array_equal(again.log[key], first.log[key])
    assert first.report["metrics"].keys() == mission.report["metrics"].keys()


def test_a_replay_knows_the_table_the_mission_knew(tmp_path):
    from tactile_bt.tree.behaviours.table import TABLE_Z_KEY, write_table_height
    from tactile_bt.tree.blackboard import read

    rec = tmp_path / "cable.tbr"
    run_mission(TREE, SCENE, duration=0.1, seed=2, recording=rec)
    table_z = read(TABLE_Z_KEY)
    assert table_z == pytest.approx(read_recording(rec).metadata["table_z_m"])
    write_table_height(float("nan"))
    replay_mission(TREE, rec)
    assert read(TABLE_Z_KEY) == pytest.approx(table_z)


def test_a_recording_with_a_bad_table_height_is_a_clear_error(tmp_path):
    from tactile_bt.errors import RecordingError, RecordingWarning
    from tactile_bt.sense.hardware.recording import Recorder

    path = tmp_path / "bad.tbr"
    with Recorder(path, metadata={"table_z_m": "low"}) as recorder:
        recorder.write(np.zeros((16, 16), dtype=np.uint16), np.eye(4), timestamp=0.0)
    with pytest.warns(RecordingWarning, match="bad.tbr.calibration.npz is missing"), \
            pytest.raises(RecordingError, match="bad.tbr.*table_z_m"):
        replay_mission(TREE, path)


def test_replay_of_an_empty_recording_is_a_clear_error(tmp_path):
    from tactile_bt.sense.hardware.recording import Recorder

    path = tmp_path / "empty.tbr"
    with Recorder(path):
        pass
    with pytest.raises(ValueError, match="empty.tbr"):
        replay_mission(TREE, path)
