"""Studies: sweeps of missions (``sweep``), the paper's tables, stability, bench, feature accuracy;
``executors`` runs their missions in this process or on a Dask cluster.

Layer 9: built on missions; nothing in the library imports it.
"""
