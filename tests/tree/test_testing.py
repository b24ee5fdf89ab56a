"""The testing kit itself (tactile_bt.testing): fake features, scripted frames through the real
perception, the fake clock, tick helpers, twist access — and a user's test of their own leaf."""

import doctest
import itertools

import numpy as np
import py_trees
import pytest
from numpy.testing import assert_allclose
from py_trees.common import Status

import tactile_bt.testing
from tactile_bt import defaults
from tactile_bt.tree.behaviours import AlignEdge, Approach, Centre, ContactLost, ForceHold, GuidedSlide, TactileBehaviour
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.perception.features import extract
from tactile_bt.perception.smoothing import FeatureSmoother
from tactile_bt.testing import (
    FramePerception,
    LeafHarness,
    contact_frame,
    make_features,
    raw_frame,
)

DT = 1.0 / 128.0



def test_module_examples_run():
    result = doctest.testmod(tactile_bt.testing)
    assert result.attempted >= 5 and result.failed == 0


# --------------------------------------------------------------------------------- frames


def test_contact_frame_has_the_asked_force_position_and_orientation():
    f = extract(contact_frame(cop_px=(9.0, 6.0), force_n=2.0, orientation_rad=0.4))
    assert f.in_contact
    assert f.force == pytest.approx(2.0, rel=0.03)  # the threshold cuts the rim
    assert_allclose(f.cop_px, (9.0, 6.0), atol=0.05)
    assert f.orientation == pytest.approx(0.4, abs=0.02)
    blob = extract(contact_frame(length_px=0.0, width_px=1.5))
    assert blob.in_contact and np.isnan(blob.orientation)  # round: no dominant axis


def test_raw_frame_round_trips_through_the_calibration():
    image = contact_frame(force_n=1.5)
    raw = raw_frame(image)
    assert raw.dtype == np.uint16 and raw.max() <= defaults.ADC_MAX
    back = TactelCalibration.nominal().force_from_raw(raw)
    assert extract(back).force == pytest.approx(extract(image).force, rel=0.01)
    noisy = raw_frame(image, noise_counts=20, rng=np.random.default_rng(1))
    assert np.any(noisy != raw)


def test_frame_perception_is_the_missions_pipeline():
    """calibrate → extract → moving average over the last 10 frames (paper Sec. V)."""
    perceive = FramePerception()
    smoother = FeatureSmoother(defaults.SMOOTHING_SAMPLES)
    forces = np.linspace(0.6, 2.0, 15)
    for force in forces:
        f_raw, f = perceive(force=contact_frame(force_n=force))
        reference = extract(contact_frame(force_n=force))
        assert f_raw.pressure == pytest.approx(reference.pressure)
        assert f.pressure == pytest.approx(smoother(reference).pressure)
    # raw counts take the calibration inverse first
    cal = TactelCalibration.random(np.random.default_rng(2))
    perceive = FramePerception(calibration=cal)
    f_raw, _ = perceive(raw=raw_frame(contact_frame(force_n=1.0), calibration=cal))
    assert f_raw.force == pytest.approx(extract(contact_frame(force_n=1.0)).force, rel=0.01)
    with pytest.raises(ValueError):
        perceive()


def test_tick_with_frames_smooths_across_ticks_like_a_mission():
    h = LeafHarness(ForceHold(target_pa=2000.0), dt=DT)
    h.tick(frame=contact_frame(force_n=0.5))
    first = h.features.pressure
    h.tick(frame=contact_frame(force_n=1.5))
    assert h.features_raw.pressure > h.features.pressure > first  # the average lags
    assert h.features.pressure == pytest.approx(0.5 * (first + h.features_raw.pressure))
    h.tick(raw=raw_frame(np.zeros((16, 16))))  # an empty frame resets the average
    assert not h.features.in_contact


def test_tick_until_scripts_frames_and_keeps_the_last_one():
    """Approach through the real perception: a growing contact ends it."""
    h = LeafHarness(Approach(pressure_pa=800.0), dt=DT)
    script = [np.zeros((16, 16))] * 3 + [contact_frame(force_n=f) for f in (0.2, 0.4, 0.8, 1.2)]
    n = h.tick_until(Status.SUCCESS, frames=script)
    assert n >= 7  # the smoothed pressure may need the last frame repeated
    assert h.features.pressure >= 800.0
    h2 = LeafHarness(Approach(pressure_pa=800.0), dt=DT)
    raws = [raw_frame(np.zeros((16, 16)))] + [raw_frame(contact_frame(force_n=1.5))]
    assert h2.tick_until(Status.SUCCESS, raw_frames=raws) >= 2
    with pytest.raises(ValueError, match="one kind"):
        h2.tick_until(features=[make_features()], frames=[contact_frame()])


def test_tick_until_raises_after_max_ticks():
    h = LeafHarness(ForceHold(), dt=DT)
    with pytest.raises(AssertionError, match="still"):
        h.tick_until(Status.SUCCESS, max_ticks=10)


def test_tick_for_counts_mission_time_and_the_clock_is_the_missions():
    h = LeafHarness(GuidedSlide(duration_s=0.5), dt=DT)
    assert h.tick_for(0.25) == Status.RUNNING
    assert h.time == pytest.approx(0.25)
    assert h.tick_for(1.0) == Status.SUCCESS  # stops when the leaf finishes
    assert h.time == pytest.approx(0.5 + DT)


def test_twist_parts_errors_and_blackboard_writes():
    tree = py_trees.composites.Parallel(
        "p", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[ForceHold(), Centre(), GuidedSlide(name="guide", twist_key="/planner/twist")])
    h = LeafHarness(tree, dt=DT)
    h.set("/planner/twist", [0.0, 0.01, 0.0, 0.0, 0.0, 0.0])
    h.tick(make_features(pressure=1500.0, cop_px=(10.0, 7.5)))
    assert h.twist_of("force_hold")[2] > 0 and h.twist_of("centre")[0] > 0
    assert_allclose(h.twist_of(tree.children[2]), [0, 0.01, 0, 0, 0, 0])
    assert_allclose(h.twist, h.twist_of("force_hold") + h.twist_of("centre") + h.twist_of("guide"))
    assert h.twist_of("p").tolist() == [0.0] * 6  # a node of the tree that added nothing
    assert set(h.errors) == {"pressure_pa", "cop_x_px", "cop_y_px"}


def test_twist_of_an_unknown_name_is_an_error_that_lists_the_names():
    from tactile_bt.errors import UnknownNodeError

    tree = py_trees.composites.Parallel(
        "p", policy=py_trees.common.ParallelPolicy.SuccessOnOne(), children=[ForceHold(), Centre()])
    h = LeafHarness(tree, dt=DT)
    h.tick()
    with pytest.raises(KeyError) as info:
        h.twist_of("typo")
    assert isinstance(info.value, UnknownNodeError)
    assert str(info.value) == "no node named 'typo' in 'p'; known: p, force_hold, centre"
    with pytest.raises(UnknownNodeError, match=r"did you mean 'centre'\?"):
        h.twist_of("center")
    with pytest.raises(UnknownNodeError, match="known: force_hold"):
        LeafHarness(ForceHold()).twist_of(Centre())


def test_leaf_harness_takes_a_loaded_tree_or_its_root():
    from tactile_bt import load_tree

    text = "root:\n  parallel:\n    children: [{force_hold: {target_pa: 2000}}, {centre: {}}]\n"
    tree = load_tree("t.yaml", text=text)
    h = LeafHarness(tree, dt=DT)
    assert h.tree is tree and h.behaviour is tree.root
    h.tick(make_features(pressure=1500.0, cop_px=(10.0, 7.5)))
    assert h.twist_of("force_hold")[2] > 0 and h.twist_of("centre")[0] > 0
    assert LeafHarness(load_tree("t.yaml", text=text).root).tree is None
    plain = py_trees.trees.BehaviourTree(ForceHold(name="hold"))
    assert LeafHarness(plain).tick(make_features(pressure=1500.0)) == Status.RUNNING


def test_guided_slide_without_its_twist_key_fails_clearly_when_it_starts():
    from tactile_bt.errors import BlackboardReferenceError

    h = LeafHarness(GuidedSlide(twist_key="/planner/twist"), dt=DT)
    with pytest.raises(BlackboardReferenceError, match="'/planner/twist'.*not set"):
        h.tick()


# --------------------------------------------------------------------------------- a user's test


class PressureAbove(TactileBehaviour):
    """A user's own leaf: SUCCESS while the smoothed pressure is above ``limit_pa``."""

    uses = frozenset({"pressure"})

    def __init__(self, name: str = "pressure_above", limit_pa: float = 1000.0) -> None:
        super().__init__(name)
        self.limit_pa = float(limit_pa)

    def update(self) -> Status:
        return Status.SUCCESS if self.features.pressure > self.limit_pa else Status.FAILURE


def test_a_user_leaf_in_a_few_lines():
    h = LeafHarness(PressureAbove(limit_pa=1000.0))
    assert h.tick(make_features(pressure=1500)) == Status.SUCCESS
    assert h.tick(make_features(pressure=500)) == Status.FAILURE
    assert h.tick(frame=contact_frame(force_n=2.0)) == Status.SUCCESS  # through the real perception


def test_a_user_tree_with_a_guard_in_a_few_lines():
    """A user's small tree: hold the force and centre, fail when contact is lost for 0.25 s."""
    root = py_trees.composites.Parallel("hold", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                                        children=[ForceHold(), Centre(), ContactLost(grace_s=0.25)])
    h = LeafHarness(root, dt=DT)
    assert h.tick_for(1.0, features=itertools.repeat(make_features())) == Status.RUNNING
    n = h.tick_until(Status.FAILURE, features=itertools.repeat(make_features(in_contact=False)))
    assert (n - 1) * DT == pytest.approx(0.25)


def test_hybrid_tree_drives_only_its_rows(monkeypatch):
    """The example of docs/trees.md ("Testing a tree"), run from the repository root."""
    from pathlib import Path

    from tactile_bt import load_tree

    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    root = load_tree("trees/hybrid.yaml").root
    touch, hold = root.children
    h = LeafHarness(root)
    h.tick_until(lambda status: touch.status.name == "SUCCESS", features=[make_features(pressure=900)])
    h.tick(frame=contact_frame(cop_px=(10.0, 7.5), force_n=1.0))   # off centre along x, too light
    assert h.twist[0] > 0 and h.twist[2] > 0                        # slide along +x, press along +z
    assert set(np.flatnonzero(h.twist)) <= {0, 1, 2}                # P = diag(1, 1, 1, 0, 0, 0)


def test_align_edge_through_frames_turns_the_right_way():
    """A line contact at 70° with target 90°: Δα > 0, ω_z = −u_α < 0."""
    h = LeafHarness(AlignEdge(target_rad=np.pi / 2), dt=DT)
    h.tick(frame=contact_frame(orientation_rad=np.deg2rad(70.0)))
    assert h.twist[5] < 0
    assert h.errors["orientation_rad"] == pytest.approx(np.deg2rad(-20.0), abs=0.02)
