"""A rerun recording of everything the control loop sees, on a ``mission_time`` timeline.

Entities (world frame z up, metres; the pad's frame is O_s of docs/architecture.md):

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
:data:`tactile_bt.defaults.RERUN_RATE_HZ`), status changes at every tick. The features and the
pad's pose are read from the mission's log, the images and overlays kept in small buffers, and
all of them sent as columns every :data:`SEND_EVERY` logged frames and at the end (a tenth of
the cost of one call per entity and frame); contacts and status changes are sent as they come. rerun-sdk (the
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
#: Logged frames whose features and pad poses are sent together (0.5 s of mission time at 50 Hz).
SEND_EVERY = 25


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
        self.stream = self._open()
        self._every = max(1, int(round(1.0 / (loop.dt * self.rate_hz))))
        self._contacts_logged = 0
        self._last_codes = None
        self._log = log
        self._pending: list[int] = []
        shape = loop.pad.shape
        self._images = np.zeros((SEND_EVERY, *shape), np.float32)
        self._masks = np.zeros((SEND_EVERY, *shape), np.uint8)
        self._cop = np.full((SEND_EVERY, 2), np.nan)
        self._angle = np.full(SEND_EVERY, np.nan)
        self._log_static(loop.pad)
        if scene is not None:
            self._log_scene(scene)

    def cycle(self, k: int, t: float, loop, log) -> None:
        nodes = log.nodes
        if nodes is not None and nodes.changed:
            self.stream.set_time("mission_time", duration=t)
            codes = nodes.current
            lines = status_changes(self._last_codes, codes, nodes.names)
            self._last_codes = codes.copy()
            self.stream.log("tree/status", self.rr.TextLog("\n".join(lines), level="INFO"))
        if k % self._every == 0:
            self._keep(k, t, loop)

    def finish(self, result) -> None:
        stream = self.stream
        if stream is None:
            return
        try:
            self._send()
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

    # --- the recording and what never changes ----------------------------------------------

    def _open(self):
        """A recording stream to the file, the viewer or both; mission time its only timeline."""
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
        return stream

    def _log_static(self, pad) -> None:
        """World axes (z up), the image format and overlay styles, the feature series' names
        and the pad's outline."""
        rr, stream = self.rr, self.stream
        stream.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        image = "tactile/force_image"
        stream.log(image, rr.Image.from_fields(format=rr.components.ImageFormat(
            width=pad.cols, height=pad.rows, color_model="L", channel_datatype="F32")), static=True)
        stream.log(f"{image}/region", rr.SegmentationImage.from_fields(format=rr.components.ImageFormat(
            width=pad.cols, height=pad.rows, channel_datatype="U8"), opacity=0.35), static=True)
        stream.log(f"{image}/cop", rr.Points2D.from_fields(radii=0.35, colors=[(255, 40, 40)]), static=True)
        stream.log(f"{image}/orientation", rr.LineStrips2D.from_fields(colors=[(255, 40, 40)]), static=True)
        for name in FEATURES:
            stream.log(f"features/{name}", rr.SeriesLines(names=list(_SERIES), colors=[(40, 110, 200), (120, 120, 120),
                                                                                      (220, 80, 60)]), static=True)
        stream.log("pad/outline", rr.LineStrips3D([_outline(pad)], colors=[(230, 160, 30)]), static=True)

    # --- what one logged cycle holds ---------------------------------------------------------

    def _keep(self, k: int, t: float, loop) -> None:
        """Keep cycle ``k``'s image and overlays for the next send; send the contacts recorded
        since the last logged cycle."""
        i = len(self._pending)
        f = loop.features_raw
        self._images[i] = loop.image
        self._masks[i] = f.mask
        # tactel centres at index + 0.5 in rerun's image coordinates
        self._cop[i] = f.cop_px + 0.5 if f.in_contact else np.nan
        self._angle[i] = loop.features.orientation if f.in_contact else np.nan
        self._pending.append(k)
        self.frames += 1
        if len(self._pending) == SEND_EVERY:
            self._send()
        n = len(loop.contacts)
        if n > self._contacts_logged:
            self.stream.set_time("mission_time", duration=t)
            points = loop.contacts.points[self._contacts_logged:n]
            self.stream.log("contacts", self.rr.Points3D(points, radii=0.0008, colors=[(30, 30, 30)]))
            self._contacts_logged = n

    def _send(self) -> None:
        """Send the pending logged cycles as columns: image, region, COP and axis from the
        buffers, features and pad poses from the mission's log."""
        n = len(self._pending)
        if n == 0:
            return
        rr, stream, log = self.rr, self.stream, self._log
        k = np.array(self._pending)
        self._pending.clear()
        time = [rr.TimeColumn("mission_time", duration=log.scalars["t"][k])]
        image = "tactile/force_image"
        stream.send_columns(image, indexes=time,
                            columns=rr.Image.columns(buffer=self._images[:n].reshape(n, -1).view(np.uint8)))
        stream.send_columns(f"{image}/region", indexes=time,
                            columns=rr.SegmentationImage.columns(buffer=self._masks[:n].reshape(n, -1)))
        cop, angle = self._cop[:n], self._angle[:n]
        touching = np.isfinite(cop[:, 0])  # an empty row: nothing drawn at that time
        stream.send_columns(f"{image}/cop", indexes=time,
                            columns=rr.Points2D.columns(positions=cop[touching]).partition(touching.astype(int)))
        axis = np.isfinite(angle)
        d = 3.0 * np.column_stack((np.cos(angle[axis]), np.sin(angle[axis])))
        strips = np.stack((cop[axis] - d, cop[axis] + d), axis=1)
        stream.send_columns(f"{image}/orientation", indexes=time,
                            columns=rr.LineStrips2D.columns(strips=list(strips)).partition(axis.astype(int)))
        for name in FEATURES:
            value, error = log.scalars[name][k], log.scalars["error_" + name][k]
            rows = np.column_stack((value, value + error, error))
            stream.send_columns(f"features/{name}", indexes=time,
                                columns=rr.Scalars.columns(scalars=rows.ravel()).partition([3] * n))
        stream.send_columns("pad", indexes=time,
                            columns=rr.Transform3D.columns(translation=log.position[k], mat3x3=log.rotation[k]))

    def _log_scene(self, scene) -> None:
        """The scene's objects (simulated truth), static: a cable as its centreline, other
        shapes as triangle meshes; objects without a surface mesh (the table) are left out."""
        rr, stream = self.rr, self.stream
        for i, obj in enumerate(scene.objects):
            line = obj.centreline()
            if line is not None:
                stream.log(f"object/{i}", rr.LineStrips3D([line[0]], radii=line[1], colors=[(74, 120, 181)]),
                           static=True)
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
