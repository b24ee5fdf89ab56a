"""Layouts of the packed float64 work arrays the compiled kernels read and write.

A kernel takes few arguments when its state is one flat float64 array; the price is a set of
offsets into it.  A :class:`Layout` declares such an array once, as a list of named fields with
their shapes, and derives every offset and the total size from that list at import time, so no
two fields can share memory and no offset is added by hand.  The kernels' modules publish the
offsets as plain module-level ints (``W_Q = WORK.offset("q")``), which numba reads as
compile-time constants, and the Python side packs and reads the arrays through
:meth:`Layout.pack` and :meth:`Layout.view` instead of slicing them.

Note that numba's disk cache is keyed by the source file of a kernel: declare a kernel's layouts
in the module of the kernel, so that editing a field list recompiles it.

Layer: robot.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Layout"]


class Layout:
    """Named fields of a flat float64 array, laid one after the other in the order declared.

    Parameters
    ----------
    name : str
        What the array is (for messages).
    fields : tuple of (str, int or tuple of int)
        Each field's name and shape (an int: that many numbers; ``()`` or ``1``: one number).

    Examples
    --------
    >>> lay = Layout("state", ("q", 7), ("T", (4, 4)), ("dt", 1))
    >>> lay.offset("T"), lay.size
    (7, 24)
    """

    def __init__(self, name: str, *fields: tuple[str, int | tuple[int, ...]]) -> None:
        self.name = name
        self._offsets: dict[str, int] = {}
        self._shapes: dict[str, tuple[int, ...]] = {}
        offset = 0
        for field, shape in fields:
            if field in self._offsets:
                raise ValueError(f"{name}: field {field!r} declared twice")
            shape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(n) for n in shape)
            if any(n < 1 for n in shape):
                raise ValueError(f"{name}: field {field!r} has an empty shape {shape}")
            self._offsets[field] = offset
            self._shapes[field] = shape
            offset += math.prod(shape)
        #: Numbers in the array.
        self.size = offset

    @property
    def fields(self) -> tuple[str, ...]:
        """The field names, in memory order."""
        return tuple(self._offsets)

    def offset(self, field: str) -> int:
        """Index of the field's first number."""
        try:
            return self._offsets[field]
        except KeyError:
            raise KeyError(f"{self.name} has no field {field!r}; fields: {', '.join(self._offsets)}") from None

    def shape(self, field: str) -> tuple[int, ...]:
        """The field's shape (``(1,)`` for a scalar)."""
        self.offset(field)
        return self._shapes[field]

    def length(self, field: str) -> int:
        """Numbers in the field."""
        return math.prod(self.shape(field))

    def end(self, field: str) -> int:
        """Index one past the field's last number."""
        return self.offset(field) + self.length(field)

    def span(self, array: np.ndarray, first: str, last: str) -> np.ndarray:
        """Flat view of the fields from ``first`` through ``last`` (consecutive in memory)."""
        lo, hi = self.offset(first), self.end(last)
        if hi <= lo:
            raise ValueError(f"{self.name}: {last!r} does not follow {first!r}")
        return self._check(array)[..., lo:hi]

    def view(self, array: np.ndarray, field: str) -> np.ndarray:
        """The field of ``array`` (the layout's last axis) as a view of its shape; a scalar field
        is a view of one number (write ``view(a, f)[0] = x`` or use :meth:`pack`)."""
        lo = self.offset(field)
        shape = self._shapes[field]
        part = self._check(array)[..., lo:lo + math.prod(shape)]
        return part if len(shape) == 1 else part.reshape(part.shape[:-1] + shape)

    def pack(self, out: np.ndarray | None = None, /, **values) -> np.ndarray:
        """Write fields by name into ``out`` (a new zeroed array of :attr:`size` if omitted) and
        return it.  A value with as many numbers as its field fills it in row-major order (a
        flat or a shaped array); a scalar fills it; fields not named are left alone."""
        if out is None:
            out = np.zeros(self.size)
        for field, value in values.items():
            target = self.view(out, field)
            value = np.asarray(value, dtype=float)
            if value.size == target.size:
                target[...] = value.reshape(target.shape)
            elif value.size == 1:
                target[...] = value.ravel()[0]
            else:
                raise ValueError(f"{self.name}: field {field!r} takes {self.length(field)} numbers, got {value.shape}")
        return out

    def unpack(self, array: np.ndarray) -> dict[str, np.ndarray]:
        """Every field of ``array`` as a copy, by name."""
        return {field: self.view(array, field).copy() for field in self._offsets}

    def _check(self, array: np.ndarray) -> np.ndarray:
        if array.shape[-1:] != (self.size,):
            raise ValueError(f"{self.name} takes arrays of {self.size} numbers on the last axis, got {array.shape}")
        return array

    def __repr__(self) -> str:
        body = ", ".join(f"{f}@{o}{self._shapes[f]}" for f, o in self._offsets.items())
        return f"Layout({self.name!r}, size={self.size}: {body})"
