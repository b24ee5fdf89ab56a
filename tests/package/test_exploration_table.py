"""The README's table of exploration runs (docs/exploration_scenes.py) shortens a reason to what a
reader needs: the counts and lists go, a joint held at its limit and what a scan had left when
its time ran out stay."""

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
