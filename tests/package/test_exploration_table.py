"""The README's table of exploration runs (docs/exploration_scenes.py) shortens a reason to what a
reader needs: the counts and lists go, a joint held at its limit and what a scan had left when
its time ran out stay."""

import pytest

import tactile_bt
from docs_scripts import load_docs_script

TABLE = load_docs_script("exploration_scenes")


def test_a_failure_s_reason_loses_its_counts_and_lists():
    reason = ("reapproach: no reachable frontier left, but about 18 % of the surface untouched (36.5 cm² in valleys "
              "narrower than the pad; 918 mm explained (404 table, 288 valley)) (298 targets, 100 ends of the surface)")
    assert TABLE._short(reason) == ("reapproach: no reachable frontier left, but about 18 % of the surface untouched "
                                    "(36.5 cm² in valleys narrower than the pad)")


def test_a_time_out_keeps_what_the_scan_had_left():
    reason = ("600 s of mission time ran out while border_sweep was running: sweeping with the border, pass 8 of 9; "
              "the scan so far: about 19 % of the surface untouched (2.1 cm² near the table; 38.2 cm² in valleys "
              "narrower than the pad)")
    assert TABLE._short(reason) == reason  # nothing of it is a count or a list
    plain = "600 s of mission time ran out while frontier_guidance was running: sliding (12 targets, 3 ends)"
    assert TABLE._short(plain) == "600 s of mission time ran out while frontier_guidance was running: sliding"


def test_a_parameter_the_scan_tree_does_not_have_stops_the_table_before_any_mission(capsys):
    with pytest.raises(SystemExit) as stop:
        TABLE.main(["--kind", "scan", "--only", "object", "--param", "frontier_guidance.sped_mps=30 mm/s"])
    assert stop.value.code == 2
    message = capsys.readouterr().err
    assert "sped_mps" in message and "did you mean 'speed_mps'" in message


def test_a_scan_parameter_reaches_the_scan_s_mission(monkeypatch):
    seen = []

    def run_mission(tree, scene, **kwargs):  # stands in for the mission: only what it was given matters
        seen.append(kwargs["params"])
        raise RuntimeError("not run")

    monkeypatch.setattr(tactile_bt, "run_mission", run_mission)
    TABLE.check_params(None, ["frontier_guidance.speed_mps=30 mm/s"])  # fits the tree: no error
    row = TABLE._job(("scan", TABLE.ROOT / "sim" / "object.yaml", 0, None, ("frontier_guidance.speed_mps=30 mm/s",)))
    assert seen == [["frontier_guidance.speed_mps=30 mm/s"]]
    assert row["verdict"] == "**ERROR**"  # a crash is a row of its own
