"""Where the runs of a study execute: in this process, on a local Dask cluster, or on a running
Dask cluster (``--workers N`` / ``--scheduler ADDRESS`` of ``sweep``, ``paper`` and ``stability``).

* :class:`InProcess` (``--workers 1``): one run after the other in this process; no Dask needed.
* :class:`DaskExecutor` on a :class:`distributed.LocalCluster` of N worker processes with one
  thread each (``--workers N``), or on a running cluster (``--scheduler tcp://host:port``,
  started with ``dask scheduler`` and ``dask worker``). Dask is imported here only, and only
  for these.

Every executor runs a module-level function on picklable items and yields ``(index, value,
error)`` as runs finish. A worker that dies while running an item has it run again elsewhere
once (the scheduler's ``allowed-failures``, set to 1 for a local cluster; a running cluster
keeps its own setting, Dask's default being 3); a second death ends that item as a
``KilledWorker`` error. Missions in one process run one at a time (the behaviour trees share
py_trees' process-wide blackboard), so a worker started with several threads still computes
correctly: start workers with ``--nthreads 1`` and as many ``--nworkers`` as cores instead.

Layer: experiments.
"""

from __future__ import annotations

import os
import re
import threading
import uuid
from typing import Any, Callable, Iterable, Iterator, Sequence

from tactile_bt.errors import CommandLineError

__all__ = ["Executor", "InProcess", "DaskExecutor", "make_executor", "dask_available", "default_workers",
           "check_scheduler_address", "run_all", "LostRunError", "ALLOWED_FAILURES"]

#: Times a run is started again on another worker after its worker died (local clusters).
ALLOWED_FAILURES = 1
#: Seconds to wait for a running scheduler to answer.
CONNECT_TIMEOUT_S = 10.0

_ADDRESS = re.compile(r"^(?:(tcp|tls|inproc|ucx|ws|wss)://)?[^\s/:]+(?::\d{1,5})?(?:/[^\s]*)?$")


class LostRunError(RuntimeError):
    """A run that ended without a result: the cluster cancelled it (the scheduler went away)."""


def dask_available() -> bool:
    """Whether ``dask.distributed`` can be imported (the ``cluster`` extra)."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def default_workers() -> int:
    """The machine's cores available to this process."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def check_scheduler_address(text: str) -> str:
    """``text`` if it looks like a Dask scheduler address (``tcp://host:port``), else a
    :class:`CommandLineError` naming the option."""
    if not _ADDRESS.match(text.strip()):
        raise CommandLineError(f"--scheduler {text!r}: expected a Dask scheduler address such as "
                               "tcp://127.0.0.1:8786")
    return text.strip()


# --------------------------------------------------------------------------- one at a time
_ONE_AT_A_TIME = threading.Lock()


def _exclusive(fn: Callable[[Any], Any], item: Any) -> Any:
    """``fn(item)`` while no other run of this process is running (one blackboard per process)."""
    with _ONE_AT_A_TIME:
        return fn(item)


def dask_setup(worker=None) -> None:
    """Dask preload hook of the local cluster's worker processes: they ignore Ctrl-C, which a
    terminal sends to every process of the command; the command then closes the cluster."""
    import signal

    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread of a process
        pass


# --------------------------------------------------------------------------- executors
class Executor:
    """Runs ``fn(item)`` for every item; see :meth:`run`. Use as a context manager."""

    #: What the executor is, for messages (``"this process"``, ``"2 local Dask workers"``).
    label = ""
    #: Runs that can go on at once.
    workers = 1

    def run(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> Iterator[tuple[int, Any, BaseException | None]]:
        """Yield ``(index, fn(items[index]), None)`` as runs finish, or ``(index, None, exc)``
        for a run that raised (or whose worker died twice). A run the cluster lost without a
        result (the scheduler went away) yields a :class:`LostRunError`. Leaving the loop early
        (Ctrl-C) cancels the runs not finished."""
        raise NotImplementedError

    def close(self) -> None:
        pass

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class InProcess(Executor):
    """One run after the other in this process (``--workers 1``); Dask is not needed."""

    label = "this process"
    workers = 1

    def run(self, fn, items):
        for index, item in enumerate(items):
            try:
                value = fn(item)
            except Exception as exc:  # the caller decides: a row with the message, or raise
                yield index, None, exc
            else:
                yield index, value, None


class DaskExecutor(Executor):
    """Runs on a Dask cluster: a new :class:`distributed.LocalCluster` of ``workers`` processes
    (one thread each, on 127.0.0.1, no dashboard), or the running cluster at ``address``, or an
    existing :class:`distributed.Client` (``client``, which is left open)."""

    def __init__(self, workers: int | None = None, address: str | None = None, client=None,
                 processes: bool = True) -> None:
        import logging

        import dask
        from distributed import Client, LocalCluster

        self._cluster = None
        self._own_client = client is None
        self._quieted: dict[str, int] = {}
        if client is not None:
            self.client = client
        elif address is not None:
            try:
                self.client = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
            except (OSError, TimeoutError, ValueError) as exc:
                raise CommandLineError(f"--scheduler {address}: cannot connect to a Dask scheduler there "
                                       f"({type(exc).__name__}: {exc})") from None
        else:
            n = int(workers or default_workers())
            # Worker processes ignore Ctrl-C (see dask_setup): this process stops them.
            preload = {"preload": [__name__]} if processes else {}
            with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}):
                self._cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes, **preload,
                                             host="127.0.0.1" if processes else None, dashboard_address=None,
                                             silence_logs=logging.ERROR,
                                             scheduler_kwargs={"allowed_failures": ALLOWED_FAILURES,
                                                               "dashboard": False,  # its HTTP server: any
                                                               "dashboard_address": "127.0.0.1:0"})  # free port
            self.client = Client(self._cluster, set_as_default=False)
        # Faults (a lost scheduler, a dead worker) come back as results and end in one line or an
        # error row; Dask's own logging of them would print tracebacks in this process.
        if self._own_client:
            self._quieted = {name: logging.getLogger(name).level for name in ("distributed", "distributed.client")}
        for name in self._quieted:
            logging.getLogger(name).setLevel(logging.CRITICAL)
        info = self.client.scheduler_info()
        threads = sum(w.get("nthreads", 1) for w in info.get("workers", {}).values())
        processes_n = len(info.get("workers", {}))
        self.workers = max(1, processes_n)
        if self._cluster is not None:
            self.label = f"{processes_n} local Dask worker{'s' if processes_n != 1 else ''}"
        else:
            self.label = (f"the Dask cluster at {self.client.scheduler.address} ({processes_n} worker"
                          f"{'s' if processes_n != 1 else ''}, {threads} thread{'s' if threads != 1 else ''})")
            if not processes_n:
                self.label += "; the runs wait for a worker to join"

    def run(self, fn, items):
        from concurrent.futures import CancelledError

        from distributed import as_completed

        if not items:
            return
        batch = uuid.uuid4().hex[:8]
        name = getattr(fn, "__name__", "run")
        futures = [self.client.submit(_exclusive, fn, item, key=f"{name}-{batch}-{i}", pure=False, retries=0)
                   for i, item in enumerate(items)]
        index = {f.key: i for i, f in enumerate(futures)}
        pending = set(futures)
        try:
            for future in as_completed(futures, loop=self.client.loop):
                pending.discard(future)
                i = index[future.key]
                if future.status == "finished":
                    yield i, future.result(), None
                elif future.status == "cancelled":
                    yield i, None, LostRunError("the cluster cancelled the run (did the scheduler stop?)")
                else:
                    try:
                        exc = future.exception()
                    except CancelledError:
                        exc = LostRunError("the cluster cancelled the run (did the scheduler stop?)")
                    yield i, None, exc
                future.release()
        finally:
            if pending:
                try:
                    self.client.cancel(list(pending))
                except Exception:  # the connection is gone: nothing left to cancel
                    pass

    def close(self) -> None:
        import logging

        try:
            if self._own_client:
                try:
                    self.client.close()
                finally:
                    if self._cluster is not None:
                        self._cluster.close()
                        self._cluster = None
        finally:
            for name, level in self._quieted.items():
                logging.getLogger(name).setLevel(level)
            self._quieted = {}


def make_executor(workers: int | None = None, scheduler: str | None = None,
                  note: Callable[[str], None] | None = None) -> Executor:
    """The executor of ``--workers`` / ``--scheduler``.

    ``workers`` 1 runs in this process; more starts a local Dask cluster; ``None`` means one
    worker per core, in this process (with a ``note``) when Dask is not installed. ``scheduler``
    connects to a running cluster. An explicit request that needs Dask without it installed is a
    :class:`CommandLineError`.
    """
    if workers is not None and scheduler is not None:
        raise CommandLineError("--workers and --scheduler exclude each other: --scheduler uses the cluster's workers")
    if scheduler is not None:
        check_scheduler_address(scheduler)
        _require_dask("--scheduler")
        return DaskExecutor(address=scheduler)
    explicit = workers is not None
    n = int(workers) if explicit else default_workers()
    if n < 1:
        raise CommandLineError(f"--workers {n}: expected an integer >= 1")
    if n == 1:
        return InProcess()
    if not dask_available():
        if explicit:
            _require_dask(f"--workers {n}")
        if note is not None:
            note("dask is not installed: the runs go one after the other in this process "
                 "(pip install '.[cluster]' for one worker per core)")
        return InProcess()
    return DaskExecutor(workers=n)


def _require_dask(option: str) -> None:
    if not dask_available():
        raise CommandLineError(f"{option} needs Dask: pip install '.[cluster]' (or 'dask[distributed]'), "
                               "or use --workers 1")


def run_all(fn: Callable[[Any], Any], items: Iterable[Any], executor: Executor | None = None,
            progress: Callable[[int, int], None] | None = None) -> list:
    """``[fn(item) for item in items]`` on ``executor`` (default: this process), in the items'
    order; the first error is raised once every run has ended. ``progress(done, total)`` is
    called as runs finish."""
    items = list(items)
    executor = executor or InProcess()
    results: list = [None] * len(items)
    first_error = None
    done = 0
    for i, value, exc in executor.run(fn, items):
        done += 1
        if exc is not None and first_error is None:
            first_error = exc
        results[i] = value
        if progress is not None:
            progress(done, len(items))
    if first_error is not None:
        raise first_error
    return results
