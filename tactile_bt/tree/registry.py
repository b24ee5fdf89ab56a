"""The registry of YAML node types: composites, decorators, leaves and ``subtree``.

The composites (``sequence``, ``selector``, ``parallel``) are py_trees' own and their
parameters are listed here (:data:`COMPOSITES`); decorators and leaves are the behaviour classes
registered in :mod:`tactile_bt.tree.behaviours` (``DECORATORS``, ``LEAVES``), to which
:func:`register_node` adds classes of your own.  :mod:`tactile_bt.tree.loader` builds nodes from this
registry (and re-exports its names); :mod:`tactile_bt.tree.reference` documents it.

Layer: tree.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
import re
import sys
from pathlib import Path
from typing import Literal

import py_trees

from tactile_bt.errors import PluginError
from tactile_bt.tree.behaviours import DECORATORS, LEAVES
from tactile_bt.tree.declaration import is_parameterised, undeclared_arguments
from tactile_bt.tree.parameters import ParameterInfo
from tactile_bt.units import format_value

__all__ = ["COMPOSITES", "ENTRY_POINT_GROUP", "NODE_TYPES", "POLICIES", "import_plugin", "load_entry_points",
           "node_types", "register_node", "format_parameter"]

#: The entry-point group through which installed packages add node types (name -> class).
ENTRY_POINT_GROUP = "tactile_bt.behaviours"

#: ``parallel`` policy name -> factory of the py_trees policy (argument: ``synchronise``).
POLICIES = {
    "success_on_all": lambda sync: py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=sync),
    "success_on_one": lambda sync: py_trees.common.ParallelPolicy.SuccessOnOne(),
}
MISSING = inspect.Parameter.empty  # the default of a required parameter


def format_parameter(value) -> str:
    """A parameter's value or default as tree files write it (:func:`tactile_bt.units.format_value`),
    ``required`` for a required parameter (:data:`MISSING`): ``tree --params`` and docs/trees.md."""
    return "required" if value is MISSING else format_value(value)


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


def _origin(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


#: Where each node type added after import came from (for messages about clashes).
_ADDED_BY: dict[str, str] = {}


def register_node(type_name: str, cls: type, decorator: bool | None = None, origin: str | None = None) -> None:
    """Make a behaviour class of your own a YAML node type.

    Its parameters are its :class:`~tactile_bt.tree.declaration.Parameter` declarations
    (``float``, ``int``, ``bool``, ``str``, ``Literal[...]``, ``Sequence[float]``, with
    defaults, units and bounds), exactly as for the built-in leaves; a decorator class
    (:class:`~tactile_bt.tree.behaviours.base.TactileDecorator`) takes its child as the first
    argument ``child``.

    Parameters
    ----------
    type_name : str
        The name trees use for it (an identifier, not yet taken).
    cls : type
        A :class:`py_trees.behaviour.Behaviour` subclass, usually a
        :class:`~tactile_bt.tree.TactileBehaviour`.
    decorator : bool, optional
        Register it as a decorator (it takes one child). Default: whether ``cls`` is a
        :class:`py_trees.decorators.Decorator`.
    origin : str, optional
        Where the registration comes from, for messages (an entry point, a module).

    Raises
    ------
    PluginError
        When ``type_name`` is taken (the message names both classes), not an identifier, or
        ``cls`` is not a behaviour class that declares its parameters.
    """
    here = origin or _origin(cls)
    if not isinstance(type_name, str) or not IDENTIFIER.match(type_name):
        raise PluginError(f"{here}: node type {type_name!r} must be an identifier")
    taken = {**COMPOSITES, **DECORATORS, **LEAVES, "subtree": None}
    if type_name in taken:
        other = taken[type_name]
        if other is cls:
            return  # the same class again (a module imported twice): nothing to do
        owner = _ADDED_BY.get(type_name) or (f"the built-in {_origin(other)}" if isinstance(other, type)
                                              else "a built-in node type")
        raise PluginError(f"node type {type_name!r} of {here} clashes with {type_name!r} of {owner}: "
                          "rename one of them")
    if not (isinstance(cls, type) and issubclass(cls, py_trees.behaviour.Behaviour)):
        raise PluginError(f"{here}: {cls!r} is not a py_trees behaviour class")
    if not is_parameterised(cls):
        raise PluginError(f"{here}: {cls.__name__} declares no parameters: derive it from TactileBehaviour (or "
                          "TactileDecorator) and declare each parameter as a class attribute Parameter(...)")
    undeclared = undeclared_arguments(cls)
    if undeclared:
        raise PluginError(f"{here}: {', '.join(undeclared)} takes a value no Parameter declares: declare each "
                          "parameter as a class attribute Parameter(...) (docs/writing_leaves.md)")
    if decorator is None:
        decorator = issubclass(cls, py_trees.decorators.Decorator)
    (DECORATORS if decorator else LEAVES)[type_name] = cls
    _ADDED_BY[type_name] = here
    cls.node_type = type_name  # the YAML type, for messages


_entry_points_loaded = False


def load_entry_points(force: bool = False) -> list[str]:
    """Register the node types that installed packages declare in the entry-point group
    ``tactile_bt.behaviours`` (``name = "package.module:Class"``), once per process; return
    their names. The loader calls it before it builds the first tree.

    Raises
    ------
    PluginError
        When an entry point cannot be imported, is not a behaviour class, or its name clashes
        with another node type.
    """
    global _entry_points_loaded
    if _entry_points_loaded and not force:
        return []
    _entry_points_loaded = True
    added = []
    for ep in sorted(importlib.metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        dist = getattr(ep, "dist", None)
        where = (f"entry point '{ep.name} = {ep.value}' of {dist.name} {dist.version}" if dist is not None
                 else f"entry point '{ep.name} = {ep.value}'")
        try:
            cls = ep.load()
        except Exception as exc:  # any error of the plugin's own import
            raise PluginError(f"{where}: cannot be loaded: {type(exc).__name__}: {exc}") from exc
        if LEAVES.get(ep.name) is cls or DECORATORS.get(ep.name) is cls:
            continue
        register_node(ep.name, cls, origin=where)
        added.append(ep.name)
    return added


def import_plugin(spec: str) -> str:
    """Import a module that registers node types (``--plugin``): a module name (looked up on the
    import path and in the current folder) or the path of a ``.py`` file.

    Returns the plugin as another process (a Dask worker) imports it: a file as its absolute path,
    a module by its name.

    Raises
    ------
    PluginError
        When the module cannot be found or raises while it is imported.
    """
    as_file = spec.endswith(".py") or "/" in spec or "\\" in spec
    try:
        if as_file:
            path = Path(spec)
            if not path.is_file():
                raise PluginError(f"--plugin {spec}: no such file")
            # Under its own name when that is free, so that an entry point naming the same module
            # later finds it imported (and its classes the same objects).
            name = path.stem if path.stem.isidentifier() and path.stem not in sys.modules else \
                f"tactile_bt_plugin_{path.stem}"
            loaded = sys.modules.get(path.stem)
            if loaded is not None and getattr(loaded, "__file__", None) and Path(loaded.__file__).resolve() == path.resolve():
                return str(path.resolve())
            module_spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[name] = module
            try:
                module_spec.loader.exec_module(module)
            except BaseException:
                del sys.modules[name]
                raise
        else:
            if "" not in sys.path and "." not in sys.path:
                sys.path.append("")  # the current folder, as ``python -m`` has it; after everything else
            importlib.import_module(spec)
    except PluginError:
        raise
    except ModuleNotFoundError as exc:
        raise PluginError(f"--plugin {spec}: no module named {exc.name!r} (give a module on the import path, "
                          "or the path of a .py file)") from exc
    except Exception as exc:
        raise PluginError(f"--plugin {spec}: importing it failed: {type(exc).__name__}: {exc}") from exc
    return str(Path(spec).resolve()) if as_file else spec
