"""Object shapes, one module each (or a few related ones per module): every module here is
imported on the first look-up of :mod:`tactile_bt.sim.registry`, so a new shape is a new module
in this package that registers its class with :func:`~tactile_bt.sim.registry.register_shape`.

Layer: sim.
"""

from tactile_bt.sim.shapes.primitives import Box, Cylinder, Sphere

__all__ = ["Box", "Sphere", "Cylinder"]
