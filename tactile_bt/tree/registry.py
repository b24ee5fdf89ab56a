"""The registry of YAML node types: composites, decorators, leaves and ``subtree``.

The composites (``sequence``, ``selector``, ``parallel``) are py_trees' own and their
parameters are listed here (:data:`COMPOSITES`); decorators and leaves are the behaviour classes
registered in :mod:`tactile_bt.tree.behaviours` (``DECORATORS``, ``LEAVES``), to which
:func:`register_node` adds classes of your own.  :mod:`tactile_bt.tree.loader` builds nodes from this
registry (and re-exports its names); :mod:`tactile_bt.tree.reference` documents it.

Layer: tree.
"""

from __future__ import annotations

import inspect
import re
from typing import Literal

import py_trees

from tactile_bt.tree.behaviours import DECORATORS, LEAVES
from tactile_bt.tree.parameters import ParameterInfo

__all__ = ["COMPOSITES", "NODE_TYPES", "POLICIES", "node_types", "register_node"]

#: ``parallel`` policy name -> factory of the py_trees policy (argument: ``synchronise``).
POLICIES = {
    "success_on_all": lambda sync: py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=sync),
    "success_on_one": lambda sync: py_trees.common.ParallelPolicy.SuccessOnOne(),
}
MISSING = inspect.Parameter.empty  # the default of a required parameter
_NODES = "list of nodes"  # the "type" of a composite's children

#: Parameters of the composites (py_trees' Sequence, Selector and Parallel).
COMPOSITES: dict[str, list[ParameterInfo]] = {
    "sequence": [
        ParameterInfo("name", str, "sequence", None, "Name of the node."),
        ParameterInfo("memory", bool, True, None,
                      "Resume at the running child on the next tick (true) or start again from the first "
                      "child every tick (false)."),
        ParameterInfo("children", _NODES, MISSING, None, "The children, ticked in order until one does not succeed."),
    ],
    "selector": [
        ParameterInfo("name", str, "selector", None, "Name of the node."),
        ParameterInfo("memory", bool, True, None,
                      "Resume at the running child (true) or re-check higher-priority children every tick (false)."),
        ParameterInfo("children", _NODES, MISSING, None, "The children, tried in order until one does not fail."),
    ],
    "parallel": [
        ParameterInfo("name", str, "parallel", None, "Name of the node."),
        ParameterInfo("policy", Literal["success_on_all", "success_on_one"], "success_on_all", None,
                      "SUCCESS when all children have succeeded, or as soon as one has; FAILURE as soon as "
                      "one fails."),
        ParameterInfo("synchronise", bool, False, None,
                      "With success_on_all: do not tick children that already succeeded."),
        ParameterInfo("children", _NODES, MISSING, None,
                      "The children, all ticked every tick: running servo leaves superimpose their "
                      "projections (paper Eq. 3)."),
    ],
}
IDENTIFIER = re.compile(r"^[A-Za-z_]\w*$")  # node type, subtree and parameter names

#: The built-in node types when the module was imported (:func:`node_types` also lists later
#: registrations).
NODE_TYPES = sorted((*COMPOSITES, *DECORATORS, *LEAVES, "subtree"))


def node_types() -> list[str]:
    """Every built-in node type, including those added with :func:`register_node`."""
    return sorted((*COMPOSITES, *DECORATORS, *LEAVES, "subtree"))


def register_node(type_name: str, cls: type, decorator: bool = False) -> None:
    """Make a behaviour class of your own a YAML node type.

    Its parameters are the keyword arguments of ``cls.__init__`` with type hints (``float``,
    ``int``, ``bool``, ``str``, ``Literal[...]``, ``Sequence[float]``) and defaults, exactly as
    for the built-in leaves; a decorator class takes its child as the first argument ``child``.
    """
    if not IDENTIFIER.match(type_name):
        raise ValueError(f"node type {type_name!r} must be an identifier")
    if type_name in node_types():
        raise ValueError(f"node type {type_name!r} exists already")
    if not (isinstance(cls, type) and issubclass(cls, py_trees.behaviour.Behaviour)):
        raise TypeError(f"{cls!r} is not a py_trees behaviour class")
    (DECORATORS if decorator else LEAVES)[type_name] = cls
    cls.node_type = type_name  # the YAML type, for messages
