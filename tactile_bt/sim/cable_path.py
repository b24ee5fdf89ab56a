"""A cable's centreline: planar paths from straight pieces and arcs, and the centreline a scene
gives (its ``points`` or its ``path`` pieces), checked with file and line.

Layer: sim.
"""

from __future__ import annotations

import numpy as np

from tactile_bt.sim.registry import ObjectSource
from tactile_bt.sim.schema import ANGLE_DEG, COORD, LENGTH, ListOf
from tactile_bt.yamlutil import Located, plain

__all__ = ["polyline_from_segments", "centreline_from_scene", "MAX_CABLE_EXTENT_M", "MAX_CABLE_LENGTH_M"]

#: A cable's centreline fits in a square of this side (m); its distance grid covers it at 2 mm.
MAX_CABLE_EXTENT_M = 1.0
#: ... and is at most this long (m).
MAX_CABLE_LENGTH_M = 10.0
#: A cable's path pieces in a scene: ``{straight: length}`` or ``{arc: {radius, angle_deg}}``.
STRAIGHT = LENGTH
ARC = {"radius": LENGTH, "angle_deg": ANGLE_DEG}


def polyline_from_segments(start, heading_deg: float, segments: list[dict], step: float = 0.001) -> np.ndarray:
    """Build a planar path from straight pieces and circular arcs.

    Parameters
    ----------
    start : (2,) start point (m).
    heading_deg : initial direction, degrees from +x towards +y.
    segments : list of ``{"straight": length_m}`` or ``{"arc": {"radius": m, "angle_deg": deg}}``
        (positive angles turn left).
    step : spacing of the returned points (m).

    Returns
    -------
    (N, 2) array of points along the path.
    """
    points = [np.asarray(start, dtype=float)]
    heading = np.deg2rad(heading_deg)
    for seg in segments:
        p = points[-1]
        if "straight" in seg:
            length = float(seg["straight"])
            n = max(1, int(np.ceil(length / step)))
            s = np.linspace(0.0, length, n + 1)[1:]
            d = np.array([np.cos(heading), np.sin(heading)])
            points.extend(p + s[:, None] * d)
        elif "arc" in seg:
            radius = float(seg["arc"]["radius"])
            angle = np.deg2rad(float(seg["arc"]["angle_deg"]))
            n = max(1, int(np.ceil(abs(angle) * radius / step)))
            turn = np.sign(angle)
            centre = p + radius * np.array([np.cos(heading + turn * np.pi / 2), np.sin(heading + turn * np.pi / 2)])
            phi0 = heading - turn * np.pi / 2
            phis = phi0 + np.linspace(0.0, angle, n + 1)[1:]
            points.extend(centre + radius * np.stack((np.cos(phis), np.sin(phis)), axis=1))
            heading += angle
        else:
            raise ValueError(f"a path segment must be 'straight' or 'arc', got {seg!r}")
    return np.array(points)


def centreline_from_scene(fields: dict, source: ObjectSource) -> tuple[np.ndarray, dict]:
    """A cable's centreline ``(N, 2)`` (m) from its scene ``fields``: ``points``, or ``path``
    pieces from ``start`` along ``heading_deg``; at least 1 mm and at most
    :data:`MAX_CABLE_LENGTH_M` long, within a square of side :data:`MAX_CABLE_EXTENT_M`. Returns
    the centreline and the other fields."""
    f, where = dict(fields), source.where
    key = "points" if "points" in f else "path"
    located = source.located(key)
    if "points" in f:
        pts = np.array([source.check(p, ListOf(2, COORD), f"{where}points[{i}]")
                        for i, p in enumerate(f.pop("points"))])
        f.pop("path", None)
        if len(pts) < 2:
            raise located.error(f"{where}points: a cable needs at least 2 points, got {len(pts)}")
    else:
        if "path" not in f:
            raise source.item.error(f"{where}: a cable needs 'path' (segments) or 'points'")
        segments = [_path_segment(seg, f"{where}path[{i}]", source.check) for i, seg in enumerate(f.pop("path"))]
        if not segments:
            raise located.error(f"{where}path: a cable needs at least one piece")
        length = sum(s["straight"] if "straight" in s else abs(np.deg2rad(s["arc"]["angle_deg"])) * s["arc"]["radius"]
                     for s in segments)
        if length > MAX_CABLE_LENGTH_M:
            raise located.error(f"{where}path: the cable is {length:.3g} m long, more than the "
                                f"{MAX_CABLE_LENGTH_M:g} m allowed")
        pts = polyline_from_segments(f.pop("start", (0.0, 0.0)), f.pop("heading_deg", 0.0), segments)
    f.pop("start", None)
    f.pop("heading_deg", None)
    extent = float(np.ptp(pts, axis=0).max())
    if extent > MAX_CABLE_EXTENT_M:
        raise located.error(f"{where}{key}: the cable's centreline spans {extent:.3g} m, more than the "
                            f"{MAX_CABLE_EXTENT_M:g} m allowed")
    if float(np.sum(np.hypot(*np.diff(pts, axis=0).T))) < 1e-3:
        raise located.error(f"{where}{key}: the cable's centreline must be at least 1 mm long")
    return pts, f


def _path_segment(seg: Located, field_name: str, check) -> dict:
    """One piece of a cable path, ``{straight: length}`` or ``{arc: {radius, angle_deg}}``, checked
    (``check`` as :attr:`tactile_bt.sim.registry.ObjectSource.check`)."""
    v = seg.value
    ok = isinstance(v, dict) and len(v) == 1 and (
        "straight" in v
        or ("arc" in v and isinstance(v["arc"].value, dict) and set(v["arc"].value) == set(ARC))
    )
    if not ok:
        raise seg.error(f"{field_name}: expected {{straight: length_m}} or "
                        f"{{arc: {{radius: m, angle_deg: deg}}}}, got {plain(seg)!r}")
    if "straight" in v:
        return {"straight": check(v["straight"], STRAIGHT, f"{field_name}.straight")}
    arc = v["arc"].value
    return {"arc": {k: check(arc[k], kind, f"{field_name}.arc.{k}") for k, kind in ARC.items()}}
