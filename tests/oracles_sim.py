"""Oracles of the compiled simulator kernels: the numpy implementations they replaced.

``OracleSensorModel`` is the numpy pad model of ``tactile_bt.sim.pad.SensorModel`` before
``tactile_bt.sim.kernels``; ``python_arm`` makes a compliant arm that takes every step with the
Python solvers (``tactile_bt.robot.equilibrium``, ``tactile_bt.robot.resolved_rate``), the
oracle of ``tactile_bt.robot.kernels``.  ``tests/perception/test_kernels.py`` compares the two.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tactile_bt import defaults
from tactile_bt.control.spatial import skew
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.sim.pad import SensorParams

__all__ = ["OracleSensorModel", "PythonContact", "python_contact"]


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
class OracleSensorModel:
    """The numpy pad model that the compiled kernels replaced (``tactile_bt.sim.pad.SensorModel``
    before them), kept as the oracle: same parameters, same random draws.

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
        self._centres = np.column_stack((xy, np.zeros(rr.size)))
        o = ((np.arange(s) + 0.5) / s - 0.5) * pad.pitch
        oy, ox = np.meshgrid(o, o, indexing="ij")
        self._offsets = np.stack((ox.ravel(), oy.ravel(), np.zeros(s * s)), axis=1)
        #: No point of a tactel is farther than this from its centre (m).
        self._reach = pad.pitch * np.sqrt(0.5)
        self._corners = pad.corners_m()
        self.tactel_area = pad.tactel_area_m2
        self._broad = None
        self._broad_corners = None
        self._broad_objects = None
        self._last_key = None
        self._last_samples: list = []
        self._spread_rows = self._spread_cols = None
        if p.foam_spread > 0:
            self._spread_rows = _gaussian_band(pad.rows, p.foam_spread)
            self._spread_cols = _gaussian_band(pad.cols, p.foam_spread)

    # ------------------------------------------------------------------------------------
    #: How far (m) the pad may move before the broad phase is redone.
    BROAD_PHASE_MARGIN = 2.0e-3

    def invalidate(self) -> None:
        """Forget the cached broad phase and penetration (call when objects move)."""
        self._broad = None
        self._last_key = None

    def _broad_phase(self, T_gs: np.ndarray, corners: np.ndarray, objects) -> list:
        """Per object, the tactels that may touch it while the pad stays within the margin.

        The signed distance is 1-Lipschitz, so a tactel whose centre is farther than its
        half-diagonal plus the margin from an object cannot touch it.
        """
        p = self.params
        R, t = T_gs[:3, :3], T_gs[:3, 3]
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        m = self.BROAD_PHASE_MARGIN
        centres = None
        pairs = []
        for obj in objects:
            b = obj.bounds()
            if np.any(hi + m < b[0]) or np.any(lo - m > b[1]):
                continue
            if centres is None:
                centres = self._centres @ R.T + t
            near = np.flatnonzero(obj.sdf(centres) < self._reach + m)
            if near.size:
                local = (self._centres[near][:, None, :] + self._offsets[None, :, :]).reshape(-1, 3)
                k = 1.0 / (1.0 / p.foam_stiffness + 1.0 / obj.area_stiffness)
                # scale = k · A_sample: the stiffness of one sub-sample spring (N/m); a tactel's
                # force is the sum over its samples of scale · depth
                pairs.append((obj, near, local, k * self.tactel_area / len(self._offsets)))
        return pairs

    def _penetration(self, T_gs: np.ndarray, objects) -> list:
        """Per touching object: (tactel indices, sample points (m, world), depths (m), stiffness
        of one sample spring (N/m)). Cached for the last pose, which a compliant mount's contact
        solve and the next frame usually share."""
        if self._last_key is not None and objects is self._broad_objects and np.array_equal(T_gs, self._last_key):
            return self._last_samples
        R, t = T_gs[:3, :3], T_gs[:3, 3]
        corners = self._corners @ R.T + t
        if (self._broad is None or objects is not self._broad_objects
                or abs(corners - self._broad_corners).max() > self.BROAD_PHASE_MARGIN / 2):
            self._broad = self._broad_phase(T_gs, corners, objects)
            self._broad_corners = corners
            self._broad_objects = objects
        samples = []
        normal = R[:, 2]  # the pad presses along +z of the sensor frame
        for obj, near, local, scale in self._broad:
            points = local @ R.T + t
            depth = obj.depth(points, normal)
            if depth.max() > 0.0:
                samples.append((near, points, depth, scale))
        self._last_key = T_gs.copy()
        self._last_samples = samples
        return samples

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

        A broad phase (cached while the pad moves less than ``BROAD_PHASE_MARGIN``) keeps only
        the tactels that can touch each object; those are integrated over their sub-samples.
        """
        shape = self.pad.shape
        samples = self._penetration(T_gs, objects)
        if not samples:
            return np.zeros(shape), 0.0
        force = np.zeros(self.pad.tactels)
        deepest = 0.0
        for near, _, depth, scale in samples:
            deepest = max(deepest, float(depth.max()))
            tactel = depth.reshape(near.size, -1).sum(axis=1) * scale
            force[near] = np.maximum(force[near], tactel)
        return self.spread(force.reshape(shape)), deepest

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
        n = T_gs[:3, 2]
        N = skew(n)
        wrench = np.zeros(6)
        K = np.zeros((6, 6))
        for _, points, depth, k in self._penetration(T_gs, objects):
            touching = depth > 0.0
            p, d = points[touching], depth[touching]
            # Σ over the springs, with a = [n; p × n] = [n; −N p] (N = [n]×):
            #   wrench = −k Σ d a,   K_x = k Σ a aᵀ,
            # written with the sums Σd, Σd·p, Σp and Σp·pᵀ.
            wrench -= k * np.concatenate((d.sum() * n, -N @ (d @ p)))
            pxn = -N @ p.sum(axis=0)
            K[:3, :3] += (k * len(d)) * np.outer(n, n)
            K[:3, 3:] += k * np.outer(n, pxn)
            K[3:, :3] += k * np.outer(pxn, n)
            K[3:, 3:] += k * (N @ (p.T @ p) @ N.T)
        return wrench, K

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
        p = self.params
        offset = self.calibration.offset
        signal = self.calibration.raw_from_force(force) - offset
        gain = 1.0 + p.noise_common * self.rng.standard_normal()
        sigma = p.noise_counts + p.noise_relative * signal
        noisy = offset + gain * signal + sigma * self.rng.standard_normal(signal.shape)
        np.rint(noisy, out=noisy)
        np.maximum(noisy, 0.0, out=noisy)
        np.minimum(noisy, defaults.ADC_MAX, out=noisy)
        return noisy.astype(np.uint16)


class PythonContact:
    """A contact model the compliant arm sees as a plain callable (no ``contact_kernel``): every step
    of an arm with it goes through the Python solvers."""

    def __init__(self, fn) -> None:
        self.fn = fn

    def __call__(self, T_gs):
        return self.fn(T_gs)


def python_contact(world) -> PythonContact:
    """The pad contact of ``world``, for the Python solvers (the oracle of the compiled step)."""
    return PythonContact(lambda T: world.sensor.contact(T, world.objects))
