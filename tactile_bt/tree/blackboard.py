"""The blackboard adapter: the ``/tactile`` keys of one control cycle, and the one place that
reaches past py_trees' client bookkeeping for them.

=================  ==================================================================
key                content
=================  ==================================================================
``features``       smoothed :class:`~tactile_bt.perception.features.ContactFeatures` (paper Sec. V)
``features_raw``   the same before smoothing
``time``           mission clock in s (never wall time)
``dt``             control period in s
``command``        the cycle's :class:`~tactile_bt.control.servo.ServoCommand`
``pose``           ``T_gs``, 4x4 pose of the sensor frame in the base frame
``contacts``       the mission's contact cloud (:class:`~tactile_bt.contacts.cloud.ContactCloud`)
``pad``            the pad's :class:`~tactile_bt.sense.geometry.PadGeometry`
=================  ==================================================================

Two keys outside ``/tactile`` come from the arm, written after it has moved:

- ``/robot/joints_held`` (:data:`JOINTS_HELD`), the joints (numbered from 1) the arm held at a
  position limit in the last cycle (:func:`write_joints_held`). A pad that stops following where
  the planner sends it is then out of the arm's reach, not at the end of the surface.
- ``/robot/turn_room`` (:data:`TURN_ROOM`), written once at the start: the arm's function that
  tells how far the pad can still turn about its normal each way before the joint that turns it
  there (the wrist's last) reaches its limit (:func:`write_turn_room`; a leaf reads it as a
  :class:`TurnRoom` with :func:`turn_room`, when it needs it, not every cycle). A square pad
  turned by a quarter turn senses the same, so a pad whose wrist is wound onto that limit can
  turn back and go on.

Either is absent when the mount says nothing of its joints.

The keys are registered once by :func:`cycle_writer` (so py_trees knows who writes them); the
per-cycle values are then read and written through :func:`read` and :func:`write`, straight in
the blackboard's storage: a client's access bookkeeping costs several microseconds a read, more
than the control law.

Layer: tree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import py_trees
from py_trees.common import Access

from tactile_bt.sense.geometry import PadGeometry

__all__ = ["JOINTS_HELD", "write_joints_held", "joints_held", "TURN_ROOM", "TurnRoom", "write_turn_room", "turn_room",
           "NAMESPACE", "KEYS", "FEATURES", "FEATURES_RAW", "TIME", "POSE", "PAD", "cycle_writer", "read", "read_or",
           "pressure_target", "write", "write_cycle", "current_pad"]

NAMESPACE = "/tactile"
KEYS = ("features", "features_raw", "time", "dt", "command", "pose", "contacts", "pad")
FEATURES, FEATURES_RAW, TIME, POSE, PAD = (f"{NAMESPACE}/{k}" for k in ("features", "features_raw", "time", "pose",
                                                                          "pad"))
#: Blackboard key of the joints the arm held at a position limit in the last cycle (tuple of
#: joint numbers from 1; absent: the mount does not say).
JOINTS_HELD = "/robot/joints_held"
#: Blackboard key of the arm's function telling the room the wrist leaves the pad to turn about its
#: normal (see :func:`write_turn_room`; absent or None: the mount does not say).
TURN_ROOM = "/robot/turn_room"
_STORAGE = py_trees.blackboard.Blackboard.storage
_NONE_HELD: tuple = ()
_DEFAULT_PAD = PadGeometry()


def read(key: str) -> Any:
    """The value of a registered blackboard key (full name, e.g. :data:`FEATURES`)."""
    return _STORAGE[key]


def read_or(key: str, default: Any = None) -> Any:
    """The value of a blackboard key, or ``default`` while nobody has written it."""
    return _STORAGE.get(key, default)


def pressure_target(key: str, nominal_pa: float) -> float:
    """A pressure target (Pa) that follows ``key`` (e.g. ``/force/target_pa``, which
    ``adapt_force_target`` writes): its value while it holds a positive float, else
    ``nominal_pa``; ``key`` empty: always ``nominal_pa``. Read every cycle."""
    if key:
        value = _STORAGE.get(key)
        if isinstance(value, float) and value > 0.0:
            return value
    return nominal_pa


def write(key: str, value: Any) -> None:
    """Set a registered blackboard key (full name)."""
    _STORAGE[key] = value


def write_cycle(t: float, pose: np.ndarray, features_raw, features) -> None:
    """The per-cycle inputs of a tick: mission time (s), ``T_gs`` and the features."""
    _STORAGE[TIME] = t
    _STORAGE[POSE] = pose
    _STORAGE[FEATURES_RAW] = features_raw
    _STORAGE[FEATURES] = features


def write_joints_held(saturated) -> None:
    """Put the joints held at a position limit in the last cycle on :data:`JOINTS_HELD`, from
    the arm's per-joint flags (``saturated``: one bool per joint)."""
    _STORAGE[JOINTS_HELD] = tuple(i + 1 for i, s in enumerate(saturated) if s) if saturated is not None else _NONE_HELD


def joints_held() -> tuple:
    """The joints (numbered from 1) the arm held at a position limit in the last cycle; () when
    none, or when the mount does not say."""
    return _STORAGE.get(JOINTS_HELD, _NONE_HELD) or _NONE_HELD


@dataclass(frozen=True)
class TurnRoom:
    """How far (rad) the pad can still turn about its normal (the sensor's +z) before ``joint``
    (numbered from 1), the joint that turns it so, reaches a limit: ``positive_rad`` turning
    about +z, ``negative_rad`` about -z (both >= 0)."""

    joint: int
    positive_rad: float
    negative_rad: float

    def after(self, turn_rad: float) -> float:
        """The room left the tighter way after the pad has turned ``turn_rad`` about +z (rad;
        negative: past the limit)."""
        return min(self.positive_rad - turn_rad, self.negative_rad + turn_rad)


def write_turn_room(room: Callable[[], tuple[int, float, float] | None] | None) -> None:
    """Put the arm's function ``room() -> (joint, about +z, about -z) | None`` (rad; as
    :meth:`tactile_bt.robot.mounts.ArmMount.turn_room`) on :data:`TURN_ROOM`, once: it is
    called when a leaf asks (None: the mount does not say)."""
    _STORAGE[TURN_ROOM] = room


def turn_room(pad: PadGeometry) -> TurnRoom | None:
    """The wrist's :class:`TurnRoom` now; None when the arm does not say, or when ``pad`` is not
    square: turned a quarter turn it would not sense the same."""
    room = _STORAGE.get(TURN_ROOM)
    if room is None or not math.isclose(*pad.size_m):
        return None
    left = room()
    return None if left is None else TurnRoom(*left)


def current_pad() -> PadGeometry:
    """The pad on the blackboard (:data:`PAD`), or the default ``PadGeometry()`` when none is
    written (a leaf ticked outside a mission or a harness)."""
    pad = _STORAGE.get(PAD)
    return _DEFAULT_PAD if pad is None else pad


def cycle_writer(name: str, command, contacts, dt: float, pose: np.ndarray | None = None,
                 pad: PadGeometry | None = None):
    """A blackboard client that owns the ``/tactile`` keys, with the mission's constant objects
    (cycle command, contact cloud, control period in s, pad geometry: ``pad``, default
    ``PadGeometry()``) and an initial pose written.

    The mission loop and :class:`tactile_bt.testing.LeafHarness` both start from it.
    """
    writer = py_trees.blackboard.Client(name=name, namespace=NAMESPACE)
    for key in KEYS:
        writer.register_key(key=key, access=Access.WRITE)
    writer.command = command
    writer.contacts = contacts
    writer.dt = float(dt)
    writer.time = 0.0
    writer.pose = np.eye(4) if pose is None else np.asarray(pose, dtype=float)
    writer.features = writer.features_raw = None
    writer.pad = _DEFAULT_PAD if pad is None else pad
    return writer
