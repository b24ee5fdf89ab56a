"""Progress of long commands on stderr: a tqdm bar on a terminal, a periodic one-line report
otherwise (logs of batch jobs and CI get a line every ``every_s`` seconds of wall time).

Layer: base.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """Progress of one quantity towards ``total`` (e.g. mission seconds, or runs of a study).

    Parameters
    ----------
    total : float
        The value that means done.
    unit : str
        Unit of the quantity, for the display (``"s"`` of mission time, ``"runs"``).
    label : str
        What is progressing, shown before the figures.
    every_s : float
        Off a terminal: seconds of wall time between two lines.
    delay_s : float
        Nothing is shown for commands that finish sooner than this (s of wall time).
    stream : file, optional
        Default: ``sys.stderr``.
    """

    def __init__(self, total: float, unit: str = "s", label: str = "mission", every_s: float = 10.0,
                 delay_s: float = 1.0, stream: TextIO | None = None) -> None:
        self.total = float(total)
        self.unit = unit
        self.label = label
        self.every_s = float(every_s)
        self.delay_s = float(delay_s)
        self.stream = sys.stderr if stream is None else stream
        self._digits = 1 if unit == "s" else 0  # seconds with a decimal, counts (runs) whole
        self.start = time.perf_counter()
        self._last_line = self.start
        self._bar = None
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._stages: set[str] = set()
        self._after_stage = False

    def stage(self, text: str) -> None:
        """Say, once, what holds the progress at its start (``"compiling kernels"``): one line
        ``label: text ...`` now, instead of a figure standing still at 0 %. The periodic lines
        resume ``every_s`` after the first progress reported once it is over."""
        if text in self._stages:
            return
        self._stages.add(text)
        self._after_stage = True
        print(f"{self.label}: {text} ...", file=self.stream, flush=True)

    def __call__(self, done: float, total: float | None = None, note: str = "") -> None:
        """Report ``done`` (same unit as ``total``); ``note`` is appended (e.g. failed runs)."""
        if total is not None:
            self.total = float(total)
        now = time.perf_counter()
        if self._after_stage:  # the stage is over: the figures count from here
            self._after_stage = False
            self._last_line = now
        if now - self.start < self.delay_s:
            return
        if self._tty:
            if self._bar is None:
                from tqdm import tqdm

                self._bar = tqdm(total=self.total, unit=self.unit, desc=self.label, file=self.stream,
                                 leave=True, dynamic_ncols=True,
                                 bar_format=f"{{desc}}: {{percentage:3.0f}}%|{{bar}}| {{n:.{self._digits}f}}/"
                                            f"{{total:.{self._digits}f}} {{unit}} "
                                            "[{elapsed}<{remaining}{postfix}]")
            self._bar.n = float(done)
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.refresh()
        elif now - self._last_line >= self.every_s:
            self._last_line = now
            share = 100.0 * done / self.total if self.total > 0 else 100.0
            extra = f", {note}" if note else ""
            d = self._digits
            print(f"{self.label}: {done:.{d}f}/{self.total:.{d}f} {self.unit} ({share:.0f} %) after "
                  f"{now - self.start:.0f} s{extra}", file=self.stream, flush=True)

    def close(self) -> None:
        """End the bar (a terminal's line is left in place)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
