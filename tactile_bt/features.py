"""The public entry point of perception: ``from tactile_bt.features import extract, ContactFeatures``.

The implementation is :mod:`tactile_bt.perception.features` (layer 2 of the control cycle); this
module is the stable name of the framework's API (docs/architecture.md) and holds no code of its own.
"""

from tactile_bt.perception.features import ContactFeatures, extract

__all__ = ["ContactFeatures", "extract"]
