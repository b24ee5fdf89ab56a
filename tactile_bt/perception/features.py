"""Contact features of a tactile force image (paper Sec. III, Eq. 1-2).

The force image is a ``(rows, cols)`` array in newtons per tactel.  The sensor frame has x along
increasing column index and y along increasing row index; tactel centres sit at integer
``[column, row]`` coordinates, so the pad centre of a 16x16 array is at ``(7.5, 7.5)``.

Pipeline of :func:`extract`:

1. Tactels that are NaN, infinite or negative are replaced by 0 and counted.
2. Binarise ``image > threshold`` (strictly greater) and label connected components with
   8-connectivity; keep the largest region ``R`` by tactel count (ties: larger force, then the
   region whose first tactel comes first in row-major order) — the paper's rule — or, with
   ``near_px``, the region that comes nearest that point (the followed line where it was last
   seen, so that another line beside it is not taken for it; ties: the larger region). With
   ``near_px`` the pressure is the pad's load: the force of every region over their tactels
   (what a force hold must bound when another strand carries part of it; the region's own with
   one region), and with ``window_px`` the centre of pressure and orientation are those of the
   region's part within a window along the line (a bend ahead leaves them alone).
3. Force ``f = sum f_ij`` and the force-weighted centre of pressure over ``R`` (Eq. 1),
   pressure ``p = f / (|R| pitch^2)`` in Pa (Eq. 2), with the pitch of the pad
   (:class:`~tactile_bt.sense.geometry.PadGeometry`) the image comes from.
4. Orientation of the major axis of ``R`` (optional): force-weighted image moments
   (``alpha = 0.5 atan2(2 mu11, mu20 - mu02)`` in (column, row) coordinates) or a grey-scale
   Hough transform of the region (:func:`hough_orientation`).

"No dominant axis" criterion (both methods): with ``l1 >= l2`` the eigenvalues of the
force-weighted covariance of ``R``, the anisotropy ``(l1 - l2) / (l1 + l2)`` must reach
:data:`MIN_ANISOTROPY` (0.2, i.e. ``l1 >= 1.5 l2``); otherwise the orientation is NaN.  A round
blob gives ~0; a straight 2-tactel-wide, 3-tactel-long bar already gives 0.45; a single tactel
(``l1 = l2 = 0``) gives NaN.

Speed: steps 1-3 and the moments of step 4 are one compiled kernel, a few passes over the image
(:func:`tactile_bt.perception.kernels.largest_region`, numba, cached on disk); a 16x16 frame
costs a few microseconds, most of them in building the result. ``tests/perception/test_kernels.py`` checks
it against the ``scipy.ndimage.label`` + moment-basis implementation it replaced.

Layer: perception.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from tactile_bt import defaults
from tactile_bt.perception.kernels import largest_region, line_fit_offset, windowed_line_sums
from tactile_bt.sense.geometry import PadGeometry

__all__ = [
    "ContactFeatures",
    "extract",
    "hough_orientation",
    "wrap_half_pi",
    "MIN_ANISOTROPY",
    "LOCAL_WINDOW_PX",
    "LOCAL_FIT_DEGREE",
    "local_contact_point",
    "line_spans_window",
    "METHODS",
    "HOUGH_LEVELS",
    "HOUGH_STEP_DEG",
    "HOUGH_SMOOTH_DEG",
]

#: Minimum anisotropy ``(l1 - l2) / (l1 + l2)`` of the region's covariance for an orientation.
MIN_ANISOTROPY: float = 0.2
#: Half-width (tactels) of the window along a line of :func:`local_contact_point`.
LOCAL_WINDOW_PX: float = 12.0
#: Degree of the polynomial :func:`local_contact_point` fits across a line.
LOCAL_FIT_DEGREE: int = 3
#: A pivot of the fit's Cholesky solve at most this share of its diagonal entry is singular.
_MIN_PIVOT = 1e-9
#: Accepted values of the ``method`` argument of :func:`extract`.
METHODS = ("moments", "hough", None)

#: Grey levels of the Hough transform (threshold decomposition of the region's forces).
HOUGH_LEVELS: int = 4
#: Angular step of the Hough accumulator in degrees.
HOUGH_STEP_DEG: float = 1.0
#: Standard deviation in degrees of the circular smoothing of the Hough angle score.
HOUGH_SMOOTH_DEG: float = 4.0

_HALF_PI = 0.5 * math.pi
_HOUGH_THETA = np.deg2rad(np.arange(-90.0, 90.0, HOUGH_STEP_DEG))
#: The pad of an image given without one: the paper's pitch, the image's shape.
_DEFAULT_PAD = PadGeometry()


@functools.lru_cache(maxsize=16)
def _pad_of_shape(shape: tuple[int, int]) -> PadGeometry:
    """The default pad (5 mm pitch) with ``shape`` tactels; the default pad for an empty shape."""
    if shape == _DEFAULT_PAD.shape or min(shape) < 1:
        return _DEFAULT_PAD
    return PadGeometry(shape[0], shape[1])


def wrap_half_pi(angle):
    """Wrap an angle (or array of angles) to ``(-pi/2, pi/2]``, i.e. take it modulo pi.

    Parameters
    ----------
    angle : float or array_like
        Angle(s) in rad.

    Returns
    -------
    float or numpy.ndarray
        Float for scalar input, array of the same shape otherwise.  NaN stays NaN.
    """
    if type(angle) is float or np.ndim(angle) == 0:
        a = float(angle)
        if not math.isfinite(a):
            return math.nan
        r = a - math.pi * math.ceil((a - _HALF_PI) / math.pi)
        if r <= -_HALF_PI:
            r += math.pi
        elif r > _HALF_PI:
            r -= math.pi
        return r
    a = np.asarray(angle, dtype=float)
    r = a - np.pi * np.ceil((a - _HALF_PI) / np.pi)
    r = np.where(r <= -_HALF_PI, r + np.pi, r)
    return np.where(r > _HALF_PI, r - np.pi, r)


@dataclass(frozen=True, slots=True)
class ContactFeatures:
    """Features of the largest contact region of one force image.

    Attributes
    ----------
    in_contact : bool
        True when a region above the threshold with positive force exists.
    force : float
        Contact force in N, sum of the force image over the region R (Eq. 1).
    area : int
        Number of tactels in R.
    pressure : float
        ``force / (area * pad.pitch**2)`` in Pa (Eq. 2); 0.0 without contact.
    cop_px : numpy.ndarray
        Shape (2,), centre of pressure ``[x, y] = [column, row]`` in tactel units, tactel
        centres at integers; ``[nan, nan]`` without contact.
    orientation : float
        Major axis angle in rad from +x towards +y, in ``(-pi/2, pi/2]``; NaN without contact,
        when not computed (``method=None``) or when R has no dominant axis.
    method : str or None
        ``"moments"``, ``"hough"`` or None (orientation not computed).
    mask : numpy.ndarray
        ``(rows, cols)`` bool, the region R.
    invalid_tactels : int
        Number of input tactels that were NaN, infinite or negative and were replaced by 0.
    pad : PadGeometry
        The pad the image came from: its pitch gives ``pressure``, its centre and pitch ``cop``.
    image : numpy.ndarray or None
        The (sanitised) force image the features came from, N per tactel; not copied.
    others_force : float
        Force in N of every tactel above the threshold outside R: the other contact regions
        (another strand beside a cable, the other side of a hollow a flat pad bridges); 0.0
        with one region.
    others_tactels : int
        Number of those tactels.
    others_cop_px : tuple of float
        Their centre of pressure ``(x, y)`` in tactels; ``(nan, nan)`` with one region.
    """

    in_contact: bool
    force: float
    area: int
    pressure: float
    cop_px: np.ndarray
    orientation: float
    method: str | None
    mask: np.ndarray
    invalid_tactels: int = 0
    pad: PadGeometry = field(default=_DEFAULT_PAD)
    image: np.ndarray | None = field(default=None, repr=False, compare=False)
    others_force: float = 0.0
    others_tactels: int = 0
    others_cop_px: tuple[float, float] = (math.nan, math.nan)

    @property
    def cop(self) -> np.ndarray:
        """Centre of pressure in m in the sensor frame (origin at the pad centre), shape (2,)."""
        return np.array(self.cop_xy)

    @property
    def cop_xy(self) -> tuple[float, float]:
        """:attr:`cop` as two Python floats ``(x, y)`` in m (cheaper in per-cycle code)."""
        x, y = self.cop_px.tolist()
        return self.pad.xy_px_to_m(x, y)

    @property
    def load_cop_xy(self) -> tuple[float, float]:
        """Centre of pressure of every contact region together ``(x, y)`` (m, sensor frame): the
        force-weighted mean of :attr:`cop_xy` and the other regions' centre; :attr:`cop_xy` with
        one region. Where a flat pad bridges a hollow, this point lies between its borders'
        contacts, and it does not jump when the largest region changes sides."""
        x, y = self.cop_xy
        other = self.others_force
        if not (self.others_tactels > 0 and other > 0.0):
            return x, y
        ox, oy = self.pad.xy_px_to_m(*self.others_cop_px)
        share = other / (other + self.force)
        return x + share * (ox - x), y + share * (oy - y)

    @property
    def lesser_share(self) -> float:
        """Share of the load on the lesser of the largest region and the other regions together
        (0 to 0.5; 0 with one region): how evenly a pad bridging a hollow rests on both sides."""
        other = self.others_force if self.others_tactels > 0 else 0.0
        return min(other, self.force) / (other + self.force) if other > 0.0 else 0.0

    @classmethod
    def no_contact(
        cls,
        shape: tuple[int, int] | None = None,
        invalid_tactels: int = 0,
        method: str | None = None,
        pad: PadGeometry | None = None,
    ) -> ContactFeatures:
        """Features of a frame without contact: zero force, NaN COP and orientation.

        ``shape`` defaults to the pad's; without ``pad``, the default pad (5 mm pitch) of that
        shape.
        """
        if pad is None:
            pad = _DEFAULT_PAD if shape is None else _pad_of_shape(tuple(shape))
        if shape is None:
            shape = pad.shape
        return cls(
            in_contact=False,
            force=0.0,
            area=0,
            pressure=0.0,
            cop_px=np.array([math.nan, math.nan]),
            orientation=math.nan,
            method=method,
            mask=np.zeros(shape, dtype=bool),
            invalid_tactels=int(invalid_tactels),
            pad=pad,
        )


@functools.lru_cache(maxsize=16)
def _clip_limit(shape: tuple[int, int]) -> float:
    """Largest per-tactel force for which no moment sum of a ``shape`` image can overflow."""
    rows, cols = shape
    return float(np.finfo(float).max / (rows * cols * (max(rows, cols) ** 2 + 1) * 4.0))


def _moment_angle(mu20: float, mu11: float, mu02: float, min_anisotropy: float) -> float:
    """Major-axis angle from central second moments, NaN without a dominant axis."""
    trace = mu20 + mu02
    if not trace > 0.0:
        return math.nan
    diff = mu20 - mu02
    if math.hypot(diff, 2.0 * mu11) < min_anisotropy * trace:
        return math.nan
    a = 0.5 * math.atan2(2.0 * mu11, diff)
    return a + math.pi if a <= -_HALF_PI else a


def hough_orientation(image: np.ndarray, mask: np.ndarray) -> float:
    """Major-axis angle of a region by a grey-scale Hough transform (no anisotropy test).

    The force image restricted to ``mask`` is decomposed into :data:`HOUGH_LEVELS` binary level
    sets ``w > k/HOUGH_LEVELS * max(w)``; their ``skimage.transform.hough_line`` accumulators
    are summed, which is a Hough transform whose votes grow with the tactel force.  A contact
    line is several tactels wide, so its accumulator has a flat ridge along the distance axis
    and the single highest cell is a poor, lattice-biased estimate (8 degree mean error in our
    study).  Instead the angle whose votes are most concentrated wins: the score
    ``sum_rho H(rho, theta)^2`` is smoothed over theta (circular Gaussian,
    :data:`HOUGH_SMOOTH_DEG`) and its maximum refined by a parabola through three bins.

    Parameters
    ----------
    image : numpy.ndarray
        ``(rows, cols)`` force image in N per tactel (finite, >= 0).
    mask : numpy.ndarray
        ``(rows, cols)`` bool, the contact region.

    Returns
    -------
    float
        Line direction in rad from +x towards +y, in ``(-pi/2, pi/2]``; NaN for an empty mask.
    """
    from scipy.ndimage import gaussian_filter1d
    from skimage.transform import hough_line

    w = np.where(mask, image, 0.0)
    top = float(w.max()) if w.size else 0.0
    if not top > 0.0:
        return math.nan
    theta = _HOUGH_THETA
    acc = None
    for k in range(HOUGH_LEVELS):
        h = hough_line(w > top * (k / HOUGH_LEVELS), theta)[0]
        acc = h.astype(float) if acc is None else acc + h
    concentration = np.einsum("ij,ij->j", acc, acc)  # sum over rho of H^2, per theta
    score = gaussian_filter1d(concentration, HOUGH_SMOOTH_DEG / HOUGH_STEP_DEG, mode="wrap")
    n = score.size
    j = int(np.argmax(score))
    s0, s1, s2 = float(score[j - 1]), float(score[j]), float(score[(j + 1) % n])
    curvature = s0 - 2.0 * s1 + s2
    offset = 0.5 * (s0 - s2) / curvature if curvature < 0.0 else 0.0
    normal = float(theta[j]) + offset * math.radians(HOUGH_STEP_DEG)
    # skimage: rho = x cos(theta) + y sin(theta) (x = column, y = row); theta is the normal.
    return wrap_half_pi(normal + _HALF_PI)


def extract(
    image,
    threshold: float = defaults.CONTACT_THRESHOLD_N,
    method: str | None = "moments",
    pad: PadGeometry | None = None,
    *,
    min_anisotropy: float = MIN_ANISOTROPY,
    near_px: tuple[float, float] | None = None,
    window_px: tuple[float, float, float] | None = None,
) -> ContactFeatures:
    """Extract contact force, pressure, centre of pressure and orientation from a force image.

    Parameters
    ----------
    image : array_like
        ``(rows, cols)`` force image in N per tactel (sensor frame: x = column, y = row).
    threshold : float
        Binarisation threshold in N per tactel; a tactel belongs to a region when its force is
        strictly greater than ``threshold``.
    method : {"moments", "hough", None}
        Orientation method; None skips the orientation (cheaper; orientation is NaN).
    pad : PadGeometry, optional
        The pad the image comes from: its pitch converts tactels to metres (pressure, metric
        COP). Its shape must be the image's. Default: the paper's 5 mm pitch, the image's shape
        (``PadGeometry()`` for a 16×16 image).
    min_anisotropy : float
        Minimum covariance anisotropy ``(l1 - l2) / (l1 + l2)`` for a defined orientation.
    near_px : (float, float), optional
        Region selection: None keeps the largest region; a point ``[column, row]`` (tactels)
        keeps the region with the tactel nearest to it, and the pressure is the pad's load.
    window_px : (float, float, float), optional
        With ``near_px``: ``(ux, uy, half_length)``, a unit vector (sensor frame) and a length
        (tactels): the COP and orientation count only the region's tactels within
        ``half_length`` of ``near_px`` along ``(ux, uy)`` (the whole region when none is).

    Returns
    -------
    ContactFeatures
        Never contains NaN/inf force, pressure or (with contact) COP; carries ``pad``.

    Raises
    ------
    ValueError
        If ``image`` is not two-dimensional, ``method`` is unknown or ``pad`` has another shape
        than ``image``.
    TypeError
        If ``pad`` is not a :class:`~tactile_bt.sense.geometry.PadGeometry` (e.g. a pitch).
    """
    img = np.asarray(image, dtype=float)
    if img.ndim != 2:
        raise ValueError(f"extract() needs a 2-D (rows, cols) force image, got ndim={img.ndim}")
    if method not in METHODS:
        raise ValueError(f"unknown orientation method {method!r}; use 'moments', 'hough' or None")
    shape = img.shape
    if pad is None:
        pad = _pad_of_shape(shape)
    elif not isinstance(pad, PadGeometry):
        raise TypeError(f"extract(): pad must be a PadGeometry(rows, cols, pitch), got {pad!r}")
    elif pad.rows != shape[0] or pad.cols != shape[1]:
        raise ValueError(f"extract(): the image has {shape[0]}x{shape[1]} tactels, the pad "
                         f"{pad.rows}x{pad.cols}")
    pitch = pad.pitch
    if img.size == 0:
        return ContactFeatures.no_contact(shape, 0, method, pad)
    if not (img.flags.c_contiguous and img.flags.writeable):
        img = np.array(img, order="C")  # the one array layout the kernel is compiled for
    clean = np.empty(shape)
    mask = np.empty(shape, dtype=bool)
    work = np.empty(3 * img.size + 1, dtype=np.int32)
    near_x, near_y = (math.nan, math.nan) if near_px is None else (float(near_px[0]), float(near_px[1]))
    ux, uy, half = (0.0, 0.0, math.inf) if window_px is None or near_px is None else map(float, window_px)
    n_bad, changed, area, f, fw, mx, my, mxx, mxy, myy, load, loaded, ox, oy = largest_region(
        img, float(threshold), _clip_limit(shape), clean, mask, work, near_x, near_y, ux, uy, half)
    if not (fw > 0.0) and area > 0 and half < math.inf:  # nothing of the region in the window
        n_bad, changed, area, f, fw, mx, my, mxx, mxy, myy, load, loaded, ox, oy = largest_region(
            img, float(threshold), _clip_limit(shape), clean, mask, work, near_x, near_y, ux, uy, math.inf)
    if changed:
        img = clean
    if not (area > 0 and f > 0.0 and math.isfinite(f)):
        return ContactFeatures.no_contact(shape, n_bad, method, pad)
    # a convex combination of tactel centres; clip the last-ulp rounding back onto the pad
    cx = min(max(mx / fw, 0.0), shape[1] - 1.0)
    cy = min(max(my / fw, 0.0), shape[0] - 1.0)
    if method is None:
        angle = math.nan
    else:
        mu20 = max(mxx / fw - cx * cx, 0.0)
        mu11 = mxy / fw - cx * cy
        mu02 = max(myy / fw - cy * cy, 0.0)
        angle = _moment_angle(mu20, mu11, mu02, min_anisotropy)
        if method == "hough" and angle == angle:
            angle = hough_orientation(img, mask)
    # in_contact, force, area, pressure, cop_px, orientation, method, mask, invalid_tactels, pad,
    # image: positional, a third cheaper than by keyword, once per cycle
    pressure = f / (area * pitch * pitch) if near_px is None or loaded == area else load / (loaded * pitch * pitch)
    others = load - f if loaded > area else 0.0
    others_cop = (ox / others, oy / others) if others > 0.0 else (math.nan, math.nan)
    return ContactFeatures(True, f, area, pressure, np.array((cx, cy)), angle, method, mask, n_bad, pad, img,
                           max(others, 0.0), loaded - area, others_cop)


def local_contact_point(features: ContactFeatures, window_px: float = LOCAL_WINDOW_PX,
                        degree: int = LOCAL_FIT_DEGREE) -> np.ndarray:
    """Where an elongated contact crosses the pad's centre: ``[x, y]`` in tactels.

    The COP of a curved line contact (a bent cable) lies on the chord, off the line by about
    ``s² / (6 R)`` for a visible half-length ``s`` and radius of curvature ``R`` (2.7 mm for
    s = 40 mm, R = 100 mm). This estimate fits the line's centre across its major axis as a
    polynomial of ``degree`` along it, weighted by the region's force and a triangular window of
    half-width ``window_px`` centred where the axis passes closest to the pad centre, and takes
    the fit there: the chord's bias goes with the curvature the polynomial follows.

    A wide window matters for a line thinner than a tactel (a 2 mm cable on 5 mm tactels):
    each row's centroid then sits towards the nearest tactel centre (by up to 0.3 tactel in the
    simulated sensor), an error a centroid of a few rows keeps; where the line runs across
    columns that error changes sign from row to row, and a fit over many rows averages it out.
    On a tight bend the wide cubic follows the curve less closely than a narrow window (the
    README's cable table, "How the path error is measured", gives both).

    With fewer distinct positions along the axis than the polynomial needs, the degree drops
    (down to 0: the windowed centroid across the axis). Without a defined orientation it is the
    COP.

    Parameters
    ----------
    features : ContactFeatures
        Features with ``image`` and, for the local estimate, a finite ``orientation``.
    window_px : float
        Half-width of the window along the major axis (tactels).
    degree : int
        Degree of the polynomial (0 to 3).
    """
    alpha = features.orientation
    if not features.in_contact or alpha != alpha or features.image is None:
        return features.cop_px
    ux, uy, cx, cy, centre_along = _centre_crossing(features)
    image, mask = features.image, features.mask
    if not (image.flags.c_contiguous and image.flags.writeable and image.dtype == np.float64):
        image = np.array(image, dtype=float, order="C")
    if not (mask.flags.c_contiguous and mask.flags.writeable and mask.dtype == np.bool_):
        mask = np.array(mask, dtype=bool, order="C")
    ox, oy = cx + centre_along * ux, cy + centre_along * uy
    sums = windowed_line_sums(image, mask, ux, uy, ox, oy, 1.0 / window_px)
    across = line_fit_offset(sums, int(degree), _MIN_PIVOT)
    if across != across:
        return features.cop_px
    return np.array((ox - across * uy, oy + across * ux))


def line_spans_window(features: ContactFeatures, window_px: float = 3.0) -> bool:
    """Whether an elongated contact reaches ``window_px`` (tactels) beyond where its axis
    passes closest to the pad's centre, both ways along the axis: then the fit of
    :func:`local_contact_point` holds the line on both sides of that crossing. Near the line's
    end (a cable's tip under the pad) it does not, and the point leans onto the tip, up to the
    cable's radius and the foam's spread beyond the end of its centreline. False without a
    contact or an orientation; True without an image (the local point is then the COP, with
    nothing to cut short)."""
    alpha = features.orientation
    if not features.in_contact or alpha != alpha:
        return False
    if features.image is None:
        return True
    ux, uy, cx, cy, centre_along = _centre_crossing(features)
    rows, cols = np.nonzero(features.mask)
    along = (cols - cx) * ux + (rows - cy) * uy
    return bool(len(along)) and along.min() <= centre_along - window_px and along.max() >= centre_along + window_px


def _centre_crossing(features: ContactFeatures) -> tuple[float, float, float, float, float]:
    """The major axis of a contact with a finite orientation: its unit direction ``(ux, uy)``,
    the COP ``(cx, cy)`` it runs through and, along it from the COP, where it passes closest to
    the pad centre (tactels)."""
    ux, uy = math.cos(features.orientation), math.sin(features.orientation)
    cx, cy = features.cop_px.tolist()
    px, py = features.pad.centre_px
    return ux, uy, cx, cy, (px - cx) * ux + (py - cy) * uy
