"""Studies: the paper's tables, stability, bench.

Layer 9: built on missions; nothing in the library imports it.
"""
