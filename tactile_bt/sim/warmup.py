"""The first run after an install: the compiled kernels built on two cores.

numba compiles a kernel the first time it is called and keeps the machine code in its disk
cache (``cache=True``); every later run loads it.  Compiling the simulator's entry point
(:func:`tactile_bt.sim.kernels.pad_kernel`) compiles its whole call tree in one process, one
function after the other, and that is most of the first run's wall time.  The call tree splits
into parts that do not depend on each other: the arm's kernels (:mod:`tactile_bt.robot.kernels`:
resolved rates, one Newton step of the contact equilibrium) and the pad's contact model
(:mod:`tactile_bt.sim.kernels`); perception's (:mod:`tactile_bt.perception.kernels`) stand
alone.  :func:`start` compiles the arm's, then perception's, in a second process;
:func:`finish` compiles the pad's in this one, then, as soon as the second process has the
arm's, the entry point, whose callees load from numba's disk cache instead of compiling again.

The split is what makes this pay: the large functions (the pad's contact, the arm's Newton
step) are called, not inlined, by the entry point, so they are compiled once, in parallel, and
the entry point itself is small.  numba still links and optimises the whole call tree into the
entry point's machine code; that part stays serial.  ``tactile-bt bench`` reports the first
run's time.

Nothing changes in the compiled code: each function is compiled for the same argument types as
a mission calls it with, and the cache key is the same either way
(``tests/test_kernel_build.py`` checks that a mission compiles no other version).

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

from numba import types

__all__ = ["start", "finish", "compile_group", "is_cached", "GROUPS"]

_F1 = types.Array(types.float64, 1, "C")
_F2 = types.Array(types.float64, 2, "C")
_I1 = types.Array(types.int64, 1, "C")
_I2 = types.Array(types.int64, 2, "C")
_F = types.float64
_INT = types.int64
_MASK = types.Array(types.boolean, 2, "C")
# The work arrays of the arm's step (tactile_bt.robot.kernels.arm_work).
_ARM_WORK = types.Tuple((_F1, _F2, _F2, _F1, _F2, _F1, _F1, _F2, _F2, _F1, _F2, _F1, _F2, _F1, _F1, _F1, _F1))

#: The kernel parts :func:`compile_group` builds: the arm's, then perception's (in the second
#: process), and the pad's (in this one); the entry point, last, links the arm's and the pad's.
GROUPS = ("arm", "perception", "pad")
#: What the second process compiles, in this order.
AHEAD = ("arm", "perception")

#: Longest wait (s) for the second process; after it, this process compiles what is missing.
TIMEOUT_S = 300.0

_build: _Build | None = None


def _pad_kernel_signature() -> tuple:
    """The one signature :class:`tactile_bt.sim.pad.SensorModel` calls the entry point with."""
    return (_INT, _F2, _F2, _F2, _F2, _F1, _F2, _F1, _I2, _I1, _F1, _F1, _F1, _F1, _F2, _F2, _INT, _F2, _F1, _F,
            _F1, _F1, types.Array(types.uint16, 1, "C"), _F1, _F1, _F1, _F1)


def _signatures(group: str) -> list:
    """``(dispatcher, signature)`` of the functions of one group, callees before callers."""
    if group == "arm":
        from tactile_bt.robot import kernels as rk

        return [(rk.pose_jacobian, (_F1, _F1, _F2, _F2)),
                (rk.rates_fast, (_F1, _F1, _F1, _F1, _F, _F, _F, _F1)),
                (rk.arm_next, (_INT, _F1, _F1, _F1, _F1, _ARM_WORK))]
    if group == "perception":
        from tactile_bt.perception import kernels as pk

        return [(pk.largest_region, (_F2, _F, _F, _F2, _MASK, types.Array(types.int32, 1, "C"))),
                (pk.windowed_centroid, (_F2, _MASK, _F, _F, _F, _F))]
    if group == "pad":
        from tactile_bt.sim import kernels as sk

        data = types.Tuple((_F2, _F2, _F2, _F1, _F2, _F1, _I2, _I1, _F1, _F1, _F1, _F1, _F1))
        return [(sk.to_local, (_F2, _INT, _F2, _INT, _F2)),
                (sk.local_sdf, (_F2, _F1, _INT, _F2, _INT, _F1)),
                (sk.pad_contact, (_F2, data, _F1, _F2)),
                (sk._spread, (_F1, _F2, _F2, _INT, _INT, _INT)),
                (sk._raw, (_F1, _F2, _F1, _F, _F1, types.Array(types.uint16, 1, "C")))]
    if group == "entry":
        from tactile_bt.sim import kernels as sk

        return [(sk.pad_kernel, _pad_kernel_signature())]
    raise ValueError(f"unknown kernel group {group!r}; expected one of {GROUPS + ('entry',)}")


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
    """The second process, and which of its groups are done (it prints each one's name)."""

    def __init__(self, groups: tuple[str, ...]):
        self.process = subprocess.Popen(_command(*groups), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                        stderr=subprocess.DEVNULL, text=True)
        self.done = {group: threading.Event() for group in groups}
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:
            event = self.done.get(line.strip())
            if event is not None:
                event.set()
        for event in self.done.values():  # the process ended: nothing more to wait for
            event.set()

    def wait(self, group: str, deadline: float) -> None:
        """Until the process has compiled ``group`` (or ended, or ``deadline`` passed)."""
        self.done[group].wait(max(deadline - time.monotonic(), 0.0))

    def end(self, deadline: float) -> None:
        """Until the process ends; killed at ``deadline``."""
        try:
            self.process.wait(timeout=max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            self.stop()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


def start() -> None:
    """On a cold cache, start compiling the arm's and perception's kernels in a second process
    (no-op when the entry point is cached, on one core, or when a build is already running)."""
    global _build
    if _build is not None or (os.cpu_count() or 1) < 2:
        return
    dispatcher, signature = _signatures("entry")[0]
    if is_cached(dispatcher, signature):
        return
    try:
        _build = _Build(AHEAD)
    except OSError:  # no second process: this one compiles everything, as without start()
        _build = None
    else:
        atexit.register(_stop)


def _stop() -> None:
    """Stop a build nobody waited for (the run ended before it needed the kernels)."""
    if _build is not None:
        _build.stop()


def _command(*groups: str) -> list[str]:
    """The second process: this Python compiling ``groups`` of the tactile_bt this process runs
    (its directory first on the path: numba's cache is per source file, and ``python -m`` would
    put the working directory first, where another copy may be)."""
    root = str(Path(__file__).resolve().parents[2])
    code = ("import sys; sys.path.insert(0, sys.argv[1]); "
            "from tactile_bt.sim.warmup import _main; sys.exit(_main(sys.argv[2:]))")
    return [sys.executable, "-c", code, root, *groups]


def finish() -> None:
    """Compile the pad's kernels here while the second process (if :func:`start` started one)
    compiles the arm's; once it has, compile the entry point (its callees load from the disk
    cache) while the second process goes on with perception's; then wait for it to end.
    Without a started build: nothing (the first call compiles)."""
    global _build
    build, _build = _build, None
    if build is None:
        return
    deadline = time.monotonic() + TIMEOUT_S
    compile_group("pad")
    build.wait("arm", deadline)
    compile_group("entry")
    build.end(deadline)


def _main(argv: list[str]) -> int:
    for group in argv:
        compile_group(group)
        print(group, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
