"""Simulated tactile pad (the scene's ``sensor:`` section; 16×16 tactels at 5 mm by default): from
the pad's pose among objects to a frame of raw counts.

Pipeline per frame (all in SI units):

1. penetration of sub-tactel sample points of the pad surface into every object (m);
2. local pressure ``k · depth`` with the object's per-area stiffness in series with the foam
   (Pa), averaged over each tactel (tactel-integrated force, N);
3. spread by the foam: a 3×3 kernel, so a point load shows on neighbouring tactels;
4. per-tactel squashed characteristic (paper Fig. 1) to raw counts, Gaussian noise,
   12-bit quantisation and saturation.

Perception inverts step 4 with the calibration of the same tactels.

Steps 1-4 and the contact wrench a compliant mount feels run as compiled kernels
(:mod:`tactile_bt.sim.kernels`); the random draws stay with the model's numpy ``Generator``, in
the same order (one frame gain, then one draw per tactel), so a seed gives the same frames.

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tactile_bt import defaults
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.sim import kernels

__all__ = ["SensorParams", "SensorModel", "PadContact"]


def _gaussian_band(n: int, sigma: float) -> np.ndarray:
    """``(n, n)`` matrix that convolves a length-n signal with a normalised Gaussian (zero outside)."""
    radius = max(1, int(np.ceil(2.5 * sigma)))
    taps = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    taps /= taps.sum()
    G = np.zeros((n, n))
    for k, w in zip(range(-radius, radius + 1), taps):
        G += w * np.eye(n, k=k)
    return G


@dataclass
class SensorParams:
    """Parameters of the simulated pad (the scene's ``sensor:`` section).

    Attributes
    ----------
    rows, cols : int
        Tactel grid (16 × 16 by default).
    pitch : float
        Tactel pitch (m).
    subsamples : int
        Sample points per tactel along each axis for the tactel-integrated force.
    foam_stiffness : float
        Per-area stiffness of the pad's foam (Pa/m), in series with the object's.
    foam_spread : float
        Standard deviation (in tactels) of the Gaussian with which the foam spreads a load over
        neighbouring tactels; 0 disables the spread.
    calibration_spread : float
        Relative spread of the tactels' characteristics (0 = identical tactels).
    noise_counts : float
        Standard deviation of the noise on every tactel (ADC counts).
    noise_relative : float
        Independent noise per tactel proportional to its signal above its offset (fraction).
    noise_common : float
        Frame-wide gain noise shared by all tactels (fraction of the signal above the offsets),
        the part that does not average out over a contact region. With the defaults a steady
        contact of ~40–60 tactels at 2 kPa shows a pressure standard deviation of about
        0.04 × target before smoothing, the paper's sensor noise level (``tests`` check it).
    """

    rows: int = PadGeometry.rows
    cols: int = PadGeometry.cols
    pitch: float = PadGeometry.pitch
    subsamples: int = 3
    foam_stiffness: float = 2.0e7
    foam_spread: float = 0.7
    calibration_spread: float = 0.15
    noise_counts: float = 5.0
    noise_relative: float = 0.1
    noise_common: float = 0.03

    @property
    def geometry(self) -> PadGeometry:
        """The pad's :class:`~tactile_bt.sense.geometry.PadGeometry` (rows, cols, pitch)."""
        return PadGeometry(self.rows, self.cols, self.pitch)


@dataclass
class SensorModel:
    """Turns the pad pose ``T_gs`` and the scene's objects into raw frames.

    Parameters
    ----------
    params : SensorParams
    rng : numpy.random.Generator
        Source of the tactels' characteristics and the frame noise.
    """

    params: SensorParams = field(default_factory=SensorParams)
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))

    def __post_init__(self) -> None:
        p = self.params
        pad = p.geometry
        #: The pad's geometry: every tactel ↔ metre conversion of the model goes through it.
        self.pad = pad
        if p.calibration_spread > 0:
            self.calibration = TactelCalibration.random(self.rng, spread=p.calibration_spread, pad=pad)
        else:
            self.calibration = TactelCalibration.nominal(pad=pad)
        s = p.subsamples
        # Tactel (r, c) centre at pad.px_to_m([c, r]) (z = 0) in the sensor frame, row-major.
        rr, cc = np.meshgrid(np.arange(pad.rows), np.arange(pad.cols), indexing="ij")
        xy = pad.px_to_m(np.stack((cc.ravel(), rr.ravel()), axis=1))
        self._centres = np.ascontiguousarray(np.column_stack((xy, np.zeros(rr.size))))
        o = ((np.arange(s) + 0.5) / s - 0.5) * pad.pitch
        oy, ox = np.meshgrid(o, o, indexing="ij")
        self._offsets = np.ascontiguousarray(np.stack((ox.ravel(), oy.ravel(), np.zeros(s * s)), axis=1))
        self._corners = np.ascontiguousarray(pad.corners_m(), dtype=float)
        self.tactel_area = pad.tactel_area_m2
        self._spread_rows = self._spread_cols = None
        radius = 0
        if p.foam_spread > 0:
            self._spread_rows = _gaussian_band(pad.rows, p.foam_spread)
            self._spread_cols = _gaussian_band(pad.cols, p.foam_spread)
            radius = max(1, int(np.ceil(2.5 * p.foam_spread)))
        self._spread_radius = radius
        # What the compiled kernels read (types fixed: float64 / int64 C arrays, writable).
        self._padf = kernels.PAD.pack(reach=pad.pitch * np.sqrt(0.5),  # no point of a tactel is farther from its centre
                                      margin=self.BROAD_PHASE_MARGIN, noise=p.noise_counts,
                                      noise_relative=p.noise_relative, adc_max=defaults.ADC_MAX)
        eye = np.eye(1)
        self._Gr = eye if self._spread_rows is None else np.ascontiguousarray(self._spread_rows)
        self._Gc = eye if self._spread_cols is None else np.ascontiguousarray(self._spread_cols)
        n = pad.tactels
        self._force = np.zeros(n)
        self._z = np.zeros(n)
        self._raw = np.zeros(n, dtype=np.uint16)
        self._wK = np.zeros(kernels.CONTACT.size)
        self._T = np.eye(4)
        self._args = None
        self._cal_of = None
        self._cal = np.zeros((3, n))
        self._packed: tuple = ()
        self._objf = np.zeros((1, kernels.OBJ.size))
        self._grids = np.zeros(1)
        self._near = np.zeros((1, n), dtype=np.int64)
        self._nnear = np.zeros(1, dtype=np.int64)
        self._broad = np.zeros(kernels.BROAD.size)
        self._job = np.zeros(kernels.JOB.size)
        self._last = np.zeros(kernels.LAST.size)
        self._last_force = np.zeros(n)

    # ------------------------------------------------------------------------------------
    #: How far (m) the pad may move before the broad phase is redone.
    BROAD_PHASE_MARGIN = 2.0e-3

    def invalidate(self) -> None:
        """Forget the packed objects, the broad phase and the last pose's result (call when
        objects move)."""
        self._packed = ()
        self._forget()

    def _ask(self, forces: bool) -> None:
        """What :func:`~tactile_bt.sim.kernels.pad_contact` computes: the tactel forces, or the
        contact wrench and stiffness."""
        self._job[kernels.J_FORCES] = 1.0 if forces else 0.0
        self._job[kernels.J_CONTACT] = 0.0 if forces else 1.0

    def _forget(self) -> None:
        """Mark the broad phase and the last pose's result as stale."""
        self._broad[kernels.B_VALID] = 0.0
        self._last[kernels.LAST_VALID] = 0.0

    def _prepare(self, T_gs, objects) -> None:
        """The pose and the objects as the kernel reads them (objects repacked when the list
        holds other objects than last time, which also redoes the broad phase)."""
        objects = tuple(objects)
        if objects != self._packed:  # objects compare by identity
            self._objf, self._grids = kernels.pack_objects(objects, self.params.foam_stiffness, self.tactel_area,
                                                           len(self._offsets))
            if not objects:  # a row no pad is near
                kernels.OBJ.pack(self._objf[0], bounds_lo=np.inf, bounds_hi=-np.inf)
            self._near = np.zeros((max(len(objects), 1), self.pad.tactels), dtype=np.int64)
            self._nnear = np.zeros(max(len(objects), 1), dtype=np.int64)
            self._forget()
            self._packed = objects
            self._args = None
        if self.calibration is not self._cal_of:
            cal = self.calibration
            self._cal = np.ascontiguousarray(np.stack([np.broadcast_to(np.asarray(a, float), self.pad.shape).ravel()
                                                       for a in (cal.offset, cal.span, cal.force_scale)]))
            self._cal_of = cal
            self._args = None
        if self._args is None:  # pad_contact's data
            self._args = (self._centres, self._offsets, self._corners, self._padf, self._objf, self._grids, self._near,
                          self._nnear, self._broad, self._force, self._job, self._last, self._last_force)
        if T_gs is not None:
            T = T_gs
            if not (type(T) is np.ndarray and T.dtype == np.float64 and T.shape == (4, 4) and T.flags.c_contiguous):
                T = np.ascontiguousarray(T_gs, dtype=float)
                if T.shape != (4, 4):
                    raise ValueError(f"T_gs must be a 4x4 pose, got shape {T.shape}")
            self._T = T

    def _forces(self) -> float:
        """The tactel forces at ``_T`` (spread by the foam) into ``_force``; returns the deepest
        penetration (m).  The kernels are always called with arguments of the same types (one
        compiled version each)."""
        self._ask(forces=True)
        deepest = kernels.pad_contact(self._T, self._args, self._wK)
        if self._spread_rows is not None:
            kernels.foam_spread(self._force, self._Gr, self._Gc, self._spread_radius, *self.pad.shape)
        return deepest

    def _counts(self, gain: float) -> None:
        """Raw counts of ``_force`` into ``_raw``, with the frame gain and the draws in ``_z``."""
        kernels.raw_counts(self._force, self._cal, self._z, gain, self._padf, self._raw)

    def _draw(self) -> float:
        """The frame's random draws, in the order of the numpy model: the common gain, then one
        standard normal per tactel (into ``_z``)."""
        gain = 1.0 + self.params.noise_common * self.rng.standard_normal()
        self.rng.standard_normal(out=self._z)
        return gain

    def penetration_by_object(self, T_gs: np.ndarray, objects) -> np.ndarray:
        """Deepest indentation (m) of the pad's sample points into each object, for the pad at
        ``T_gs``: the depth :meth:`force_image` integrates, 0 for an object the pad does not
        touch. Every sample of every tactel is tested (no broad phase, no cache): for checks
        such as a scene's start pose, not for the control loop."""
        R, t = T_gs[:3, :3], T_gs[:3, 3]
        points = (self._centres[:, None, :] + self._offsets[None, :, :]).reshape(-1, 3) @ R.T + t
        normal = R[:, 2]
        return np.array([float(np.max(obj.depth(points, normal), initial=0.0)) for obj in objects])

    def force_image(self, T_gs: np.ndarray, objects) -> tuple[np.ndarray, float]:
        """Noise-free tactel forces (N) and the largest penetration (m) for the pad at ``T_gs``.

        A broad phase (kept while the pad moves less than ``BROAD_PHASE_MARGIN``) keeps only
        the tactels that can touch each object; those are integrated over their sub-samples,
        and the foam spreads the result (:meth:`spread`).
        """
        self._prepare(T_gs, objects)
        deepest = self._forces()
        return self._force.reshape(self.pad.shape).copy(), float(deepest)

    def sense(self, T_gs: np.ndarray, objects) -> tuple[np.ndarray, np.ndarray, float]:
        """:meth:`force_image` and :meth:`raw_frame` in one pass: ``(raw, force, deepest)``."""
        self._prepare(T_gs, objects)
        gain = self._draw()
        deepest = self._forces()
        self._counts(gain)
        shape = self.pad.shape
        return self._raw.reshape(shape).copy(), self._force.reshape(shape).copy(), float(deepest)

    def contact(self, T_gs: np.ndarray, objects) -> tuple[np.ndarray, np.ndarray]:
        """Contact wrench on the pad and its stiffness, for a compliant mount.

        Every penetrating sub-sample is a spring of stiffness ``k · A`` along the pad normal
        ``n`` (the Winkler model of :meth:`force_image`, before the foam's sensing spread).

        Returns
        -------
        wrench_g : (6,) array
            ``[f; τ]`` on the pad in the base frame, torque about the base origin (N, N m).
        K_x : (6, 6) array
            ``−d wrench / d ξ`` for a spatial displacement twist ξ of the pad:
            ``Σ k A a aᵀ`` with ``a = [n; p × n]`` over the penetrating samples.
        """
        self._prepare(T_gs, objects)
        self._ask(forces=False)
        kernels.pad_contact(self._T, self._args, self._wK)
        return kernels.CONTACT.view(self._wK, "wrench").copy(), kernels.CONTACT.view(self._wK, "stiffness").copy()

    def contact_kernel(self, objects) -> tuple:
        """The compiled contact with ``objects`` for the compliant arm's step
        (:class:`~tactile_bt.robot.stepping.CompiledContact`): ``(kernel, data)``, where
        ``kernel(T, data, wK)`` writes the wrench and stiffness at the pad pose ``T`` into ``wK``
        (:func:`tactile_bt.sim.kernels.pad_contact`, set to compute those and not the forces)."""
        self._prepare(None, objects)
        self._ask(forces=False)
        return kernels.pad_contact, self._args

    def spread(self, force: np.ndarray) -> np.ndarray:
        """Foam spread: a separable Gaussian of ``foam_spread`` tactels, truncated at 2.5 σ.

        Done as ``G_r · F · G_cᵀ`` with precomputed band matrices; load spread beyond the pad's
        border is lost, as on the real pad.
        """
        if self._spread_rows is None:
            return force
        return self._spread_rows @ force @ self._spread_cols.T

    def raw_frame(self, force: np.ndarray) -> np.ndarray:
        """Raw 12-bit counts (uint16) of a tactel force image, with noise and saturation."""
        f = np.asarray(force, dtype=float)
        if f.shape != self.pad.shape:
            f = np.broadcast_to(f, self.pad.shape)
        self._prepare(None, self._packed)
        self._force[:] = f.ravel()
        gain = self._draw()
        self._counts(gain)
        return self._raw.reshape(self.pad.shape).copy()


class PadContact:
    """The contact of a world's pad with its objects, for a compliant mount.

    Called with a pose it returns ``(wrench_g, K_x)`` (:meth:`SensorModel.contact`), like any
    contact model of :mod:`tactile_bt.robot.equilibrium`; :meth:`contact_kernel` lets
    :class:`~tactile_bt.robot.arm.CompliantArm` take its whole step in compiled kernels
    (:class:`~tactile_bt.robot.stepping.CompiledContact`).

    Parameters
    ----------
    sensor : SensorModel
    world : object with an ``objects`` list (read at every call: scene events replace objects)
    """

    def __init__(self, sensor: SensorModel, world) -> None:
        self.sensor = sensor
        self.world = world

    def __call__(self, T_gs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.sensor.contact(T_gs, self.world.objects)

    def contact_kernel(self) -> tuple:
        """See :meth:`SensorModel.contact_kernel`."""
        return self.sensor.contact_kernel(self.world.objects)
