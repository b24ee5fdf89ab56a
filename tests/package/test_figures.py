"""The README's figures match a fresh run (docs/check_figures.py; its short checks here)."""

from __future__ import annotations

import pytest

from docs_scripts import load_docs_script


def _checker():
    return load_docs_script("check_figures")


@pytest.mark.slow
def test_the_readme_cable_figures_match_a_fresh_run(capsys):
    assert _checker().main([]) == 0, capsys.readouterr().out
    assert "6 README rows compared" in capsys.readouterr().out


def test_a_drifted_number_is_listed_with_its_tolerance():
    check = _checker()
    readme = check.table_rows("| case | time | std |\n|---|---|---|\n| pen | 1.00 s | 0.031 |\n")
    fresh = check.table_rows("| case | time | std |\n|---|---|---|\n| pen | 1.05 s | 0.041 |\n")
    assert check.compare(fresh[0], readme[0]) == ["std: 0.031 -> 0.041 (tolerance 0.0031)"]


def test_words_must_match_and_machine_columns_are_skipped():
    check = _checker()
    readme = check.table_rows("| scene | status | wall (s) |\n|---|---|---|\n| a | success: end | 1.0 |\n")
    fresh = check.table_rows("| scene | status | wall (s) |\n|---|---|---|\n| a | failure: lost | 9.0 |\n")
    assert check.compare(fresh[0], readme[0]) == ["status: 'success: end' -> 'failure: lost'"]
