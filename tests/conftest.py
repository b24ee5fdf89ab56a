"""Fixtures shared by the test files."""

from __future__ import annotations

import pytest

from tactile_bt.testing import fresh_blackboard as _fresh_blackboard
from tactile_bt.tree.behaviours import DECORATORS, LEAVES


@pytest.fixture(autouse=True)
def fresh_blackboard():
    """Every test starts from, and leaves, an empty py_trees blackboard (its keys are global)."""
    with _fresh_blackboard():
        yield


@pytest.fixture
def node_registry():
    """Node types registered during the test (``register_node``) are removed after it."""
    from tactile_bt.tree import registry

    leaves, decorators, added = dict(LEAVES), dict(DECORATORS), dict(registry._ADDED_BY)
    yield
    registry._ADDED_BY.clear()
    registry._ADDED_BY.update(added)
    LEAVES.clear()
    LEAVES.update(leaves)
    DECORATORS.clear()
    DECORATORS.update(decorators)
