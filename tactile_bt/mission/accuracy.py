"""How good is a scanned shape: distances between a reconstructed surface, the contact cloud and
the scene's true object, inside the region the scan set out to cover.

Both surfaces are sampled evenly (:func:`sample_surface`: a lattice of about one sample per
``spacing²`` in every triangle, each weighted by the area it stands for), so every mean below
is an area-weighted mean over the surface, not over however the vertices happen to fall. Distances
come from scipy's ``cKDTree``: the nearest sample, refined to the distance to that sample's
tangent plane when the query's foot lies within one sample spacing of it (exact on flat parts,
and within micrometres on the curved surfaces here); beyond a surface's border (the foot farther
than that) the straight distance to the nearest sample is used.

Definitions (all distances in m; T = the true surface, T_r = its part inside the scan region,
S = the reconstructed surface, S_r = the part of S whose nearest true point lies in the region,
C = the contact cloud):

=====================  ===================================================================
``accuracy_m``         mean distance from S_r to T
``completeness_m``     mean distance from T_r to S
``chamfer_m``          (accuracy + completeness) / 2
``hausdorff_m``        max of the largest distance S_r → T and the largest T_r → S
``fscore_1mm``, …      2PR/(P+R) with P the share of S_r within 1 mm (2 mm) of T and R the
                       share of T_r within 1 mm (2 mm) of S
``coverage``           share of T_r within 2 mm of a point of C
``coverage_total``     the same over the whole object T
=====================  ===================================================================

The scan region (``scan_region``, from the scene or :func:`tactile_bt.run_mission`) is described
in :mod:`tactile_bt.sim.region`; no region (or an empty mapping) is the whole object.

Layer: mission.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from tactile_bt import defaults
from tactile_bt.sim.region import check_region

__all__ = ["true_surface", "scan_object", "sample_surface", "region_mask", "surface_distance", "covered_by",
           "scene_region", "reconstruction_metrics", "scan_settings", "contact_continuity", "evaluate_scan",
           "SAMPLE_SPACING_M", "COVERAGE_RADIUS_M"]

#: Spacing (m) of the surface samples the metrics are computed on.
SAMPLE_SPACING_M = 0.0008
#: A true point counts as covered within this distance (m) of a contact.
COVERAGE_RADIUS_M = defaults.COVERAGE_RADIUS_M
#: Thresholds (m) of the F-scores.
FSCORE_THRESHOLDS_M = (0.001, 0.002)


def true_surface(obj):
    """The surface of a scene object as a ``trimesh.Trimesh`` in the world frame (m): the shape's
    ``surface_mesh()`` placed at its pose; None for objects a scan does not explore (table,
    cable)."""
    mesh = obj.surface_mesh()
    if mesh is None:
        return None
    mesh.apply_transform(obj.pose)
    return mesh


def scan_object(scene, region: dict | None = None):
    """``(index, object)`` of the scanned object: ``region['object']`` or the first object with
    a true surface; ``(None, None)`` when the scene has none."""
    index = (region or {}).get("object")
    if index is not None:
        index = int(index)
        if not 0 <= index < len(scene.objects):
            raise ValueError(f"scan_region.object: no object {index} in the scene")
        return index, scene.objects[index]
    for i, obj in enumerate(scene.objects):
        if obj.surface_mesh() is not None:
            return i, obj
    return None, None


def _lattice(n1: int, n2: int) -> np.ndarray:
    """Parameters ``(a, b)`` of the lattice points ``((i + 1/3)/n1, (j + 1/3)/n2)`` with
    ``a + b <= 1``: sample positions ``v0 + a e1 + b e2`` in a triangle."""
    a, b = np.meshgrid((np.arange(n1) + 1 / 3) / n1, (np.arange(n2) + 1 / 3) / n2, indexing="ij")
    inside = a + b <= 1.0 + 1e-12
    return np.column_stack((a[inside], b[inside]))


def sample_surface(mesh, spacing_m: float = SAMPLE_SPACING_M) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Even samples of a triangle mesh, about one per ``spacing_m²`` of area.

    Each triangle gets a lattice along its two shorter edges, ``ceil(edge / spacing_m)`` steps
    on each, and keeps the lattice points inside; long thin triangles (a cylinder's sides) get
    no more samples than their area needs.

    Returns
    -------
    points : (N, 3) array
        Sample positions (m, the mesh's frame).
    normals : (N, 3) array
        The face normals at the samples.
    weights : (N,) array
        Area (m²) each sample stands for; they sum to the mesh's area.
    """
    tri = np.asarray(mesh.triangles, dtype=float)
    if len(tri) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    normals = np.asarray(mesh.face_normals, dtype=float)
    area = np.asarray(mesh.area_faces, dtype=float)
    # Start at the vertex opposite the longest edge: e1, e2 are the two shorter edges.
    edge_len = np.linalg.norm(np.roll(tri, -1, axis=1) - np.roll(tri, 1, axis=1), axis=2)  # opposite vertex i
    first = edge_len.argmax(axis=1)
    rows = np.arange(len(tri))
    v0 = tri[rows, first]
    e1 = tri[rows, (first + 1) % 3] - v0
    e2 = tri[rows, (first + 2) % 3] - v0
    n1 = np.maximum(1, np.ceil(np.linalg.norm(e1, axis=1) / spacing_m).astype(np.int64))
    n2 = np.maximum(1, np.ceil(np.linalg.norm(e2, axis=1) / spacing_m).astype(np.int64))
    out_p, out_n, out_w = [], [], []
    pairs, inverse = np.unique(np.column_stack((n1, n2)), axis=0, return_inverse=True)
    for g, (k1, k2) in enumerate(pairs):
        sel = np.flatnonzero(inverse.ravel() == g)
        ab = _lattice(int(k1), int(k2))
        pts = v0[sel, None] + ab[None, :, 0, None] * e1[sel, None] + ab[None, :, 1, None] * e2[sel, None]
        out_p.append(pts.reshape(-1, 3))
        out_n.append(np.repeat(normals[sel], len(ab), axis=0))
        out_w.append(np.repeat(area[sel] / len(ab), len(ab)))
    return np.vstack(out_p), np.vstack(out_n), np.concatenate(out_w)


def region_mask(points: np.ndarray, normals: np.ndarray, region: dict | None) -> np.ndarray:
    """Which surface samples (world points and outward normals) lie in the scan region."""
    region = check_region(region)
    mask = np.ones(len(points), dtype=bool)
    if "normal" in region or "max_angle_deg" in region:
        n = np.asarray(region.get("normal", (0.0, 0.0, 1.0)), dtype=float)
        limit = np.cos(np.radians(float(region.get("max_angle_deg", 90.0))))
        mask &= normals @ n >= limit - 1e-9
    if "box" in region:
        lo, hi = np.asarray(region["box"], dtype=float)
        mask &= np.all((points >= lo - 1e-12) & (points <= hi + 1e-12), axis=1)
    return mask


def surface_distance(query: np.ndarray, samples: np.ndarray, normals: np.ndarray,
                     spacing_m: float = SAMPLE_SPACING_M, tree: cKDTree | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distance (m) of each query point to a sampled surface, and the nearest sample's index.

    The distance to the nearest sample's tangent plane where the query's foot on that plane is
    within ``1.2 × spacing_m`` of the sample, the straight distance otherwise.
    """
    if len(samples) == 0:
        return np.full(len(query), np.inf), np.full(len(query), -1)
    tree = cKDTree(samples) if tree is None else tree
    d, idx = tree.query(query)
    diff = query - samples[idx]
    along = np.einsum("ij,ij->i", diff, normals[idx])
    lateral = np.sqrt(np.maximum(d * d - along * along, 0.0))
    return np.where(lateral <= 1.2 * spacing_m, np.abs(along), d), idx


def _wmean(values: np.ndarray, weights: np.ndarray) -> float | None:
    total = weights.sum()
    return float(np.sum(values * weights) / total) if total > 0 else None


def covered_by(points: np.ndarray, contacts: np.ndarray) -> np.ndarray:
    """Which of the surface samples ``points`` ``(n, 3)`` (m) lie within
    :data:`COVERAGE_RADIUS_M` of one of the ``contacts`` ``(k, >=3)`` (m, world): the
    ``coverage`` of :func:`reconstruction_metrics`."""
    c = np.asarray(contacts, dtype=float)[:, :3]
    d, _ = cKDTree(c).query(points, distance_upper_bound=COVERAGE_RADIUS_M * 1.01)
    return d <= COVERAGE_RADIUS_M


def scene_region(scene) -> dict:
    """The scan region a scene sets (its ``scan_region``, checked; ``{}``: the whole object)."""
    return check_region((getattr(scene, "data", None) or {}).get("scan_region"))


def reconstruction_metrics(true_mesh, surface_mesh=None, contacts: np.ndarray | None = None,
                           region: dict | None = None, spacing_m: float = SAMPLE_SPACING_M) -> dict:
    """The scan figures of the module docstring.

    Parameters
    ----------
    true_mesh : trimesh.Trimesh
        The scanned object's surface (world frame, m).
    surface_mesh : trimesh.Trimesh, optional
        The reconstruction; without it only the coverage figures are computed.
    contacts : (N, 3) array, optional
        Contact points (m, world).
    region : dict, optional
        The scan region (``object`` is ignored here).
    spacing_m : float
        Sample spacing of both surfaces (m).

    Returns
    -------
    dict
        ``accuracy_m``, ``completeness_m``, ``chamfer_m``, ``hausdorff_m``, ``fscore_1mm``,
        ``fscore_2mm`` (None without a surface), ``coverage``, ``coverage_total`` (None without
        contacts) and ``region_area_m2``, ``object_area_m2``.
    """
    t_pts, t_nrm, t_w = sample_surface(true_mesh, spacing_m)
    in_region = region_mask(t_pts, t_nrm, region)
    out: dict = {"region_area_m2": float(t_w[in_region].sum()), "object_area_m2": float(t_w.sum())}
    if not in_region.any():
        raise ValueError("the scan region contains none of the object's surface")
    t_tree = cKDTree(t_pts)
    keys = ("accuracy_m", "completeness_m", "chamfer_m", "hausdorff_m") + tuple(
        f"fscore_{round(t * 1e3)}mm" for t in FSCORE_THRESHOLDS_M)
    out.update(dict.fromkeys(keys))
    if surface_mesh is not None and len(surface_mesh.faces):
        s_pts, s_nrm, s_w = sample_surface(surface_mesh, spacing_m)
        d_st, nearest = surface_distance(s_pts, t_pts, t_nrm, spacing_m, t_tree)
        s_in = in_region[nearest]
        d_ts, _ = surface_distance(t_pts[in_region], s_pts, s_nrm, spacing_m)
        tw = t_w[in_region]
        accuracy = _wmean(d_st[s_in], s_w[s_in])
        completeness = _wmean(d_ts, tw)
        out["accuracy_m"], out["completeness_m"] = accuracy, completeness
        if accuracy is not None:
            out["chamfer_m"] = 0.5 * (accuracy + completeness)
            out["hausdorff_m"] = float(max(d_st[s_in].max(), d_ts.max()))
        else:
            out["hausdorff_m"] = float(d_ts.max())
        for tau in FSCORE_THRESHOLDS_M:
            precision = _wmean((d_st[s_in] <= tau).astype(float), s_w[s_in]) or 0.0
            recall = _wmean((d_ts <= tau).astype(float), tw) or 0.0
            f = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
            out[f"fscore_{round(tau * 1e3)}mm"] = float(f)
    out["coverage"] = out["coverage_total"] = None
    if contacts is not None and len(contacts):
        covered = covered_by(t_pts, contacts).astype(float)
        out["coverage"] = _wmean(covered[in_region], t_w[in_region])
        out["coverage_total"] = _wmean(covered, t_w)
    return out


def scan_settings(method: str, scene, scan_region: dict | None = None) -> dict:
    """Check a scan's reconstruction method and region before the mission runs.

    The region is ``scan_region``, else the scene's top-level ``scan_region`` (when the scene
    schema has it), else the whole object.

    Returns
    -------
    dict
        ``{"method": method, "region": checked region}``.
    """
    from tactile_bt.contacts.reconstruct import METHODS

    if method not in METHODS:
        raise ValueError(f"reconstruct: unknown method {method!r}; valid: none, {', '.join(METHODS)}")
    return {"method": method, "region": check_region(scan_region) if scan_region is not None else scene_region(scene)}


def contact_continuity(t: np.ndarray, in_contact: np.ndarray) -> dict:
    """How steadily a mission kept contact after it first touched.

    Returns
    -------
    dict
        ``first_contact_s`` (mission time of the first contact, s), ``contact_share`` (share of
        the cycles from then on that were in contact) and ``longest_gap_s`` (the longest run of
        cycles without contact after the first contact, s); None values without contact.
    """
    t = np.asarray(t, dtype=float)
    touching = np.asarray(in_contact, dtype=float) > 0.5
    if not touching.any():
        return {"first_contact_s": None, "contact_share": None, "longest_gap_s": None}
    first = int(np.argmax(touching))
    after = touching[first:]
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    gaps, run = [], 0
    for value in after:
        if value:
            if run:
                gaps.append(run)
            run = 0
        else:
            run += 1
    if run:
        gaps.append(run)
    return {"first_contact_s": float(t[first]), "contact_share": float(after.mean()),
            "longest_gap_s": float(max(gaps, default=0) * dt)}


def evaluate_scan(scene, contact_data: np.ndarray, method: str = "auto", region: dict | None = None,
                  voxel_m: float = 0.0) -> tuple[object, dict]:
    """Reconstruct a mission's contact cloud and, when the scene knows the object, measure it.

    Parameters
    ----------
    scene : tactile_bt.sim.scene.Scene
    contact_data : (N, 8) array
        The contact cloud (columns of :class:`~tactile_bt.contacts.cloud.ContactCloud`).
    method : str
        Reconstruction method (:data:`tactile_bt.contacts.reconstruct.METHODS`).
    region : dict, optional
        The scan region (module docstring); None is the whole object.
    voxel_m : float
        Thin the cloud to one point per voxel (m) before reconstructing.

    Returns
    -------
    mesh : trimesh.Trimesh
        The reconstructed surface (world frame, m).
    report : dict
        The reconstruction's summary (method, time, faces, watertight, ...) and, with a true
        object, ``object``, ``region`` and the figures of :func:`reconstruction_metrics`.
    """
    from tactile_bt.contacts.reconstruct import reconstruct

    region = check_region(region)
    data = np.asarray(contact_data, dtype=float)
    rec = reconstruct(data[:, :3], data[:, 3:6], method=method, voxel_m=voxel_m)
    report = rec.summary()
    index, obj = scan_object(scene, region)
    truth = true_surface(obj) if obj is not None else None
    if truth is not None:
        report["object"] = index
        report["region"] = {k: v for k, v in region.items() if k != "object"} or "whole object"
        report.update(reconstruction_metrics(truth, rec.mesh, data[:, :3], region))
    return rec.mesh, report
