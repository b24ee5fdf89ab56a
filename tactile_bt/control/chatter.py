"""Chatter of a servo output: detected when it switches sign with a large jump tick after tick,
and damped (gain reduced, output low-passed) until it stops. Every servo leaf applies it to its
PID's outputs (:class:`tactile_bt.tree.behaviours.base.ServoLeaf`).

A pad rocking between two contacts (:class:`RockingDetector`): the largest contact region
changing sides again and again, as a flat pad bridging a hollow does when it rolls towards
whichever rim bears more. The rolling leaf can hold the pad's tilt while it lasts
(``rocking_hold_s`` of :class:`tactile_bt.tree.behaviours.placement.RollTo`).

Layer: control.
"""

from __future__ import annotations

import math
from typing import Sequence

__all__ = ["ChatterDamper", "RockingDetector"]


class ChatterDamper:
    """Damps servo outputs that switch sign with a large jump tick after tick (chatter).

    A flat pad bridging a concave surface, or lying across a ridge, sees its centre of pressure
    jump from one side to the other as the pad turns: a rolling or sliding loop then saturates in
    one direction and the next, every cycle. Each component keeps a chatter level ``c`` in
    [0, 1]: a sign change whose jump is at least ``jump_share`` of the component's output limit
    and that comes within ``gap_s`` of the previous one raises it by ``step`` (one sign change
    alone, a loop reversing once, does not), and it falls by ``dt / recover_s`` a cycle
    otherwise. The output is
    then ``y += (g·u − y) · dt / (dt + c·smooth_s)`` with the gain ``g = 1 − (1 − gain_min)·c``:
    the gain reduced and the output low-passed while the loop chatters, and ``y = u`` exactly
    while it does not (``c = 0``). Components without a finite limit are left alone.

    Parameters
    ----------
    output_limit : sequence of float
        Largest ``|u|`` per component (the PID's limits).
    jump_share : float
        Share of the limit a sign change must jump to count (0–2; above 2 nothing counts).
    step : float
        Rise of the chatter level per counted sign change (0–1).
    recover_s : float
        Time for the level to fall from 1 to 0 without chatter (s).
    gain_min : float
        Gain at full chatter (0–1).
    smooth_s : float
        Time constant of the output's low-pass at full chatter (s).
    gap_s : float
        Longest time between two large sign changes that count as chatter (s).
    """

    def __init__(self, output_limit: Sequence[float], jump_share: float, step: float, recover_s: float,
                 gain_min: float, smooth_s: float, gap_s: float) -> None:
        self.jumps = [jump_share * lim if math.isfinite(lim) else math.inf for lim in output_limit]
        self.step, self.recover_s, self.gain_min, self.smooth_s = float(step), float(recover_s), float(gain_min), \
            float(smooth_s)
        self.gap_s = float(gap_s)
        self.n = len(self.jumps)
        self.reset()

    def reset(self) -> None:
        """No chatter, no history (called when a leaf starts)."""
        self.level = [0.0] * self.n
        self._u = [0.0] * self.n
        self._y = [0.0] * self.n
        self._since = [math.inf] * self.n  # time since the last large sign change (s)
        self.counted = 0

    def apply(self, u: list[float], dt: float, active: Sequence[int] | None = None) -> list[float]:
        """The damped outputs of one cycle for the PID outputs ``u``; only the components
        ``active`` (indices; all by default) are looked at, the others pass unchanged."""
        level, previous, outputs, jumps, since = self.level, self._u, self._y, self.jumps, self._since
        decay = dt / self.recover_s
        out = list(u)
        for i in range(self.n) if active is None else active:
            v, p = u[i], previous[i]
            c = level[i]
            since[i] += dt
            if v * p < 0.0 and abs(v - p) >= jumps[i]:
                if since[i] <= self.gap_s:
                    c = min(1.0, c + self.step)
                    self.counted += 1
                since[i] = 0.0
            elif c > 0.0:
                c = max(0.0, c - decay)
            level[i] = c
            previous[i] = v
            if c > 0.0:
                g = 1.0 - (1.0 - self.gain_min) * c
                y = outputs[i]
                y += (g * v - y) * dt / (dt + c * self.smooth_s)
                out[i] = y
            outputs[i] = out[i]
        return out


class RockingDetector:
    """Tells a pad rocking between two contacts: the largest region's centre of pressure jumping
    by more than ``jump_share`` of the pad's width from one cycle to the next, with another
    region under the pad (a change of side), ``changes`` times within the last ``window_s``, and
    for ``hold_s`` after that no longer holds. A flat pad resting on the two
    rims of a hollow narrower than itself bears them in turn: rolled towards the one that bears
    more, it presses the other, which then bears more. Rolling cannot centre such a contact; it
    only rocks the pad from rim to rim, pressing each rim's narrow contact hard in turn.

    Parameters
    ----------
    jump_share : float
        Share of the pad's smaller width (0–1) the centre of pressure must jump.
    changes : int
        Changes of side within ``window_s`` that make it rocking.
    window_s : float
        Time window of the changes (s).
    hold_s : float
        The pad counts as rocking until this long after fewer than ``changes`` changes lie
        within ``window_s`` (s).
    """

    def __init__(self, jump_share: float, changes: int, window_s: float, hold_s: float) -> None:
        self.jump_share, self.changes = float(jump_share), int(changes)
        self.window_s, self.hold_s = float(window_s), float(hold_s)
        self.reset()

    def reset(self) -> None:
        """No history."""
        self._last_xy: tuple[float, float] | None = None
        self._times: list[float] = []
        self._until = -math.inf

    def update(self, now: float, in_contact: bool, cop_xy: tuple[float, float], others: bool,
               width_m: float) -> bool:
        """Whether the pad rocks at ``now`` (s), given this cycle's contact: ``cop_xy`` the
        largest region's centre of pressure (m, sensor frame), ``others`` whether another region
        is under the pad, ``width_m`` the pad's smaller width (m)."""
        x, y = cop_xy
        last = self._last_xy
        times = self._times
        if in_contact and others and last is not None and \
                math.hypot(x - last[0], y - last[1]) > self.jump_share * width_m:
            times.append(now)
        self._last_xy = (x, y) if in_contact else None
        while times and now - times[0] > self.window_s:
            times.pop(0)
        if len(times) >= self.changes:
            self._until = now + self.hold_s
        return now < self._until
