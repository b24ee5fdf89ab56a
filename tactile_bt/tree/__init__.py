"""The behaviour layer: blackboard adapter, leaves, guards, decorators and the YAML loader.

The leaf author's API is public here and stable (``from tactile_bt.tree import ...``):

- :class:`TactileBehaviour`, the base of a leaf that reads the cycle's features
  (``uses``, ``self.features``, ``self.now``, ``self.command.add(name, twist)``), and
  :class:`ServoLeaf`, the base of a PID servo primitive;
- :func:`register_node`, which makes a class a YAML node type (installed packages use the
  entry-point group ``tactile_bt.behaviours`` instead, :data:`ENTRY_POINT_GROUP`);
- :class:`Parameter`, the one declaration of a node parameter (a class attribute: default,
  type, unit, bound, doc), with :class:`Bound`, :func:`between` and the usual bounds
  :data:`POSITIVE`, :data:`NON_NEGATIVE`, :data:`FINITE`, :data:`POSITIVE_OR_INF`; a unit not
  declared follows from the name's suffix (:data:`UNITS`: ``_pa`` Pa, ``_m`` m, ``_s`` s,
  ``_n`` N, ``_mps`` m/s, ``_rad`` rad, ``_rps`` rad/s); :class:`TactileDecorator`, the base
  of a decorator with declared parameters;
- :func:`load_tree`.

docs/writing_leaves.md shows a complete leaf, its tests on :mod:`tactile_bt.testing` and its
packaging as a plugin. The names are imported on first use, so ``import tactile_bt.tree`` stays cheap.

Layer 4 of the control cycle; imports only the layers below it.
"""

from __future__ import annotations

import importlib

__all__ = ["TactileBehaviour", "TactileDecorator", "ServoLeaf", "Parameter", "register_node", "ENTRY_POINT_GROUP",
           "Bound", "between", "POSITIVE", "NON_NEGATIVE", "FINITE", "POSITIVE_OR_INF", "UNITS", "load_tree"]

_WHERE = {
    "TactileBehaviour": "tactile_bt.tree.behaviours.base",
    "TactileDecorator": "tactile_bt.tree.behaviours.base",
    "ServoLeaf": "tactile_bt.tree.behaviours.base",
    "Parameter": "tactile_bt.tree.declaration",
    "between": "tactile_bt.tree.parameters",
    "register_node": "tactile_bt.tree.registry",
    "ENTRY_POINT_GROUP": "tactile_bt.tree.registry",
    "Bound": "tactile_bt.tree.parameters",
    "POSITIVE": "tactile_bt.tree.parameters",
    "NON_NEGATIVE": "tactile_bt.tree.parameters",
    "FINITE": "tactile_bt.tree.parameters",
    "POSITIVE_OR_INF": "tactile_bt.tree.parameters",
    "UNITS": "tactile_bt.tree.parameters",
    "load_tree": "tactile_bt.tree.loader",
}


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'tactile_bt.tree' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
