"""tactile_bt: tactile servoing as composable behaviour trees.

The public entry points are imported lazily so that ``import tactile_bt`` stays cheap and a
mission only loads what it uses (no VTK unless a scene or tree asks for rendering).
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["load_tree", "run_mission", "__version__"]


def __getattr__(name: str):
    if name == "load_tree":
        from tactile_bt.tree.loader import load_tree

        return load_tree
    if name == "run_mission":
        from tactile_bt.mission.run import run_mission

        return run_mission
    raise AttributeError(f"module 'tactile_bt' has no attribute {name!r}")
