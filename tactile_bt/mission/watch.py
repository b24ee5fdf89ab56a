"""Watching a mission from outside the loop: what a watcher is shown, and when.

A watcher sees a mission (:func:`~tactile_bt.mission.run.run_mission`, a replay, a live mission)
without taking part in it: it is started once the control loop and the log exist, shown every
cycle after the log has stored it, and finished with the result (or, when the mission raised,
with None). The rerun recording (:class:`~tactile_bt.mission.recording_rerun.RerunRecorder`) is
one; a live mission passes the same watchers to its loop.

Layer: mission.
"""

from __future__ import annotations

from typing import Iterable, Protocol

__all__ = ["MissionWatcher", "start_watchers", "finish_watchers"]


class MissionWatcher(Protocol):
    """What a mission shows a watcher."""

    def start(self, loop, log, scene=None) -> None:
        """Before the first cycle: the :class:`~tactile_bt.mission.loop.ControlLoop`, the
        :class:`~tactile_bt.mission.log.MissionLog` (its ``nodes`` when node status is logged)
        and the simulated scene (None for a replay or a live mission)."""

    def cycle(self, k: int, t: float, loop, log) -> None:
        """After cycle ``k`` (mission time ``t``, s) ran and ``log`` stored it."""

    def finish(self, result) -> None:
        """After the mission: its :class:`~tactile_bt.mission.result.MissionResult`, or None
        when it raised. Closes what the watcher opened."""


def start_watchers(watchers: Iterable[MissionWatcher] | None, loop, log, scene=None) -> tuple:
    """Start every watcher; returns them as a tuple (empty: nothing to show per cycle). When
    one fails to start, those already started are finished with None and the error raised."""
    started = []
    for watcher in watchers or ():
        try:
            watcher.start(loop, log, scene)
        except BaseException:
            finish_watchers(started, None)
            raise
        started.append(watcher)
    return tuple(started)


def finish_watchers(watchers: Iterable[MissionWatcher], result) -> None:
    """Finish every watcher with ``result``; one failing does not keep the others open (the
    first error is raised after all were finished)."""
    error = None
    for watcher in watchers:
        try:
            watcher.finish(result)
        except Exception as exc:
            error = error or exc
    if error is not None:
        raise error
