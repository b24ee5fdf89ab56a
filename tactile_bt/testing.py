"""Helpers to unit-test tactile leaves and small trees without a simulator: fake features or
scripted tactile frames, a fake mission clock, and access to the twist a leaf added.

Example
-------
>>> from tactile_bt.tree.behaviours import ForceHold
>>> from tactile_bt.testing import LeafHarness, make_features
>>> h = LeafHarness(ForceHold(target_pa=2000))
>>> h.tick(make_features(pressure=1500))        # too light: press on
<Status.RUNNING: 'RUNNING'>
>>> bool(h.twist[2] > 0)                         # +z of the sensor frame, towards the object
True

The same through the real perception (calibration inverse, feature extraction, moving
average), from force images or raw 12-bit counts:

>>> from tactile_bt.testing import contact_frame
>>> h = LeafHarness(ForceHold(target_pa=2000))
>>> h.tick(frame=contact_frame(force_n=1.0))     # a line contact of 1 N
<Status.RUNNING: 'RUNNING'>
>>> round(h.features.force, 2), bool(h.twist[2] > 0)
(1.0, True)
"""

from __future__ import annotations

import contextlib
from typing import Callable, Iterable, Iterator

import numpy as np
import py_trees
from py_trees.common import Access, Status

from tactile_bt.errors import UnknownNodeError
from tactile_bt import defaults
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.tree.blackboard import cycle_writer
from tactile_bt.contacts.cloud import ContactCloud
from tactile_bt.sense.calibration import TactelCalibration
from tactile_bt.control.servo import ServoCommand
from tactile_bt.perception.features import ContactFeatures, extract
from tactile_bt.perception.smoothing import FeatureSmoother

__all__ = [
    "make_features",
    "contact_frame",
    "raw_frame",
    "FramePerception",
    "LeafHarness",
    "UnknownNodeError",
    "fresh_blackboard",
]


def _pad_and_shape(shape, pad: PadGeometry | None) -> tuple[PadGeometry, tuple[int, int]]:
    """The pad of a fake frame: ``pad``, or the default pitch with ``shape`` (default 16 x 16)."""
    if pad is None:
        pad = PadGeometry() if shape is None else PadGeometry(*shape)
    elif shape is not None and tuple(shape) != pad.shape:
        raise ValueError(f"shape {tuple(shape)} differs from the pad's {pad.shape}: give one")
    return pad, pad.shape


def make_features(
    cop_px=None,
    pressure: float = defaults.TARGET_PRESSURE_PA,
    orientation: float = np.pi / 2,
    area: int = 40,
    in_contact: bool = True,
    shape=None,
    pad: PadGeometry | None = None,
) -> ContactFeatures:
    """Features of a fake contact: COP in tactels ``[x, y]`` (default: the pad centre),
    pressure in Pa, orientation in rad, on ``pad`` (default: the paper's 5 mm pitch with
    ``shape`` tactels, 16 x 16 without one). The force is ``pressure`` times ``area`` tactels of
    the pad.

    ``in_contact=False`` gives the features of an empty frame.
    """
    pad, shape = _pad_and_shape(shape, pad)
    if not in_contact:
        return ContactFeatures.no_contact(shape, pad=pad)
    if cop_px is None:
        cop_px = pad.centre_px
    mask = np.zeros(shape, dtype=bool)
    mask.flat[:area] = True
    force = pressure * area * pad.tactel_area_m2
    return ContactFeatures(
        in_contact=True,
        force=float(force),
        area=int(area),
        pressure=float(pressure),
        cop_px=np.asarray(cop_px, dtype=float),
        orientation=float(orientation),
        method="moments",
        mask=mask,
        invalid_tactels=0,
        pad=pad,
    )


def contact_frame(
    cop_px=None,
    force_n: float = 2.0,
    orientation_rad: float = np.pi / 2,
    length_px: float = 6.0,
    width_px: float = 2.0,
    shape=None,
    pad: PadGeometry | None = None,
) -> np.ndarray:
    """Force image (N per tactel, ``(rows, cols)``) of a contact centred at ``cop_px``
    (``[x, y]`` in tactels; default the pad centre, (7.5, 7.5) on a 16 x 16 pad) carrying
    ``force_n`` newtons, on ``pad`` (default: 16 x 16, or ``shape``).

    ``length_px > 0`` gives a line contact (an edge, a pen, a cable) along ``orientation_rad``
    (from +x towards +y) with a cross profile ``width_px`` wide; ``length_px = 0`` a round
    contact of that width. Extraction sees a little less force (1–3 %): the binarisation
    threshold cuts the contact's rim. The defaults cover 36 tactels: 2 N is then about 2.2 kPa on
    5 mm tactels. Built with :mod:`tactile_bt.perception.synthetic`.
    """
    from tactile_bt.perception.synthetic import blob_contact, line_contact

    pad, shape = _pad_and_shape(shape, pad)
    if cop_px is None:
        cop_px = pad.centre_px
    if length_px > 0:
        return line_contact(cop_px, orientation_rad, length_px, width_px, force_n, shape=tuple(shape))
    return blob_contact(cop_px, width_px, force_n, shape=tuple(shape))


def raw_frame(force_image, calibration: TactelCalibration | None = None, noise_counts: float = 0.0,
              rng: np.random.Generator | None = None, pad: PadGeometry | None = None) -> np.ndarray:
    """Raw 12-bit counts (integers, as the sensor sends them) of a force image, through
    ``calibration`` (nominal tactels of ``pad`` by default: the default pitch, the image's
    shape), with optional Gaussian noise in counts."""
    image = np.asarray(force_image, dtype=float)
    if calibration is None:
        pad, _ = _pad_and_shape(image.shape, pad)
        calibration = TactelCalibration.nominal(pad=pad)
    raw = calibration.raw_from_force(image)
    if noise_counts > 0:
        raw = raw + (rng if rng is not None else np.random.default_rng(0)).normal(0.0, noise_counts, image.shape)
    return np.clip(np.rint(raw), 0, defaults.ADC_MAX).astype(np.uint16)


class FramePerception:
    """The mission's perception of one frame: raw counts → calibration inverse → force image →
    :func:`~tactile_bt.perception.features.extract` → :class:`~tactile_bt.perception.smoothing.FeatureSmoother`.

    Call it with a force image (``force=``, N per tactel) or raw counts (``raw=``); it returns
    ``(features_raw, features)`` — unsmoothed and smoothed, as the leaves see them on the
    blackboard. The moving average runs across calls, as in a mission; :meth:`reset` forgets it.

    Parameters
    ----------
    calibration : TactelCalibration, optional
        Inverse characteristic for raw counts (nominal tactels by default).
    threshold : float
        Binarisation threshold (N per tactel).
    method : "moments", "hough" or None
        Orientation method (None: orientation NaN, as when no running leaf needs it).
    smoothing : int
        Samples of the moving average (paper: 10).
    pad : PadGeometry, optional
        The pad the frames come from (its pitch gives pressure and metric COP). Default: the
        paper's 5 mm pitch with the frames' shape.
    """

    def __init__(self, calibration: TactelCalibration | None = None,
                 threshold: float = defaults.CONTACT_THRESHOLD_N, method: str | None = "moments",
                 smoothing: int = defaults.SMOOTHING_SAMPLES, pad: PadGeometry | None = None) -> None:
        self.pad = pad
        self.calibration = calibration if calibration is not None else TactelCalibration.nominal(pad=pad)
        self.threshold = float(threshold)
        self.method = method
        self.smoother = FeatureSmoother(smoothing)

    def reset(self) -> None:
        """Forget the moving average."""
        self.smoother.reset()

    def __call__(self, force=None, raw=None, near_px=None, window_px=None) -> tuple[ContactFeatures, ContactFeatures]:
        """``near_px``, ``window_px``: the region selection of a running leaf's ``region_hint``
        (:func:`~tactile_bt.perception.features.extract`; None: the largest region)."""
        if (force is None) == (raw is None):
            raise ValueError("give either a force image (force=) or raw counts (raw=)")
        image = self.calibration.force_from_raw(raw) if raw is not None else np.asarray(force, dtype=float)
        f_raw = extract(image, self.threshold, self.method, pad=self.pad, near_px=near_px, window_px=window_px)
        return f_raw, self.smoother(f_raw)


class LeafHarness:
    """Tick one behaviour (or a small tree) against fake features or scripted tactile frames and
    a fake mission clock.

    Parameters
    ----------
    behaviour : py_trees.behaviour.Behaviour or py_trees.trees.BehaviourTree
        The leaf (or subtree root) under test, or a whole tree such as :func:`~tactile_bt.load_tree`
        returns (its root is ticked; its ``setup()`` writes the tree's ``--blackboard`` values);
        ``setup()`` is called here.
    dt : float
        Control period (s); the clock advances by ``dt`` after every tick.
    features : ContactFeatures, optional
        Initial features (default: a centred contact at the target pressure).
    pose : (4, 4) array, optional
        ``T_gs`` of the pad (default identity).
    perception : FramePerception, optional
        Used for ``tick(frame=...)`` and ``tick(raw=...)`` (default: nominal calibration of
        ``pad``, moments, 10-sample smoothing).
    pad : PadGeometry, optional
        The pad of the mission, on the blackboard (``/tactile/pad``) for the leaves: it sets the
        unit of their logged COP errors (tactels), their blackboard references in tactels, and
        the default features and frames. Default ``PadGeometry()`` (16 x 16 at 5 mm).
    """

    def __init__(self, behaviour: py_trees.behaviour.Behaviour, dt: float = 1.0 / defaults.RATE_HZ,
                 features: ContactFeatures | None = None, pose: np.ndarray | None = None,
                 perception: FramePerception | None = None, pad: PadGeometry | None = None) -> None:
        tree = behaviour if isinstance(behaviour, py_trees.trees.BehaviourTree) else None
        #: The tree under test, when a BehaviourTree was given.
        self.tree = tree
        self.behaviour = tree.root if tree is not None else behaviour
        self.dt = float(dt)
        self.time = 0.0
        #: The pad on the blackboard.
        self.pad = PadGeometry() if pad is None else pad
        self.command = ServoCommand(np.inf, np.inf)
        self.contacts = ContactCloud()
        self._perception = perception
        self._writer = cycle_writer("harness", self.command, self.contacts, self.dt, pose, pad=self.pad)
        self._extra: py_trees.blackboard.Client | None = None
        self.set_features(features if features is not None else make_features(pad=self.pad))
        if tree is not None:
            tree.setup()
        else:
            for node in behaviour.iterate():
                node.setup()

    # -- inputs ------------------------------------------------------------------------------
    @property
    def perception(self) -> FramePerception:
        """The frame pipeline of ``tick(frame=...)`` / ``tick(raw=...)`` (created on first use)."""
        if self._perception is None:
            self._perception = FramePerception(pad=self.pad)
        return self._perception

    def set_features(self, features: ContactFeatures, raw: ContactFeatures | None = None) -> None:
        """Features seen from the next tick on (``raw``: unsmoothed, defaults to the same)."""
        self._writer.features = features
        self._writer.features_raw = raw if raw is not None else features

    def set_frame(self, frame=None, raw=None) -> None:
        """Features of a force image (``frame``, N per tactel) or of raw counts (``raw``),
        through :attr:`perception`, seen from the next tick on; with the region a running node's
        ``region_hint`` asks for, as in a mission (:class:`~tactile_bt.mission.loop.ControlLoop`)."""
        near = window = None
        for node in self.behaviour.iterate():
            if node.status == Status.RUNNING and callable(getattr(node, "region_hint", None)):
                near, window = node.region_hint()
                break
        f_raw, f = self.perception(force=frame, raw=raw, near_px=near, window_px=window)
        self.set_features(f, raw=f_raw)

    def set_pose(self, pose: np.ndarray) -> None:
        self._writer.pose = np.asarray(pose, dtype=float)

    def set(self, key: str, value) -> None:
        """Write any blackboard ``key`` (absolute, e.g. ``/goal/pressure``), for leaves that read
        one (``twist_key``, blackboard references)."""
        if self._extra is None:
            self._extra = py_trees.blackboard.Client(name="harness/extra")
        key = key if key.startswith("/") else "/" + key
        if not self._extra.is_registered(key, access=Access.WRITE):
            self._extra.register_key(key=key, access=Access.WRITE)
        self._extra.set(key, value)

    @property
    def features(self) -> ContactFeatures:
        """The (smoothed) features of the last / next tick."""
        return self._writer.features

    @property
    def features_raw(self) -> ContactFeatures:
        """The unsmoothed features of the last / next tick."""
        return self._writer.features_raw

    # -- ticking -----------------------------------------------------------------------------
    def tick(self, features: ContactFeatures | None = None, *, frame=None, raw=None) -> Status:
        """Tick once — with new ``features``, or the features of a force image ``frame`` or of
        raw counts ``raw`` through the real perception — then advance the clock by ``dt``."""
        if features is not None:
            self.set_features(features)
        elif frame is not None or raw is not None:
            self.set_frame(frame=frame, raw=raw)
        self._writer.time = self.time
        self.command.clear()
        self.behaviour.tick_once()
        self.time += self.dt
        return self.behaviour.status

    def tick_until(self, done: Callable[[Status], bool] | Status = Status.SUCCESS, max_ticks: int = 10_000,
                   features=None, frame=None, raw=None, *, frames: Iterable | None = None,
                   raw_frames: Iterable | None = None) -> int:
        """Tick until ``done(status)`` (or the status equals ``done``); return the number of ticks.

        ``features``, ``frame`` (a force image) and ``raw`` (raw counts) are the keywords of
        :meth:`tick`: one input, held for every tick, or a sequence of inputs, one per tick (when
        the sequence ends first, the last input stays). ``frames`` and ``raw_frames`` are older
        names of ``frame`` and ``raw``. Raises ``AssertionError`` when ``max_ticks`` pass first.
        """
        test = done if callable(done) else (lambda s: s == done)
        frame = frames if frame is None else frame
        raw = raw_frames if raw is None else raw
        given = [(kind, value) for kind, value in (("features", features), ("frame", frame), ("raw", raw))
                 if value is not None]
        if len(given) > 1:
            raise ValueError("script one kind of input: features, frame or raw")
        kind, script = given[0] if given else (None, None)
        if kind is not None and _one_input(kind, script):
            self.tick(**{kind: script})  # a single input: set it once, then it stays
            if test(self.behaviour.status):
                return 1
            kind, script, first = None, None, 1
        else:
            first = 0
        items = iter(script) if script is not None else None
        for n in range(first + 1, max_ticks + 1):
            item = next(items, None) if items is not None else None
            status = self.tick() if item is None else self.tick(**{kind: item})
            if test(status):
                return n
        raise AssertionError(f"{self.behaviour.name}: still {self.behaviour.status} after {max_ticks} ticks")

    def tick_for(self, seconds: float, **script) -> Status:
        """Tick for ``seconds`` of mission time (``round(seconds / dt)`` ticks, at least one),
        or until the behaviour finishes (SUCCESS or FAILURE) if that comes first; return the
        last status. ``script``: ``features``, ``frame`` or ``raw`` as in :meth:`tick_until`."""
        n = max(1, int(round(seconds / self.dt)))
        count = [0]

        def done(status: Status) -> bool:
            count[0] += 1
            return count[0] >= n or status in (Status.SUCCESS, Status.FAILURE)

        self.tick_until(done, max_ticks=n, **script)
        return self.behaviour.status

    # -- outputs -----------------------------------------------------------------------------
    @property
    def twist(self) -> np.ndarray:
        """Summed sensor-frame twist ``[vx, vy, vz, wx, wy, wz]`` added during the last tick."""
        return self.command.twist()

    def twist_of(self, name: str | py_trees.behaviour.Behaviour) -> np.ndarray:
        """The twist part one leaf (by name or object) added during the last tick (zeros if it
        added none). Raises :class:`UnknownNodeError` (a KeyError) for a name that no node of the
        behaviour under test has, listing the names it has."""
        key = name if isinstance(name, str) else name.name
        names = list(dict.fromkeys(node.name for node in _preorder(self.behaviour)))
        if key not in names:
            from difflib import get_close_matches

            close = get_close_matches(str(key), names, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise UnknownNodeError(f"no node named {key!r} in {self.behaviour.name!r}{hint}; "
                                   f"known: {', '.join(names)}")
        part = self.command.parts.get(key)
        return np.zeros(6) if part is None else part

    @property
    def errors(self) -> dict[str, float]:
        """Errors (measured − target, metric units) reported during the last tick."""
        return dict(self.command.errors)


def _one_input(kind: str, value) -> bool:
    """Whether ``value`` is one input of ``kind`` (held for every tick) rather than a script."""
    if kind == "features":
        return isinstance(value, ContactFeatures)
    if isinstance(value, np.ndarray):
        return value.ndim == 2
    return isinstance(value, (list, tuple)) and np.ndim(value) == 2  # nested lists of numbers


def _preorder(node: py_trees.behaviour.Behaviour) -> Iterator[py_trees.behaviour.Behaviour]:
    """The nodes of a (sub)tree, parents before their children, as the tree display shows them."""
    yield node
    for child in node.children:
        yield from _preorder(child)


@contextlib.contextmanager
def fresh_blackboard() -> Iterator[None]:
    """Clear the py_trees blackboard before and after the block (every test should start from
    an empty one: keys and clients are global)."""
    py_trees.blackboard.Blackboard.clear()
    try:
        yield
    finally:
        py_trees.blackboard.Blackboard.clear()
