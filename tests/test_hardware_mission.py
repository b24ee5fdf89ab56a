"""Missions with a real serial link in the loop, recording during missions, and replay."""

from pathlib import Path

import pytest
from numpy.testing import assert_array_equal

from tactile_bt import run_mission
from tactile_bt.sense.hardware.recording import read_recording
from tactile_bt.mission.replay import replay_mission

ROOT = Path(__file__).resolve().parent.parent
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


def test_replay_of_an_empty_recording_is_a_clear_error(tmp_path):
    from tactile_bt.sense.hardware.recording import Recorder

    path = tmp_path / "empty.tbr"
    with Recorder(path):
        pass
    with pytest.raises(ValueError, match="empty.tbr"):
        replay_mission(TREE, path)
