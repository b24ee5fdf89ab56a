"""The first run after an install: the compiled kernels built on two cores.

numba compiles a kernel the first time it is called and keeps the machine code in its disk
cache (``cache=True``); every later run loads it.  On an empty cache that compile is most of the
first run's wall time.  The kernels form three groups that do not call one another: the arm's
(:mod:`tactile_bt.robot.kernels`: resolved rates, the contact equilibrium's step), the pad's
(:mod:`tactile_bt.sim.kernels`) and perception's (:mod:`tactile_bt.perception.kernels`); the
arm's step and the pad's contact are called in turn from Python
(:class:`tactile_bt.robot.stepping.ArmStepper`), so no kernel links the arm's and the pad's
machine code together (numba would compile that call tree again, in series).

:func:`start` starts a second process; :func:`finish` then compiles groups in this process
while the second one compiles others, both taking the next group from one queue (largest
first), until all are built; whatever one process builds, the other loads from the disk cache.
``tactile-bt bench`` reports the first run's time.

Nothing changes in the compiled code: each function is compiled for the same argument types as
a mission calls it with, and the cache key is the same either way
(``tests/sim/test_kernel_build.py`` checks that a mission compiles no other version).

Layer: sim.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable

__all__ = ["start", "finish", "compiling", "compile_group", "is_cached", "GROUPS"]

#: The kernel groups, in the order they are taken from the queue (largest first).
GROUPS = ("arm", "pad", "perception")

#: Longest wait (s) for the second process; after it, it is stopped and this process compiles
#: what it did not report.
TIMEOUT_S = 300.0

_build: _Build | None = None
_start_lock = threading.Lock()
#: The kernels are built (this process checked the cache, or built them): nothing to start.
_built = False
#: One core and a cold cache: :func:`finish` compiles every group in this process.
_cold_here = False


def _signatures(group: str) -> list:
    """``(dispatcher, signature)`` of the functions of one group, callees before callers: the
    argument types the simulator (:class:`tactile_bt.sim.pad.SensorModel`,
    :class:`tactile_bt.robot.arm.CompliantArm`) and perception call them with."""
    from numba import types  # (not at import: start() spawns the second process first)

    f1, f2 = types.Array(types.float64, 1, "C"), types.Array(types.float64, 2, "C")
    i1, i2 = types.Array(types.int64, 1, "C"), types.Array(types.int64, 2, "C")
    f, i = types.float64, types.int64
    if group == "arm":
        from tactile_bt.robot import kernels as rk

        return [(rk.pose_jacobian, (f1, f1, f2, f2)),
                (rk.rates_fast, (f1, f1, f1, f1, f, f, f, f1)),
                (rk.arm_step, (i, f1, f1, f1, f1, f1))]
    if group == "perception":
        from tactile_bt.perception import kernels as pk

        mask = types.Array(types.boolean, 2, "C")
        return [(pk.largest_region, (f2, f, f, f2, mask, types.Array(types.int32, 1, "C"), f, f, f, f, f)),
                (pk.windowed_line_sums, (f2, mask, f, f, f, f, f)),
                (pk.line_fit_offset, (f1, i, f))]
    if group == "pad":
        from tactile_bt.sim import kernels as sk

        data = types.Tuple((f2, f2, f2, f1, f2, f1, i2, i1, f1, f1, f1, f1, f1))
        return [(sk.foam_spread, (f1, f2, f2, i, i, i)),
                (sk.raw_counts, (f1, f2, f1, f, f1, types.Array(types.uint16, 1, "C"))),
                (sk.pad_contact, (f2, data, f1))]
    raise ValueError(f"unknown kernel group {group!r}; expected one of {GROUPS}")


def compile_group(group: str) -> None:
    """Compile (or load from the disk cache) the functions of ``group``."""
    for dispatcher, signature in _signatures(group):
        dispatcher.compile(signature)


def is_cached(dispatcher, signature) -> bool:
    """Whether numba's disk cache holds ``dispatcher`` compiled for ``signature`` (or this
    process has it already).  A dispatcher without a disk cache counts as cached: there is
    nothing to build ahead for it."""
    if tuple(signature) in dispatcher.overloads:
        return True
    cache = getattr(dispatcher, "_cache", None)
    load = getattr(cache, "load_overload", None)
    if load is None or type(cache).__name__ == "NullCache":
        return True
    try:
        return load(signature, dispatcher.targetctx) is not None
    except Exception:  # an unreadable cache entry: numba recompiles it anyway
        return False


class _Build:
    """The second process, the queue of groups both processes take from, and which are built.

    The second process reads the group to build from its standard input, one name per line, and
    writes each name back when the group is built, on a pipe of its own (anything else it prints
    goes to its standard error).  A group it was given but never reported (it died, or hung past
    the deadline) is built by :func:`finish` in this process."""

    def __init__(self):
        self._lock = threading.Lock()
        self._queue = list(GROUPS)
        self.built: set[str] = set()
        self.done = {group: threading.Event() for group in GROUPS}
        self.process = subprocess.Popen(_command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        stderr=subprocess.DEVNULL, text=True)
        threading.Thread(target=self._read, daemon=True).start()

    def take(self) -> str | None:
        """The next group nobody builds yet (None: none left)."""
        with self._lock:
            return self._queue.pop(0) if self._queue else None

    def mark(self, group: str) -> None:
        """``group`` is built."""
        with self._lock:
            self.built.add(group)
        self.done[group].set()

    def give(self) -> None:
        """Give the second process the next group, or tell it there is none (it then ends)."""
        group = self.take()
        try:
            if group is None:
                self.process.stdin.close()
            else:
                self.process.stdin.write(group + "\n")
                self.process.stdin.flush()
        except (OSError, ValueError):  # it has ended: the group goes back to the queue
            if group is not None:
                with self._lock:
                    self._queue.insert(0, group)

    def _read(self) -> None:
        for line in self.process.stdout:
            group = line.strip()
            if group in self.done:
                self.mark(group)
            self.give()  # (a line that names no group: the next one all the same)
        for event in self.done.values():  # the process ended: nothing more to wait for
            event.set()
        self.process.wait()

    def stop_giving(self) -> None:
        """Nothing for the second process to build: it ends."""
        with self._lock:
            self._queue.clear()
        self.give()

    def end(self, deadline: float) -> None:
        """Wait for every group (or the process's end), then for the process; killed at
        ``deadline``."""
        for event in self.done.values():
            event.wait(max(deadline - time.monotonic(), 0.0))
        try:
            self.process.wait(timeout=max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            self.stop()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # (not on every platform)
        return os.cpu_count() or 1


def start() -> None:
    """On a cold cache, start the second process on the first group.  Nothing is started on one
    core (a cold cache is noted, for :func:`finish` to compile here), when a build is already
    running, or once this process knows the kernels are built.
    The process starts before the cache is checked, so that its start-up overlaps the check; on
    a warm cache it is told there is nothing to build, and ends.  The check looks at the last
    function of each group, which :func:`compile_group` builds last."""
    global _build, _built, _cold_here
    with _start_lock:
        if _built or _build is not None:
            return
        if _cores() < 2:  # no second process: finish() compiles here on a cold cache
            _cold_here = not _all_cached()
            _built = not _cold_here
            return
        try:
            build = _Build()
        except OSError:  # no second process: this one compiles everything, as without start()
            return
        if _all_cached():
            build.stop_giving()
            _built = True
            return
        build.give()
        _build = build
        atexit.register(_stop)


def _all_cached() -> bool:
    """Whether the disk cache holds every group (judged by its last function)."""
    return all(is_cached(*_signatures(group)[-1]) for group in GROUPS)


def compiling() -> bool:
    """Whether :func:`finish` will compile kernels: :func:`start` found the cache cold (and
    started a second process, on two cores or more). For a progress display that would
    otherwise stand still at 0 % while they compile."""
    return _build is not None or _cold_here


def _stop() -> None:
    """Stop a build nobody waited for (the run ended before it needed the kernels)."""
    if _build is not None:
        _build.stop()


def _command(*groups: str) -> list[str]:
    """The second process: this Python compiling ``groups`` (none: the groups named on its
    standard input, as :class:`_Build` says) of the tactile_bt this process runs (its
    directory first on the path: numba's cache is per source file, and ``python -m`` would put
    the working directory first, where another copy may be)."""
    root = str(Path(__file__).resolve().parents[2])
    code = ("import sys; sys.path.insert(0, sys.argv[1]); "
            "from tactile_bt.sim.warmup import _main; sys.exit(_main(sys.argv[2:]))")
    return [sys.executable, "-c", code, root, *groups]


def finish(idle: Callable[[], object] | None = None) -> None:
    """Compile groups here, taking them from the queue the second process (if :func:`start`
    started one) takes from too, until none is left; then wait for the second process's,
    calling ``idle`` first if it is still at work (say, to import what the run needs later),
    and build here any group it did not report.  On one core with a cold cache, compile every
    group here.  Without a started build: nothing (the first call compiles)."""
    global _build, _built, _cold_here
    with _start_lock:
        build, _build = _build, None
    if build is None:
        if _cold_here:  # one core, cold cache: the groups here, before the mission's clock starts
            for group in GROUPS:
                compile_group(group)
            _cold_here, _built = False, True
        return
    deadline = time.monotonic() + TIMEOUT_S
    try:
        while (group := build.take()) is not None:
            compile_group(group)
            build.mark(group)
        if idle is not None and not all(event.is_set() for event in build.done.values()):
            idle()
        build.end(deadline)
        for group in GROUPS:
            if group not in build.built:
                compile_group(group)
                build.mark(group)
        _built = True
    finally:
        build.stop()


def _main(argv: list[str]) -> int:
    if argv:
        for group in argv:
            compile_group(group)
            print(group, flush=True)
        return 0
    # Serving: the names go back on their own pipe; the rest of standard output to stderr.
    report = os.fdopen(os.dup(sys.stdout.fileno()), "w")
    sys.stdout.flush()
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    for line in sys.stdin:
        group = line.strip()
        compile_group(group)
        report.write(group + "\n")
        report.flush()
    os._exit(0)  # the cache files are written: skip the interpreter's teardown (0.3-0.5 s)


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
