"""One declaration per node parameter: :class:`Parameter` fields and the :class:`Parameterised` base.

A node class declares each of its parameters once, as a class attribute::

    class CableEnd(TactileBehaviour):
        reach_m = Parameter(0.015, bound=NON_NEGATIVE, doc="The line has ended when ... (m).")

The declaration gives the name (the attribute's), the type (``type=``, else that of the
default), the default (none: required), the unit (``unit=``; by default from the name's
suffix, :data:`~tactile_bt.tree.parameters.UNITS`: ``_m`` m, ``_pa`` Pa, ...; ``unit=None``
declares a plain number), the admissible range (``bound=``; a float without one must be
finite), whether it is fixed at construction (``fixed=True``: no blackboard reference, no
``--param`` at run time through :meth:`Parameterised.set_parameter`) and its meaning (``doc=``).
Everything else reads these declarations: the constructor's checks, the YAML loader,
``--param``, blackboard references, ``tactile-bt tree --params`` and the node reference of
docs/trees.md (:mod:`tactile_bt.tree.reference`).

:class:`Parameterised` collects the declarations of a class and its bases with
``__init_subclass__`` (a subclass redeclares a parameter to change its default, unit, bound or
text: ``kp = ServoLeaf.kp.replace(default=2e-6, unit="(m/s)/Pa")``), checks and converts the
values of a construction (:meth:`~Parameterised.check_parameters`), sets them as attributes
and calls the hook :meth:`~Parameterised.parameters_changed`, which a node overrides to build
the state it derives from its parameters (also after :meth:`~Parameterised.set_parameter`).

Layer: tree.
"""

from __future__ import annotations

import inspect
import re
import typing
from collections.abc import Sequence
from typing import Any, ClassVar

from tactile_bt.errors import ParameterTypeError, ParameterValueError
from tactile_bt.tree.parameters import (FINITE, UNITS, Bound, convert_parameter, describe_type, node_label)

__all__ = ["Parameter", "Parameterised", "REQUIRED", "snake_case", "undeclared_arguments", "is_parameterised"]

#: The default of a required parameter (``inspect.Parameter.empty``, as in signatures).
REQUIRED: Any = inspect.Parameter.empty

_FROM_SUFFIX = object()  # the unit follows from the name's suffix


def _suffix_unit(name: str) -> str | None:
    for suffix, unit in UNITS.items():
        if name.endswith(suffix):
            return unit
    return None


def _inferred_type(default: Any) -> Any:
    if isinstance(default, bool):
        return bool
    if isinstance(default, int):
        return int
    if isinstance(default, float):
        return float
    if isinstance(default, str):
        return str
    if isinstance(default, (tuple, list)):
        return Sequence[float]
    return Any


def snake_case(name: str) -> str:
    """``ForceHold`` → ``force_hold``: the default name of a node of a class."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


class Parameter:
    """The declaration of one parameter of a node class (a class attribute).

    Parameters
    ----------
    default : object, optional
        The value when none is given; leave it out for a required parameter.
    doc : str
        What the parameter means, with its unit and frame (the reference's "meaning").
    bound : Bound, optional
        Admissible numbers (:data:`~tactile_bt.tree.parameters.POSITIVE`, ``between(0, 1)``, ...;
        lists are checked element by element). Floats without one must be finite.
    unit : str or None, optional
        SI unit of the value (``"Pa"``, ``"1/s"``, a list of units for a list); ``None``
        declares a plain number. Default: from the name's suffix (``target_pa`` → Pa).
    type : type, optional
        ``float``, ``int``, ``bool``, ``str``, ``Literal[...]`` or ``Sequence[float]``; default:
        the type of ``default``.
    fixed : bool
        Shapes the node at construction: it cannot follow a blackboard key or change later.
    attribute : str, optional
        The instance attribute holding the value, when it is not the parameter's name (e.g.
        a name a py_trees base class uses for something else).
    """

    def __init__(self, default: Any = REQUIRED, *, doc: str, bound: Bound | None = None, unit: Any = _FROM_SUFFIX,
                 type: Any = None, fixed: bool = False, attribute: str | None = None) -> None:
        self.default = default
        self.doc = " ".join(doc.split())
        self.declared_bound = bound
        self._unit = unit
        self.annotation = _inferred_type(default) if type is None else type
        self.fixed = bool(fixed)
        self._attribute = attribute
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        if self.name and self.name != name:
            raise TypeError(f"{owner.__name__}.{name}: the declaration of {self.name!r} reused under another name; "
                            f"use {self.name}.replace()")
        self.name = name

    def replace(self, **changes: Any) -> Parameter:
        """A copy with some of ``default``, ``doc``, ``bound``, ``unit``, ``type``, ``fixed``
        changed: how a subclass redeclares an inherited parameter."""
        fields = {"default": self.default, "doc": self.doc, "bound": self.declared_bound, "unit": self._unit,
                  "type": self.annotation, "fixed": self.fixed, "attribute": self._attribute}
        unknown = set(changes) - set(fields)
        if unknown:
            raise TypeError(f"Parameter.replace(): no field {', '.join(sorted(unknown))}")
        return Parameter(**{**fields, **changes})

    @property
    def unit(self) -> str | None:
        """SI unit of the value, None for a plain number (declared, else from the suffix)."""
        return _suffix_unit(self.name) if self._unit is _FROM_SUFFIX else self._unit

    @property
    def unit_declared(self) -> bool:
        """Whether the unit is stated: by ``unit=`` (``None`` included) or by the name's suffix."""
        return self._unit is not _FROM_SUFFIX or _suffix_unit(self.name) is not None

    @property
    def bound(self) -> Bound | None:
        """The admissible numbers: the declared bound, else :data:`FINITE` for floats."""
        if self.declared_bound is not None:
            return self.declared_bound
        return FINITE if self.type_name in ("float", "list[float]") else None

    @property
    def attribute(self) -> str:
        """The instance attribute that holds the value."""
        return self._attribute or self.name

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    @property
    def type_name(self) -> str:
        return describe_type(self.annotation)

    def convert(self, value: Any, label: str | None = None, pad=None) -> Any:
        """``value`` checked against the type and bound, in its Python form (see
        :func:`~tactile_bt.tree.parameters.convert_parameter`). Errors name ``label`` (the node)."""
        try:
            return convert_parameter(value, self.annotation, self.unit, self.bound, self.name, pad)
        except ParameterValueError as exc:
            raise ParameterValueError(exc.parameter, exc.detail, exc.index, label) from None
        except ParameterTypeError as exc:
            if typing.get_origin(self.annotation) is typing.Literal:  # a value not among the choices
                raise ParameterValueError(self.name, f"must be one of {exc.expected[len('one of '):]} "
                                                     f"(got {value!r})", node=label) from None
            where = f"{label}: " if label else ""
            raise ParameterTypeError(exc.expected, exc.value,
                                     f"{where}{self.name}: {exc.detail or f'expected {exc.expected}, got {exc.value!r}'}") from None

    def __repr__(self) -> str:
        return (f"Parameter({self.name}: {self.type_name} = {self.default!r}, unit={self.unit!r}, "
                f"bound={str(self.bound) if self.bound else None!r})")


class Parameterised:
    """Base of the node classes: their declared :class:`Parameter` s, checked and set the same
    way whether the values come from Python, YAML, ``--param`` or the blackboard.

    ``parameters`` maps each parameter's name to its declaration, the most derived one: ``name``
    first, then those a class adds to its bases' before theirs (each class's in the order it
    declares them; a redeclared parameter keeps its base's place).
    ``fixed_parameters`` are the names of those declared ``fixed``. The default name of a node
    is ``default_name`` (default: the class name in snake case).
    """

    parameters: ClassVar[dict[str, Parameter]] = {}
    fixed_parameters: ClassVar[frozenset[str]] = frozenset({"name"})
    default_name: ClassVar[str | None] = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        _refuse_second_declarations(cls)
        collected: dict[str, Parameter] = {}
        mro = cls.__mro__
        for i, klass in enumerate(mro):  # the most derived class's new parameters first
            inherited = {attr for base in mro[i + 1:] for attr, v in vars(base).items() if isinstance(v, Parameter)}
            for attr, value in vars(klass).items():
                if isinstance(value, Parameter) and attr not in inherited and attr not in collected:
                    collected[attr] = next(vars(k)[attr] for k in mro if isinstance(vars(k).get(attr), Parameter))
        name = Parameter(cls.__dict__.get("default_name") or snake_case(cls.__name__), type=str, fixed=True,
                         unit=None, doc="Name of the node: shown in the tree display and log records; a leaf files "
                                        "its twist part under it.")
        name.name = "name"
        cls.parameters = {"name": name, **{k: v for k, v in collected.items() if k != "name"}}
        cls.fixed_parameters = frozenset(k for k, p in cls.parameters.items() if p.fixed)
        cls.__signature__ = _signature(cls)  # for help() and IDEs; the values go through __init__

    @classmethod
    def check_parameters(cls, name: str | None, given: dict[str, Any], positional: tuple = ()) -> dict[str, Any]:
        """The values of a construction: ``given`` (keyword arguments) and ``positional`` (the
        values after the name, in the order of ``parameters``) converted and checked against the
        declarations, the others at their defaults; ``"name"`` included.

        Raises
        ------
        TypeError
            For an unknown or a missing required parameter (as Python does for a call).
        ParameterValueError, ParameterTypeError
            For a value out of bounds or of the wrong type, naming the node and the parameter.
        """
        params = cls.parameters
        if positional:
            names = list(params)[1:]
            if len(positional) > len(names):
                raise TypeError(f"{cls.__name__}() takes at most {len(names) + 1} positional parameters")
            twice = [k for k in names[:len(positional)] if k in given]
            if twice:
                raise TypeError(f"{cls.__name__}() got multiple values for parameter {twice[0]!r}")
            given = {**dict(zip(names, positional)), **given}
        node = name if name is not None else params["name"].default
        label = node_label(cls, node)
        unknown = [k for k in given if k not in params or k == "name"]
        if unknown:
            raise TypeError(f"{cls.__name__}() got an unexpected keyword argument {unknown[0]!r}; "
                            f"parameters: {', '.join(params)}")
        missing = [k for k, p in params.items() if p.required and k not in given]
        if missing:
            raise TypeError(f"{cls.__name__}() missing required parameter(s): {', '.join(missing)}")
        values = {"name": params["name"].convert(node, label)}
        for key, p in params.items():
            if key != "name":
                values[key] = p.convert(given[key], label) if key in given else p.default
        return values

    def apply_parameters(self, values: dict[str, Any]) -> None:
        """Set the parameters ``values`` (already checked) and call :meth:`parameters_changed`."""
        params = type(self).parameters
        for key, value in values.items():
            if key != "name":
                setattr(self, params[key].attribute, value)
        self.parameters_changed(frozenset(values))

    def parameters_changed(self, changed: frozenset[str]) -> None:
        """Hook: build the state derived from the parameters named in ``changed``.

        Called at construction with every parameter, and by :meth:`set_parameter` with the one
        it changed, after the new values are set as attributes. Raise ``ValueError`` naming the
        parameter for a value the declaration cannot judge (e.g. a list of the wrong length);
        :meth:`set_parameter` then restores the previous value. The default does nothing.
        """

    def set_parameter(self, name: str, value: Any) -> None:
        """Change parameter ``name`` between runs (``--param`` at run time, blackboard references
        when the node starts): checked against its declaration, set, then
        :meth:`parameters_changed`. Parameters declared ``fixed`` cannot change."""
        params = type(self).parameters
        label = node_label(type(self), getattr(self, "name", None))
        if name not in params:
            raise ValueError(f"{label}: no parameter {name!r}; parameters: {', '.join(params)}")
        p = params[name]
        if p.fixed:
            raise ValueError(f"{label}: {name} is fixed at construction")
        value = p.convert(value, label)
        old = getattr(self, p.attribute)
        setattr(self, p.attribute, value)
        try:
            self.parameters_changed(frozenset({name}))
        except Exception:
            setattr(self, p.attribute, old)
            self.parameters_changed(frozenset({name}))
            raise

    def parameter_values(self) -> dict[str, Any]:
        """Parameter → current value (the attributes, after any derived conversion)."""
        return {k: (self.name if k == "name" else getattr(self, p.attribute))  # type: ignore[attr-defined]
                for k, p in type(self).parameters.items()}


def _refuse_second_declarations(cls: type) -> None:
    """TypeError for a class that declares parameter checks elsewhere than in its
    :class:`Parameter` s: ``parameter_bounds``, ``parameter_units`` or its own ``set_parameter``."""
    legacy = sorted({"parameter_bounds", "parameter_units", "set_parameter"} & set(vars(cls)))
    if legacy:
        raise TypeError(f"{cls.__qualname__}: {', '.join(legacy)}: declare each parameter once, as a class attribute "
                        "Parameter(default, bound=..., unit=..., doc=...), and build derived state in "
                        "parameters_changed() (docs/writing_leaves.md)")


def undeclared_arguments(cls: type) -> list[str]:
    """The named arguments of the ``__init__`` of ``cls`` and its bases besides ``name`` and
    ``child``: values a node type would take without a declaration (none for a node type;
    :func:`~tactile_bt.tree.registry.register_node` refuses a class with some)."""
    out: list[str] = []
    variadic = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    for klass in cls.__mro__:
        init = vars(klass).get("__init__")
        if init is None or not issubclass(klass, Parameterised) or klass is Parameterised:
            continue
        try:
            params = inspect.signature(init).parameters
        except (TypeError, ValueError):
            continue
        out += [f"{klass.__qualname__}.__init__({n})" for n, p in params.items()
                if n not in ("self", "name", "child") and p.kind not in variadic]
    return out


def _signature(cls: type) -> inspect.Signature:
    """``(name=..., p1=..., ...)``, with ``child`` first for a decorator; the parameters after
    a required one without a default are keyword-only."""
    try:
        own = inspect.signature(cls.__init__)
    except (TypeError, ValueError):
        own = None
    params = [inspect.Parameter("child", inspect.Parameter.POSITIONAL_OR_KEYWORD)] \
        if own is not None and "child" in own.parameters else []
    kind = inspect.Parameter.POSITIONAL_OR_KEYWORD
    for k, p in cls.parameters.items():
        if p.required and k != "name":
            kind = inspect.Parameter.KEYWORD_ONLY
        params.append(inspect.Parameter(k, kind, default=p.default, annotation=p.annotation))
    return inspect.Signature(params)


def is_parameterised(cls: Any) -> bool:
    """Whether ``cls`` declares its parameters (a :class:`Parameterised` class)."""
    return isinstance(cls, type) and issubclass(cls, Parameterised)

