"""A rerun recording of everything the control loop sees, on a ``mission_time`` timeline.

Entities (world frame z up, metres; the pad's frame is O_s of DESIGN.md):

* ``tactile/force_image`` — the calibrated force image (N per tactel, rows × columns), with
  ``tactile/force_image/region`` (the contact region R, a segmentation),
  ``tactile/force_image/cop`` (the centre of pressure) and ``tactile/force_image/orientation``
  (the major axis through it), in image coordinates (a tactel's centre at index + 0.5);
* ``features/<name>`` — each feature of the controller (``pressure_pa``, ``cop_x_px``,
  ``cop_y_px``, ``orientation_rad``) as three series: its value, its target and its error
  (target − value; target and error only while a leaf controls it);
* ``pad`` — the pad's pose ``T_gs`` (a transform) and ``pad/outline`` (its edge, pad frame);
* ``contacts`` — the contact points as the tree records them (each batch at its time; the
  viewer's visible time range accumulates them);
* ``object`` — the simulated truth (static) and ``surface`` — the reconstructed surface at the end;
* ``tree/status`` — every change of a node's status, a text log (at the tick it happened).

Images, features and the pad are logged at ``rate_hz`` (default
:data:`tactile_bt.defaults.RERUN_RATE_HZ`), status changes at every tick. rerun-sdk (the
``[viewer]`` extra) is imported by this module only, when a recorder is made.

Layer: mission.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tactile_bt import defaults
from tactile_bt.errors import TactileBtError
from tactile_bt.mission.node_status import status_changes

__all__ = ["RerunRecorder", "FEATURES", "import_rerun"]

#: The features logged under ``features/``: the logged errors of :data:`defaults.METRIC_BANDS`.
FEATURES = tuple(defaults.METRIC_BANDS)
_SERIES = ("value", "target", "error")


def import_rerun():
    """The ``rerun`` module, or a :class:`TactileBtError` saying how to install it."""
    try:
        import rerun
    except ImportError:
        raise TactileBtError("--rerun needs rerun-sdk: pip install 'tactile_bt[viewer]' "
                             "(or pip install rerun-sdk)") from None
    return rerun


class RerunRecorder:
    """Log a mission to rerun: a mission watcher (:mod:`tactile_bt.mission.watch`).

    Parameters
    ----------
    path : path, optional
        Write the recording to this ``.rrd`` file.
    spawn : bool
        Also start a rerun viewer and stream to it (a live look; run ``rerun analytics
        disable`` once first, or the viewer sends usage statistics).
    rate_hz : float
        Rate (Hz of mission time) of the force image, features and pad pose; node status
        changes are logged at every tick.
    application_id : str
        rerun's application id (the viewer groups recordings by it).
    """

    def __init__(self, path: str | Path | None = None, spawn: bool = False,
                 rate_hz: float = defaults.RERUN_RATE_HZ, application_id: str = "tactile_bt") -> None:
        if path is None and not spawn:
            raise ValueError("a rerun recorder needs a file (path) or a viewer (spawn=True)")
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz must be a finite number > 0, got {rate_hz}")
        self.rr = import_rerun()
        self.path = None if path is None else Path(path)
        self.spawn = spawn
        self.rate_hz = float(rate_hz)
        self.application_id = application_id
        self.stream = None
        self.frames = 0  # force images logged
        self._every = 1
        self._contacts_logged = 0
        self._last_codes = None

    # --- the watcher -------------------------------------------------------------------------

    def start(self, loop, log, scene=None) -> None:
        rr = self.rr
        stream = rr.RecordingStream(self.application_id)
        if self.spawn:
            stream.spawn(connect=self.path is None)
            if self.path is not None:
                stream.set_sinks(rr.FileSink(str(self.path)), rr.GrpcSink())
        else:
            stream.save(str(self.path))
        stream.set_log_time_enabled(False)  # mission time only: the same mission, the same timeline
        stream.set_log_tick_enabled(False)
        self.stream = stream
        self._every = max(1, int(round(1.0 / (loop.dt * self.rate_hz))))
        self._contacts_logged = 0
        self._last_codes = None
        stream.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for name in FEATURES:
            stream.log(f"features/{name}", rr.SeriesLines(names=list(_SERIES), colors=[(40, 110, 200), (120, 120, 120),
                                                                                      (220, 80, 60)]), static=True)
        stream.log("pad/outline", rr.LineStrips3D([_outline(loop.pad)], colors=[(230, 160, 30)]), static=True)
        if scene is not None:
            self._log_scene(scene)

    def cycle(self, k: int, t: float, loop, log) -> None:
        nodes = log.nodes
        stream = self.stream
        if nodes is not None and nodes.changed:
            stream.set_time("mission_time", duration=t)
            codes = nodes.current
            lines = status_changes(self._last_codes, codes, nodes.names)
            self._last_codes = codes.copy()
            stream.log("tree/status", self.rr.TextLog("\n".join(lines), level="INFO"))
        if k % self._every:
            return
        if not (nodes is not None and nodes.changed):
            stream.set_time("mission_time", duration=t)
        self._log_cycle(k, loop, log)

    def finish(self, result) -> None:
        stream = self.stream
        if stream is None:
            return
        try:
            surface = getattr(result, "surface", None)
            if surface is not None and len(surface.faces):
                stream.set_time("mission_time", duration=float(result.summary.sim_time_s))
                stream.log("surface", self.rr.Mesh3D(vertex_positions=np.asarray(surface.vertices, np.float32),
                                                     triangle_indices=np.asarray(surface.faces, np.uint32),
                                                     albedo_factor=(90, 180, 110)))
            stream.flush()
        finally:
            if self.path is not None and not self.spawn:
                stream.disconnect()  # closes the file
            self.stream = None

    # --- what one logged cycle holds ---------------------------------------------------------

    def _log_cycle(self, k: int, loop, log) -> None:
        rr, stream = self.rr, self.stream
        f = loop.features_raw
        stream.log("tactile/force_image", rr.Image(np.asarray(loop.image, np.float32)))
        stream.log("tactile/force_image/region", rr.SegmentationImage(f.mask.view(np.uint8), opacity=0.35))
        self.frames += 1
        if f.in_contact:
            cop = f.cop_px + 0.5  # tactel centres at index + 0.5 in rerun's image coordinates
            stream.log("tactile/force_image/cop", rr.Points2D([cop], radii=0.35, colors=[(255, 40, 40)]))
            if math.isfinite(loop.features.orientation):
                a = loop.features.orientation
                d = 3.0 * np.array([math.cos(a), math.sin(a)])
                stream.log("tactile/force_image/orientation", rr.LineStrips2D([[cop - d, cop + d]],
                                                                              colors=[(255, 40, 40)]))
        else:
            stream.log("tactile/force_image/cop", rr.Clear(recursive=False))
            stream.log("tactile/force_image/orientation", rr.Clear(recursive=False))
        scalars = log.scalars
        for name in FEATURES:
            value = scalars[name][k]
            error = scalars["error_" + name][k]
            stream.log(f"features/{name}", rr.Scalars([value, value + error, error]))
        stream.log("pad", rr.Transform3D(translation=log.position[k], mat3x3=log.rotation[k]))
        n = len(loop.contacts)
        if n > self._contacts_logged:
            points = loop.contacts.points[self._contacts_logged:n]
            stream.log("contacts", rr.Points3D(points, radii=0.0008, colors=[(30, 30, 30)]))
            self._contacts_logged = n

    def _log_scene(self, scene) -> None:
        """The scene's objects (simulated truth), static: the cable as its centreline, other
        shapes as triangle meshes; the table is left out."""
        from tactile_bt.sim.objects import Cable, Table

        rr, stream = self.rr, self.stream
        for i, obj in enumerate(scene.objects):
            if isinstance(obj, Table):
                continue
            if isinstance(obj, Cable):
                stream.log(f"object/{i}", rr.LineStrips3D([obj.centreline_world()], radii=obj.radius,
                                                           colors=[(74, 120, 181)]), static=True)
                continue
            mesh = _object_mesh(obj)
            if mesh is not None:
                stream.log(f"object/{i}", rr.Mesh3D(vertex_positions=mesh[0], triangle_indices=mesh[1],
                                                     albedo_factor=(74, 120, 181, 90)), static=True)


def _outline(pad) -> np.ndarray:
    """The pad's edge in its own frame (m): a closed rectangle in z = 0."""
    w, h = pad.cols * pad.pitch / 2, pad.rows * pad.pitch / 2
    return np.array([[-w, -h, 0.0], [w, -h, 0.0], [w, h, 0.0], [-w, h, 0.0], [-w, -h, 0.0]])


def _object_mesh(obj) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices (world, m) and triangles of an object's surface, as the scan's accuracy sees it
    (:func:`tactile_bt.mission.accuracy.true_surface`); None for objects without one."""
    from tactile_bt.mission.accuracy import true_surface

    mesh = true_surface(obj)
    if mesh is None:
        return None
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)
