"""The scan region of a scene (``scan_region``): the part of an object a surface scan sets out to
cover, for the accuracy figures of :mod:`tactile_bt.mission.accuracy`.

=================  ===========================================================================
key                meaning
=================  ===========================================================================
``object``         index of the scanned object in the scene's ``objects`` (default: the first
                   box, sphere, cylinder or mesh)
``normal``         world direction [x, y, z]: keep the surface whose outward normal lies within
``max_angle_deg``  of it (default 90°), e.g. ``normal: [0, 0, 1], max_angle_deg: 10`` is a box's
                   top face
``box``            ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` (m, world): keep the surface
                   inside this box
=================  ===========================================================================

No region (or an empty mapping) is the whole object. Layer: sim (the scene's schema).
"""

from __future__ import annotations

import numpy as np

__all__ = ["REGION_KEYS", "check_region", "describe_region"]

#: The keys of a scan region.
REGION_KEYS = frozenset({"object", "normal", "max_angle_deg", "box"})


def check_region(region) -> dict:
    """Validate a ``scan_region`` mapping (see the module docstring); returns a plain dict."""
    if region is None:
        return {}
    if not isinstance(region, dict):
        raise ValueError(f"scan_region must be a mapping, got {region!r}")
    unknown = set(region) - REGION_KEYS
    if unknown:
        raise ValueError(f"scan_region: unknown key(s) {', '.join(sorted(unknown))}; valid: "
                         f"{', '.join(sorted(REGION_KEYS))}")
    out = dict(region)
    if "normal" in out:
        n = np.asarray(out["normal"], dtype=float)
        if n.shape != (3,) or not np.linalg.norm(n) > 0:
            raise ValueError(f"scan_region.normal must be a non-zero [x, y, z], got {region['normal']!r}")
        out["normal"] = (n / np.linalg.norm(n)).tolist()
    if "max_angle_deg" in out and not 0 < float(out["max_angle_deg"]) <= 180:
        raise ValueError(f"scan_region.max_angle_deg must be in (0, 180], got {out['max_angle_deg']!r}")
    if "box" in out:
        b = np.asarray(out["box"], dtype=float)
        if b.shape != (2, 3) or np.any(b[0] > b[1]):
            raise ValueError(f"scan_region.box must be [[xmin, ymin, zmin], [xmax, ymax, zmax]], got {region['box']!r}")
        out["box"] = b.tolist()
    return out


def _vector(v) -> str:
    return "[" + ", ".join(f"{float(x):.3g}" for x in v) + "]"


def describe_region(region) -> str:
    """A scan region in words, for summaries: ``"the scan region (normals within 10° of [0, 0, 1])"``,
    ``"the whole object"`` for no region (``None``, an empty mapping or the text ``"whole object"``
    that report.json stores for it)."""
    if region is None or isinstance(region, str):
        return "the whole object" if not region or region == "whole object" else str(region)
    region = check_region(region)
    parts = []
    if "normal" in region or "max_angle_deg" in region:
        parts.append(f"normals within {float(region.get('max_angle_deg', 90.0)):g}° of "
                     f"{_vector(region.get('normal', (0.0, 0.0, 1.0)))}")
    if "box" in region:
        lo, hi = region["box"]
        parts.append(f"inside the box {_vector(lo)}–{_vector(hi)} m")
    return f"the scan region ({', '.join(parts)})" if parts else "the whole object"
