"""Object shapes by name: the registry the scene files' ``type:`` reads, and what a shape provides.

A shape is a :class:`~tactile_bt.sim.objects.SimObject` subclass that registers itself under the
name scenes give it (the model is dm_control's suite registry)::

    @register_shape("torus")
    @dataclass(eq=False)
    class Torus(SimObject):
        schema = {"major_radius": LENGTH, "minor_radius": LENGTH}
        required = ("major_radius", "minor_radius")
        example = {"major_radius": 0.06, "minor_radius": 0.02}
        major_radius: float = 0.06
        minor_radius: float = 0.02

        def local_sdf(self, points): ...
        def local_bounds(self): ...
        def surface_mesh(self): ...

What the framework reads of a shape is the :class:`Shape` protocol; :class:`SimObject` gives
defaults for all but the signed distance and the bounds. A new shape is one module: in
``tactile_bt/sim/shapes/`` (every module of that package is imported on the first look-up), in an
installed package that names it in the entry-point group ``tactile_bt.shapes`` (loaded on the
first look-up too), or in any module imported before the scene is loaded.
``tests/sim/test_shape_conformance.py`` checks every registered shape.

Layer: sim.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import pkgutil
from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Mapping, Protocol

import numpy as np

from tactile_bt.yamlutil import Located, YamlError

__all__ = ["Shape", "ObjectSource", "ShapeValueError", "register_shape", "shape_class", "shape_names",
           "registered_shapes", "ENTRY_POINT_GROUP"]

_SHAPES: dict[str, type] = {}
_loaded = False


class Shape(Protocol):
    """What a registered object shape provides (all in its own frame, metres).

    Attributes
    ----------
    type_name : str
        Its scene ``type`` (set by :func:`register_shape`).
    schema : mapping
        Its own scene keys and their kinds (:mod:`tactile_bt.sim.schema`); every object also has
        ``position``, ``rpy_deg``, ``stiffness`` and ``friction``.
    required : tuple of str
        The keys a scene must give.
    example : mapping
        A typical object in scene form (its own keys), placed on nothing in particular: the
        conformance tests build it.
    move_hint : str
        The keys that move the object, for the start check's message.
    """

    type_name: ClassVar[str]
    schema: ClassVar[Mapping[str, Any]]
    required: ClassVar[tuple[str, ...]]
    example: ClassVar[Mapping[str, Any]]
    move_hint: ClassVar[str]

    @classmethod
    def from_scene(cls, fields: dict, source: "ObjectSource") -> "Shape":
        """The object from checked scene fields (its own keys and ``stiffness``, ``friction``,
        ``pose``); a :class:`ShapeValueError` names the field at fault."""

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m, negative inside, 1-Lipschitz) of ``(N, 3)`` points (numpy)."""

    def local_bounds(self) -> np.ndarray:
        """``(2, 3)`` box ``[min, max]`` that contains the shape."""

    def depth(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Indentation (m, >= 0) of world points pressed along the world ``normal``."""

    def kernel_shape(self) -> tuple[int, list, np.ndarray | None]:
        """Its compiled form: ``(shape code of tactile_bt.sim.kernels, parameters, grid or None)``;
        by default a signed-distance grid sampled from ``local_sdf`` (the meshes' path)."""

    def surface_mesh(self):
        """Its closed surface as a ``trimesh.Trimesh`` for the accuracy metrics, or None for an
        object a scan does not explore (a table, a cable)."""

    def view_surface(self, pv, extent: np.ndarray):
        """Its surface for ``tactile-bt view`` (a pyvista mesh), or None; ``extent`` is the
        ``(2, 3)`` world box the view shows (for unbounded objects)."""


@dataclass(frozen=True)
class ObjectSource:
    """Where an object comes from in a scene file: what :meth:`Shape.from_scene` needs to read
    the keys the schema cannot check alone and to report errors with file and line.

    Attributes
    ----------
    item : Located
        The object's mapping in the scene file.
    where : str
        Its path in the scene, ``"objects.<i>."``.
    scene_file : str
        The scene file (relative file names in the object are relative to its directory).
    check : callable
        ``check(located, kind, field_name)``: the value if it is of ``kind``, else a
        :class:`~tactile_bt.errors.SceneError` with file and line.
    """

    item: Located
    where: str
    scene_file: str
    check: Callable[[Located, Any, str], Any]

    def located(self, name: str) -> Located:
        """The object's key ``name`` in the file (the object itself when the key is absent)."""
        value = self.item.value
        return value[name] if isinstance(value, dict) and name in value else self.item

    def error(self, name: str, message: str) -> YamlError:
        """An error at key ``name`` (file and line): ``objects.<i>.<name>: message``."""
        return self.located(name).error(f"{self.where}{name}: {message}")


class ShapeValueError(ValueError):
    """A bad shape parameter; ``field`` is the scene key at fault."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


def register_shape(name: str) -> Callable[[type], type]:
    """Class decorator: register a shape under the scene ``type`` ``name`` (sets ``type_name``)."""

    def register(cls: type) -> type:
        known = _SHAPES.get(name)
        if known is not None and known.__qualname__ != cls.__qualname__:
            raise ValueError(f"object type {name!r} is already registered by {known.__module__}.{known.__qualname__}")
        cls.type_name = name
        _SHAPES[name] = cls
        return cls

    return register


#: Entry-point group through which installed packages add shapes (each entry names a module or
#: an object whose import registers them).
ENTRY_POINT_GROUP = "tactile_bt.shapes"


def _load_builtin() -> None:
    """Import the shapes the package ships (the table and the cable, meshes, every module of
    :mod:`tactile_bt.sim.shapes`) and those installed packages add (:data:`ENTRY_POINT_GROUP`)."""
    global _loaded
    if _loaded:
        return
    _loaded = True
    importlib.import_module("tactile_bt.sim.objects")
    importlib.import_module("tactile_bt.sim.mesh_object")
    package = importlib.import_module("tactile_bt.sim.shapes")
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        importlib.import_module(f"{package.__name__}.{info.name}")
    for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        try:
            entry.load()
        except Exception as exc:  # an installed package's import can fail in any way
            raise ImportError(f"the shape plugin {entry.name!r} ({entry.value}, entry point group "
                              f"{ENTRY_POINT_GROUP}) cannot be loaded: {exc}") from exc


def registered_shapes() -> dict[str, type]:
    """Every registered shape, by scene ``type`` (a copy)."""
    _load_builtin()
    return dict(_SHAPES)


def shape_names() -> list[str]:
    """The scene ``type`` names, sorted."""
    return sorted(registered_shapes())


def shape_class(name: str) -> type:
    """The shape registered as ``name``; KeyError when there is none."""
    return registered_shapes()[name]
