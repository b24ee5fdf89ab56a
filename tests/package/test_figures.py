"""The README's figures match a fresh run (docs/check_figures.py; its short checks here)."""

from __future__ import annotations

import pytest

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _checker():
    spec = importlib.util.spec_from_file_location("check_figures", ROOT / "docs" / "check_figures.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["check_figures"] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


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
