"""A pool of forked workers that loses only what dies.

``run_pool`` hands task indices to at most ``workers`` forked processes, started only as tasks need them (never
more than there are tasks), and calls ``on_done`` in this process as each task's result arrives, so the caller
stores finished work before anything else can fail. The rules:

* a worker that dies (``kill -9``, the OOM killer, a crash in native code) costs only the task it was running: that
  task becomes a ``LostTask`` naming how the worker ended, a new worker takes the remaining tasks, and every other
  result is delivered as usual (no ``BrokenProcessPool``);
* an exception raised by a task is raised here, after the finished results were delivered and every worker ended;
* workers ignore SIGINT (a Ctrl-C reaches the whole process group; this process decides) and are sent SIGTERM,
  then SIGKILL after ``STOP_GRACE_S``, when the pool ends for any reason (Ctrl-C, an error, SIGTERM turned into
  ``SystemExit``): no worker outlives the pool, a policy hanging in native code included;
* on Linux each worker asks the kernel to kill it when this process dies (``PR_SET_PDEATHSIG``), so even a
  ``kill -9`` of this process leaves no orphan spinning.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

STOP_GRACE_S = 2.0
"""How long a worker gets to end after SIGTERM before it is killed [s]."""
_PR_SET_PDEATHSIG = 1


@dataclass(frozen=True)
class LostTask:
    """A task whose worker died before returning its result (``reason``: how the worker ended)."""

    index: int
    reason: str

    def __post_init__(self) -> None:
        if self.index < 0:
            raise ValueError(f"index must be >= 0 (got {self.index})")


def exit_reason(exitcode: int | None) -> str:
    """How a worker process ended, for a person: ``killed by SIGKILL``, ``exited with status 3``."""
    if exitcode is None:
        return "ended without a result"
    if exitcode < 0:
        with contextlib.suppress(ValueError):
            return f"killed by {signal.Signals(-exitcode).name}"
        return f"killed by signal {-exitcode}"
    return f"exited with status {exitcode}"


def _die_with_parent() -> None:
    """Linux: have the kernel send SIGKILL to this process when its parent dies (best effort elsewhere)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL))


def _worker_main(conn: Connection, run: Callable[[int], Any], init: Callable[[], None], parent: int) -> None:
    """A worker: run each index received, send ``(index, ok, result or exception)``; ``None`` ends it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent()
    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(1)
    init()
    while True:
        index = conn.recv()
        if index is None:
            return
        try:
            message = (index, True, run(index))
        except Exception as exc:  # handed to the parent, which raises it
            message = (index, False, exc)
        try:
            conn.send(message)
        except Exception as exc:  # an unpicklable result or exception: say what it was
            conn.send((index, False, RuntimeError(f"task {index}: could not return its result: "
                                                  f"{type(exc).__name__}: {exc}"[:500])))


@dataclass
class _Worker:
    """One forked worker: its process, this end of its pipe and the task index it runs (None: idle)."""

    process: Any
    conn: Connection
    index: int | None = None


class _Pool:
    """The state of one ``run_pool`` call: its workers, the queue of task indices and the lost tasks."""

    def __init__(self, count: int, workers: int, run: Callable[[int], Any], init: Callable[[], None],
                 on_lost: Callable[[LostTask], None] | None = None) -> None:
        self.queue: deque[int] = deque(range(count))
        self.on_lost = on_lost
        self.limit = workers
        self.run, self.init = run, init
        self.workers: list[_Worker] = []
        self.lost: list[LostTask] = []
        self.context = multiprocessing.get_context("fork")

    def _start(self) -> _Worker:
        parent_end, child_end = self.context.Pipe()
        process = self.context.Process(target=_worker_main, args=(child_end, self.run, self.init, os.getpid()),
                                       daemon=True)
        process.start()
        child_end.close()
        worker = _Worker(process, parent_end)
        self.workers.append(worker)
        return worker

    def assign(self) -> None:
        """Give every idle worker a task; start workers while tasks wait and the limit allows."""
        for worker in [w for w in self.workers if w.index is None]:
            if self.queue:
                self._send(worker, self.queue.popleft())
        while self.queue and len(self.workers) < self.limit:
            self._send(self._start(), self.queue.popleft())

    def _send(self, worker: _Worker, index: int) -> None:
        """Hand ``index`` to ``worker``; a worker that died while idle is dropped and the task queued again."""
        try:
            worker.conn.send(index)
        except OSError:
            self.queue.appendleft(index)
            worker.process.join(STOP_GRACE_S)
            worker.conn.close()
            self.workers.remove(worker)
            return
        worker.index = index

    def collect(self, on_done: Callable[[int, Any], None]) -> None:
        """Wait for one or more workers to return a result or die; deliver or record each."""
        busy = [w for w in self.workers if w.index is not None]
        ready = set(wait([w.conn for w in busy] + [w.process.sentinel for w in busy]))
        for worker in busy:
            if worker.conn in ready or worker.process.sentinel in ready:
                self._take(worker, on_done)

    def _take(self, worker: _Worker, on_done: Callable[[int, Any], None]) -> None:
        index = worker.index
        assert index is not None
        try:
            got, ok, payload = worker.conn.recv() if worker.conn.poll() else (None, None, None)
        except (EOFError, OSError):
            got, ok, payload = None, None, None
        if got is None:  # died without a result: only its own task is lost
            worker.process.join(STOP_GRACE_S)
            self.lost.append(LostTask(index, exit_reason(worker.process.exitcode)))
            worker.conn.close()
            self.workers.remove(worker)
            if self.on_lost is not None:
                self.on_lost(self.lost[-1])
            return
        worker.index = None
        if not ok:
            raise payload
        on_done(index, payload)

    def stop(self) -> None:
        """End every worker: idle ones are told to stop, then SIGTERM, then SIGKILL after ``STOP_GRACE_S``."""
        for worker in self.workers:
            with contextlib.suppress(OSError, ValueError):
                if worker.index is None:
                    worker.conn.send(None)
                else:
                    worker.process.terminate()
        for worker in self.workers:
            worker.process.join(STOP_GRACE_S)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
            worker.conn.close()
        self.workers.clear()


def run_pool(count: int, workers: int, run: Callable[[int], Any], on_done: Callable[[int, Any], None],
             init: Callable[[], None] = lambda: None,
             on_lost: Callable[[LostTask], None] | None = None) -> list[LostTask]:
    """Run ``run(i)`` for ``i`` in ``range(count)`` on at most ``workers`` forked processes (``init()`` first in
    each); ``on_done(i, result)`` is called here as each result arrives, ``on_lost(task)`` as a worker is found
    dead (e.g. to count the task on a progress bar). Returns the tasks whose worker died.

    ``run`` and ``init`` are inherited by the fork (never pickled); results and exceptions are pickled back.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1 (got {workers!r})")
    pool = _Pool(count, workers, run, init, on_lost)
    try:
        while pool.queue or any(w.index is not None for w in pool.workers):
            pool.assign()
            pool.collect(on_done)
    finally:
        pool.stop()
    return sorted(pool.lost, key=lambda t: t.index)
