"""3-D view of a mission with pyvista: the scene's objects (faint), the recorded contacts
coloured by pressure or by time, the surface reconstructed from them (``surface.ply``), the true
cable and the pad's path; in a window or off screen to a PNG.

Only ``tactile-bt view`` and the outputs of a scan mission (``render.png``) import this module,
so other missions never load VTK.

Layer: mission.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

from tactile_bt.errors import CommandLineError
from tactile_bt.mission.report import MissionReport

__all__ = ["render_mission", "has_display", "scale_length_m", "MAX_POINTS_SHOWN"]

#: Largest number of contact points drawn (a scan records tens of thousands).
MAX_POINTS_SHOWN = 6000
#: For a scan, the surface and the contacts are drawn this far (m) outside the object along the
#: measured normals, so that the faint object (on whose surface they lie, the pad pressed a
#: tenth of a millimetre in) does not veil them. Only the picture; the files are untouched.
SURFACE_LIFT_M = 0.001
POINT_LIFT_M = 0.002


def has_display() -> bool:
    """Whether a window can open: always on macOS and Windows; on Linux and other Unixes, when
    an X or Wayland display is set (``DISPLAY``, ``WAYLAND_DISPLAY``)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _lifted(vertices: np.ndarray, contacts: np.ndarray, lift: float) -> np.ndarray:
    """Vertices moved ``lift`` (m) along the measured normal of their nearest contact."""
    from scipy.spatial import cKDTree

    _, idx = cKDTree(contacts[:, :3].astype(float)).query(vertices)
    return vertices + lift * contacts[idx, 3:6].astype(float)


#: Colour and opacity of the scene's objects, by type (others: OBJECT_STYLE).
STYLES = {"table": ("#d8cfc4", 0.5), "cable": ("#4a78b5", 0.35)}
OBJECT_STYLE = ("#4a78b5", 0.3)


def _scene_meshes(scene, pv, extent: np.ndarray):
    """``(name, mesh in the world, colour, opacity)`` of every object that draws a surface."""
    meshes = []
    for obj in scene.objects:
        mesh = obj.view_surface(pv, extent)
        if mesh is None:
            continue
        name = obj.type_name if obj.type_name in STYLES else f"object {len(meshes)}"
        meshes.append((name, mesh.transform(obj.pose, inplace=False), *STYLES.get(obj.type_name, OBJECT_STYLE)))
    return meshes


_METHOD_NAMES = {"delaunay": "Delaunay surface", "surface": "implicit surface", "hull": "convex hull"}


def _scan_title(report: MissionReport) -> str:
    r = report.reconstruction or {}
    if "error" in r:
        return f"\nreconstruction failed: {r['error']}"
    method = _METHOD_NAMES.get(r.get("method"), r.get("method", "?"))
    parts = [f"{report.contacts} contacts; {method}, {r.get('faces', 0)} triangles"]
    if r.get("chamfer_m") is not None:
        parts.append(f"chamfer {r['chamfer_m'] * 1e3:.2f} mm, Hausdorff {r['hausdorff_m'] * 1e3:.1f} mm")
    if r.get("coverage") is not None:
        parts.append(f"coverage {r['coverage']:.3f} of the scan region ({r['coverage_total']:.3f} of the object)")
    return "\n" + "\n".join(parts)


#: Lengths a scale bar may have (m): the longest that is at most a third of the scene.
SCALE_LENGTHS_M = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)


def scale_length_m(span_m: float) -> float:
    """The length of the scale bar for a scene ``span_m`` wide (m): a round length of at most
    a third of it (the shortest one for a tiny scene)."""
    fitting = [length for length in SCALE_LENGTHS_M if length <= span_m / 3.0]
    return fitting[-1] if fitting else SCALE_LENGTHS_M[0]


def _add_scale_bar(plotter, lo: np.ndarray, hi: np.ndarray) -> None:
    """A ruler along world x at the front lower corner of the scene's box ``lo``–``hi`` (m),
    labelled in mm."""
    length = scale_length_m(float(hi[0] - lo[0]))
    start = np.array([lo[0], lo[1], lo[2]], dtype=float)
    plotter.add_ruler(start, start + (length, 0.0, 0.0), title=f"{length * 1e3:g} mm", scale=1e3,
                      number_labels=2, label_format="%.0f", label_color="black", tick_color="black",
                      font_size_factor=0.8)


def render_mission(out_dir: str | Path, png: str | Path | None = None, window_size=(1200, 900),
                   color_by: str | None = None) -> Path | None:
    """Draw the mission in ``out_dir`` (its report.json, log.npz, contacts.ply and, for a scan,
    surface.ply).

    Parameters
    ----------
    out_dir : path
        Output directory of ``tactile-bt run``.
    png : path, optional
        Render off screen into this PNG; without it a window opens (on Linux, a
        :class:`~tactile_bt.errors.CommandLineError` when there is no display to open it on).
    window_size : (int, int)
        Picture size in pixels.
    color_by : {"time", "pressure"}, optional
        Colour of the contact points: mission time (s) or pressure (Pa). Default: time for a
        scan (the report has ``reconstruction``), pressure otherwise.
    """
    out = Path(out_dir)
    report = MissionReport.load(out)
    if png is None and not has_display():
        raise CommandLineError(f"no display to open a window on (DISPLAY is not set): render {out} "
                               f"into a picture with --png FILE, e.g. --png {out / 'render.png'}")
    if png is not None and not os.environ.get("DISPLAY"):
        # Off screen without an X server: go straight to EGL instead of trying X first.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    from tactile_bt.contacts.ply import read_ply_points
    from tactile_bt.sim.scene import load_scene

    scan = report.reconstruction is not None
    if color_by is None:
        color_by = "time" if scan else "pressure"
    if color_by not in ("time", "pressure"):
        raise ValueError(f"color_by must be 'time' or 'pressure', got {color_by!r}")
    scene = load_scene(report.scene)
    log = np.load(out / "log.npz")
    path = log["position_m"]
    points = np.zeros((0, 8))
    if (out / "contacts.ply").exists():
        _, points = read_ply_points(out / "contacts.ply")
    everything = np.vstack([path, points[:, :3]]) if len(points) else path
    for obj in scene.objects:  # include every bounded object (the table is not)
        b = obj.bounds()
        if np.all(np.isfinite(b)):
            everything = np.vstack([everything, b])
    lo, hi = everything.min(axis=0) - 0.05, everything.max(axis=0) + 0.05

    if png is not None:
        pv.OFF_SCREEN = True  # no X server needed
    plotter = pv.Plotter(off_screen=png is not None, window_size=list(window_size))
    plotter.set_background("white")
    for name, mesh, colour, opacity in _scene_meshes(scene, pv, np.array([lo, hi])):
        plotter.add_mesh(mesh, color=colour, opacity=opacity, name=name)
    if len(path) > 1:
        shown = path
        if scan:  # lifted 3 mm along the outward normal, off the surface that would hide it
            shown = path - 0.003 * log["rotation"][:, :, 2]
        plotter.add_mesh(pv.lines_from_points(shown[:: max(1, len(shown) // 2000)]), color="#d62728",
                         line_width=3 if scan else 2, label="pad centre")
        # The pad at its last pose, for scale.
        last = np.eye(4)
        last[:3, :3] = log["rotation"][-1]
        last[:3, 3] = path[-1]
        width, height = scene.sensor.geometry.size_m
        pad = pv.Plane(center=(0, 0, 0), i_size=width, j_size=height).transform(last, inplace=False)
        plotter.add_mesh(pad, color="#607080" if scan else "#f0a020", opacity=0.45, label="pad (end)")
    surface_file = out / "surface.ply"
    if surface_file.exists():
        surface = pv.read(str(surface_file))
        if surface.n_cells:
            if len(points):  # drawn just outside the object, which would otherwise veil it
                surface.points = _lifted(np.asarray(surface.points, float), points, SURFACE_LIFT_M)
            plotter.add_mesh(surface, color="#e8b04a", smooth_shading=True, label="reconstructed surface")
    if len(points):
        # At most MAX_POINTS_SHOWN (every k-th sample) so that the surface shows between them.
        points = points[:: max(1, -(-len(points) // MAX_POINTS_SHOWN))]
        shown = points[:, :3].astype(float)
        if scan:
            shown = shown + POINT_LIFT_M * points[:, 3:6].astype(float)
        cloud = pv.PolyData(shown)
        if color_by == "time":
            name, values = "contact time (s)", points[:, 7]
        else:
            name, values = "pressure (Pa)", points[:, 6]
        fmt = "%.0f" if np.ptp(values) >= 10 else "%.1f"
        cloud[name] = values.astype(float)
        size = 3 if scan else (6 if len(points) < 2000 else 4)
        # No legend entry: a swatch of one colour would not match the colour map; the colour
        # bar, titled "contacts: ...", is their key.
        plotter.add_mesh(cloud, scalars=name, cmap="viridis", point_size=size,
                         render_points_as_spheres=True,
                         scalar_bar_args={"position_x": 0.45, "width": 0.45, "fmt": fmt, "color": "black",
                                          "title": f"contacts: {name}"})
    title = f"{Path(report.tree).stem} on {Path(report.scene).stem}: {report.status}"
    if scan:
        title += _scan_title(report)
    p = report.path_error_m
    if p and p.get("mean") is not None and math.isfinite(p["mean"]):
        title += f"\npath error mean {p['mean'] * 1e3:.2f} mm, max {p['max'] * 1e3:.2f} mm, {report.contacts} contacts"
    _add_scale_bar(plotter, everything.min(axis=0), everything.max(axis=0))
    plotter.add_text(title, font_size=11, color="black")
    plotter.add_legend(bcolor="white", face="rectangle", size=(0.16, 0.12), loc="lower left")
    centre = (everything.min(axis=0) + everything.max(axis=0)) / 2
    span = float(np.max(everything.max(axis=0) - everything.min(axis=0)))
    plotter.camera.focal_point = centre
    plotter.camera.position = centre + np.array([0.0, -0.9, 1.1]) * span
    plotter.camera.up = (0.0, 0.0, 1.0)
    plotter.reset_camera()
    plotter.camera.zoom(1.5 if scan else 1.25)
    if png is None:
        plotter.show()
        return None
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(png))
    plotter.close()
    return png
