"""``python -m tactile_bt.cli``: the ``tactile-bt`` command.

Layer: the entry point (:mod:`tactile_bt.cli`).
"""

from tactile_bt.cli import console

console()
