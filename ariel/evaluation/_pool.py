"""The ``local`` executor's process pool: one call per worker, survives workers that die or hang.

CPython's `concurrent.futures.ProcessPoolExecutor` breaks as a whole when one worker dies
(every pending future fails with ``BrokenProcessPool``), cannot tell which call killed it, and
cannot stop a call that hangs. This pool keeps, in one driver thread, which worker runs which
call and since when, so that:

- a worker that dies (a segfault, the OOM killer, a SIGKILL) costs only its own call, which
  runs again on a fresh worker, at most ``max_retries`` times; after that its future fails
  with `WorkerLostError`, naming how the process ended;
- a call given a ``timeout`` (``LocalPool.submit_with_timeout``) that has no result in time has
  its worker killed and replaced, and its future fails with `CallTimeoutError` (no retry: a call
  that hangs once would hang again).

Workers are started when work arrives and no worker is idle, up to ``max_workers``; each runs
one call at a time. Arguments and results travel pickled over a pipe per worker.

Workers die with the driver, however it ends (SIGKILL included): each holds the read end of a
"lifeline" pipe whose only write end the driver process holds, and a thread in the worker
waits on it; the kernel closes the write end when the driver dies, the wait returns, and the
worker exits at once, in the middle of a call if need be. (A parent-death signal would not do:
under forkserver the workers' parent is the fork server, not the driver.) Ctrl-C or SIGTERM in
the driver (a `KeyboardInterrupt` leaving the ``with`` block) kills the workers too, rather
than waiting for their calls, and starts no new ones.

The fork server dying (a SIGKILL, or SIGTERM to the whole process group) is not a worker dying:
the forkserver's workers look dead to `multiprocessing` (its sentinel is the pipe to the fork
server), but live on. The pool stops them (by a pidfd: never another process that reused the
pid) and runs their calls again, not counted as deaths; the next worker starts a new fork
server. A worker cannot be started even after a few tries: the pool breaks, every future fails
with ``BrokenProcessPool`` saying so. Nothing here prints a traceback: the driver thread's
failures go to the futures, and a worker whose driver closed its pipe exits quietly.

This module is the driver thread (`_Driver`); the pool's executor face, ``LocalPool``, is in
`ariel.evaluation._executor_local`, and a worker process's side in
`ariel.evaluation._pool_worker`.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.connection import Connection, wait as wait_for_ready

from ariel.errors import CallTimeoutError, WorkerLostError
from ariel.evaluation._pool_worker import (
    _BROKEN,
    _DONE,
    _RETIRING,
    _STARTED,
    _STOP,
    _Call,
    _ended_how,
    _one_line,
    _open_pidfd,
    _settle,
    _Worker,
    _worker_main,
    temporary_environ as temporary_environ,
)

__all__ = [
    "WORKER_CANNOT_START",
    "CallTimeoutError",
    "WorkerCannotStartError",
    "WorkerLostError",
    "temporary_environ",
]

# Time a call's timeout does not count: a fresh worker starting and importing what the call
# needs (unpickling it); a worker that takes longer than this as well is stopped too.
_START_SECONDS = 120.0
#: The longest one wait for news: a day (the deadlines may be further; the loop waits again).
DAY_S = 86_400.0
# `multiprocessing`'s exit code for a forkserver worker whose fork server died (not its own).
_FORKSERVER_GONE = 255
# A call whose fork server died this often while it ran counts such deaths as its own.
_MAX_ORPHANED = 3
# Pauses between tries to start a worker process (a fork server that just died is replaced).
_START_RETRY_SECONDS = (0.05, 0.5, 2.0)
#: Exit status of a worker that cannot start at all (EX_CONFIG), e.g. its re-import of the
#: driver's script refused to go on: the pool fails at once, no call is retried.
WORKER_CANNOT_START = 78


class WorkerCannotStartError(BrokenProcessPool):
    """The pool is broken because a worker exited with `WORKER_CANNOT_START` before its first
    call (it said why on its stderr, e.g. the script it re-imported lacks a ``__main__`` guard)."""


class _Driver:
    """State shared by the pool object and its driver thread (which holds no pool reference)."""

    def __init__(
        self,
        max_workers: int,
        context: multiprocessing.context.BaseContext,
        worker_env: Mapping[str, str],
        initializer: Callable[..., object] | None,
        initargs: tuple[object, ...],
        max_tasks_per_child: int | None,
        max_retries: int,
    ) -> None:
        self.max_workers = max_workers
        self.context = context
        self.worker_env = dict(worker_env)
        self.initializer = initializer
        self.initargs = initargs
        self.max_tasks = max_tasks_per_child
        self.max_retries = max_retries
        self.lock = threading.Lock()
        self.pending: deque[_Call] = deque()
        self.workers: list[_Worker] = []
        self.shutting_down = False
        self.killing = False  # stopped by a KeyboardInterrupt: no new worker, no retry
        self.broken: str | None = None
        self.broken_error: type[BrokenProcessPool] = BrokenProcessPool  # raised while broken
        self._wake_reader, self._wake_writer = multiprocessing.Pipe(duplex=False)
        self._lifeline, self._lifeline_end = context.Pipe(duplex=False)
        self._woken = False
        self.thread = threading.Thread(target=self.run, name="ariel-local-pool", daemon=True)

    # -- called from any thread ----------------------------------------------------------------

    def wake(self) -> None:
        with self.lock:
            if self._woken:
                return
            self._woken = True
        with contextlib.suppress(OSError):
            self._wake_writer.send_bytes(b"!")

    def stop(self, *, cancel: bool, kill: bool, wait: bool) -> None:
        retries: list[_Call] = []
        with self.lock:
            self.shutting_down = True
            if cancel or kill:  # calls waiting for their first worker; a retry goes on ...
                for call in self.pending:
                    if not call.running:
                        call.future.cancel()
                self.pending = deque(call for call in self.pending if call.running)
            if kill:  # ... unless the pool is killed: then no worker is started any more
                self.killing = True
                retries, self.pending = list(self.pending), deque()
                for worker in self.workers:
                    worker.killed = "closed"
                    with contextlib.suppress(Exception):
                        worker.process.kill()
        for call in retries:  # outside the lock: the futures' callbacks may submit
            if not call.future.done():
                call.future.set_exception(BrokenProcessPool("the pool was closed during the call"))
        self.wake()
        if wait and self.thread.is_alive() and threading.current_thread() is not self.thread:
            self.thread.join()

    # -- the driver thread -----------------------------------------------------------------------

    def run(self) -> None:
        try:
            while self._step():
                pass
        except BaseException as exc:  # a bug here must not leave futures waiting forever
            # Not raised again: the futures carry it (as their cause); a thread's traceback
            # would only come on top of the one line that the caller makes of them.
            self._fail_everything(f"the pool's driver thread failed: {exc!r}", cause=exc)
        finally:
            self._close_workers()

    def _step(self) -> bool:
        """One round: hand out work, wait for news, handle it. False: the pool is done."""
        self._dispatch()
        with self.lock:
            busy = any(w.call is not None for w in self.workers)
            if self.shutting_down and not self.pending and not busy:
                return False
        deadlines = [w.deadline for w in self.workers if w.deadline is not None]
        # Woken at least daily: k long timeouts added up overflowed the wait's millisecond int.
        timeout = min(max(0.0, min(deadlines) - time.monotonic()), DAY_S) if deadlines else None
        waitables: list[Connection | int] = [self._wake_reader]
        for worker in self.workers:
            waitables += [worker.conn, worker.process.sentinel]
        ready = set(wait_for_ready(waitables, timeout))
        if self._wake_reader in ready:
            with self.lock:
                while self._wake_reader.poll():
                    self._wake_reader.recv_bytes()
                self._woken = False
        finished: list[tuple[_Call, bytes]] = []
        for worker in list(self.workers):
            # A closed pipe, or a process that ended (after its last message was read).
            closed = worker.conn in ready and not self._read(worker, finished)
            if closed or worker.process.sentinel in ready:
                self._lost(worker)
        if finished:
            self._dispatch()  # idle workers first, then the results
            for call, data in finished:
                _settle(call, data)
        now = time.monotonic()
        for worker in list(self.workers):
            if worker.call is not None and worker.deadline is not None and worker.deadline <= now:
                self._time_out(worker)
        return True

    def _dispatch(self) -> None:
        while True:
            with self.lock:
                if not self.pending or self.broken is not None or self.killing:
                    return
                idle = [w for w in self.workers if w.call is None and not w.retiring]
                if not idle and len(self.workers) >= self.max_workers:
                    return
                call = self.pending.popleft()
            if not call.running:
                if not call.future.set_running_or_notify_cancel():
                    continue  # cancelled while it waited
                call.running = True
            try:
                worker = idle[0] if idle else self._start_worker()
            except Exception as exc:  # e.g. no more processes: the pool fails, with this call
                with self.lock:
                    self.pending.appendleft(call)
                self._fail_everything(
                    f"a worker process could not be started: {_one_line(exc)}", cause=exc
                )
                return
            except BaseException:
                with self.lock:
                    self.pending.appendleft(call)
                raise
            if self.killing:  # killed while the worker started: `_requeue` fails the call
                self._requeue(call)
                return
            try:
                worker.conn.send_bytes(call.payload)
            except OSError:  # the worker died while idle: the call never reached it
                self._requeue(call)
                self._lost(worker)
                continue
            worker.call = call
            if call.timeout is not None:  # the clock starts once the call is unpickled
                worker.deadline = time.monotonic() + _START_SECONDS + call.timeout

    def _start_worker(self) -> _Worker:
        """A new worker process; tried again a few times when starting it fails for a reason
        that may pass (an OS error, e.g. the fork server died just now: the next try starts
        a new one)."""
        for pause in _START_RETRY_SECONDS:
            try:
                return self._try_start_worker()
            except (OSError, EOFError):
                time.sleep(pause)
        return self._try_start_worker()

    def _try_start_worker(self) -> _Worker:
        mine, theirs = self.context.Pipe(duplex=True)
        method = self.context.get_start_method()
        forked = method == "fork"
        process = self.context.Process(
            target=_worker_main,
            args=(
                theirs,
                self.initializer,
                self.initargs,
                self.max_tasks,
                self._lifeline,
                self._lifeline_end if forked else None,
            ),
            name="ariel-local-worker",
        )
        # The thread limits must be in the environment the process starts with: BLAS reads them
        # when numpy is first imported, which spawn/forkserver may do before the initializer.
        try:
            with temporary_environ(self.worker_env):
                process.start()
        except BaseException:
            mine.close()
            raise
        finally:
            theirs.close()
        pidfd = _open_pidfd(process.pid) if method == "forkserver" else None
        worker = _Worker(process, mine, pidfd=pidfd)
        with self.lock:
            self.workers.append(worker)
            if self.killing:  # the pool was killed while this one started
                worker.killed = "closed"
                with contextlib.suppress(Exception):
                    process.kill()
        return worker

    def _read(self, worker: _Worker, finished: list[tuple[_Call, bytes]]) -> bool:
        """Take every message the worker has sent; False when its pipe is closed.

        Finished calls go to ``finished`` with their pickled outcome, which the caller unpickles
        after handing out new work (so that the worker does not wait for that).
        """
        try:
            while worker.conn.poll():
                data = worker.conn.recv_bytes()
                worker.spoke = True
                tag = data[:1]
                if tag == _STARTED:
                    call = worker.call
                    if call is not None and call.timeout is not None:
                        worker.deadline = time.monotonic() + call.timeout
                elif tag in (_DONE, _RETIRING):
                    call, worker.call, worker.deadline = worker.call, None, None
                    worker.retiring = tag == _RETIRING
                    if call is not None:
                        finished.append((call, data[1:]))
                elif tag == _BROKEN:
                    last = data[1:].decode(errors="replace").strip().splitlines()[-1]
                    self._fail_everything(f"a worker's initializer failed: {last}")
                    return False
        except (EOFError, OSError):
            return False
        return True

    def _lost(self, worker: _Worker) -> None:
        """A worker process ended (or its pipe broke, or its fork server died): retry or fail
        its call; forget it."""
        with contextlib.suppress(Exception):
            if worker.process.is_alive():
                worker.process.kill()
        worker.process.join(timeout=10)
        orphaned = self._stop_orphan(worker)
        with self.lock:
            if worker in self.workers:
                self.workers.remove(worker)
        worker.conn.close()
        if not worker.spoke and worker.process.exitcode == WORKER_CANNOT_START:
            self._fail_everything(
                f"a worker process could not start (exit code {WORKER_CANNOT_START}; its "
                "stderr says why)",
                WorkerCannotStartError,
            )
            return
        call, worker.call = worker.call, None
        if call is None or worker.killed == "timeout":  # `_time_out` fails the future
            return
        if worker.killed:
            if not call.future.done():
                call.future.set_exception(BrokenProcessPool("the pool was closed during the call"))
            return
        if orphaned and call.orphaned < _MAX_ORPHANED:  # not the call's fault: not a death
            call.orphaned += 1
            self._requeue(call)
            return
        call.deaths += 1
        how = _ended_how(worker.process.exitcode)
        if call.deaths > self.max_retries:
            times = "once" if call.deaths == 1 else f"{call.deaths} times"
            call.future.set_exception(
                WorkerLostError(f"worker process died {times} running this call (last: {how})")
            )
            return
        self._requeue(call)  # next in line, on a fresh worker

    def _requeue(self, call: _Call) -> None:
        """Put a call back at the head of the line, or fail it when the pool is being killed
        (a killed pool starts no worker, so a call left in line would wait forever)."""
        with self.lock:
            if not self.killing:
                self.pending.appendleft(call)
                return
        if not call.future.done():
            call.future.set_exception(BrokenProcessPool("the pool was closed during the call"))

    @staticmethod
    def _stop_orphan(worker: _Worker) -> bool:
        """Whether the worker lives on although its fork server died (see the module
        docstring); if so, stop it. Closes the worker's pidfd."""
        pidfd, worker.pidfd = worker.pidfd, None
        if pidfd is None:
            return False
        try:
            if worker.process.exitcode != _FORKSERVER_GONE:
                return False
            signal.pidfd_send_signal(pidfd, signal.SIGKILL)
        except OSError:  # it has ended (ProcessLookupError), or no pidfd_send_signal
            return False
        finally:
            os.close(pidfd)
        return True

    def _time_out(self, worker: _Worker) -> None:
        call = worker.call
        assert call is not None and call.timeout is not None
        worker.killed = "timeout"
        with contextlib.suppress(Exception):
            worker.process.kill()
        self._lost(worker)
        call.future.set_exception(
            CallTimeoutError(f"no result after {call.timeout:g} s; the worker was stopped")
        )

    def _fail_everything(
        self,
        reason: str,
        error: type[BrokenProcessPool] = BrokenProcessPool,
        *,
        cause: BaseException | None = None,
    ) -> None:
        with self.lock:
            self.broken, self.broken_error = reason, error
            calls = list(self.pending) + [w.call for w in self.workers if w.call is not None]
            self.pending.clear()
            for worker in self.workers:
                worker.call, worker.killed = None, "closed"
            self.shutting_down = True
        for call in calls:
            if not call.running and not call.future.set_running_or_notify_cancel():
                continue  # cancelled
            if not call.future.done():
                failure = error(reason)
                failure.__cause__ = cause
                call.future.set_exception(failure)

    def _close_workers(self) -> None:
        with self.lock:
            workers = list(self.workers)
            self.workers.clear()
        for worker in workers:
            with contextlib.suppress(OSError):
                worker.conn.send_bytes(_STOP)
        for worker in workers:
            worker.process.join(timeout=5)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
            self._stop_orphan(worker)
            worker.conn.close()
        self._wake_reader.close()
        self._lifeline.close()
        self._lifeline_end.close()
