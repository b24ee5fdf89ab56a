"""Contact clouds as PLY files: binary little-endian, one float property per column, so that
trimesh, pyvista, MeshLab and CloudCompare read them as they are.

Layer: contacts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["write_ply", "read_ply_points"]


def write_ply(path: str | Path, data: np.ndarray, names=("x", "y", "z", "nx", "ny", "nz", "pressure", "t")) -> None:
    """Write an ``(N, k)`` point array as a binary little-endian PLY with float properties."""
    data = np.ascontiguousarray(data, dtype="<f4")
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(data)}"]
    header += [f"property float {n}" for n in names[: data.shape[1]]]
    header.append("end_header")
    with open(path, "wb") as fh:
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        fh.write(data.tobytes())


def read_ply_points(path: str | Path) -> tuple[list[str], np.ndarray]:
    """Read a PLY written by :func:`write_ply`: property names and the ``(N, k)`` array."""
    raw = Path(path).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    lines = raw[:end].decode("ascii").splitlines()
    n = next(int(line.split()[2]) for line in lines if line.startswith("element vertex"))
    names = [line.split()[2] for line in lines if line.startswith("property")]
    return names, np.frombuffer(raw[end:], dtype="<f4", count=n * len(names)).reshape(n, len(names))
