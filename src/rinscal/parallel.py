"""In-process parallelism of one command: independent pieces of work (channels, runs,
navigation variants) spread over the machine's cores on threads.

The work that runs on the threads releases the GIL (numpy's linear algebra, numba kernels
compiled ``nogil``, pyarrow's readers), so threads share one copy of the data and cost no
pickling. Fan-outs across processes or machines (studies, fleets) use Dask instead
(:mod:`rinscal.cluster`); this module is for the pieces of one command.

Results come back in the order of the inputs whatever the number of threads, so a command's
output does not depend on ``n_jobs``.
"""

from __future__ import annotations

import math
import os
import threading
from collections import deque
from collections.abc import Callable, Hashable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from types import TracebackType
from typing import Any, TypeVar

from rinscal.errors import ConfigError

T = TypeVar("T")
R = TypeVar("R")


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity; ``os.cpu_count()`` where the platform
    has none)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def resolve_jobs(n_jobs: int | None) -> int:
    """Threads to use for ``n_jobs``: None or 0 means every available core; a positive
    number is taken as given. A negative number is refused (ConfigError naming ``n_jobs``)."""
    if n_jobs is None or n_jobs == 0:
        return available_cores()
    if not isinstance(n_jobs, int) or isinstance(n_jobs, bool) or n_jobs < 0:
        raise ConfigError(
            f"n_jobs={n_jobs!r}: give a positive number of threads, or None/0 for every core"
        )
    return n_jobs


#: Memory the items in flight of one fan-out may hold together by default [bytes]
#: (:func:`jobs_within`).
MEMORY_BUDGET = 400 * 2**20


def jobs_within(n_jobs: int | None, each_bytes: float, budget: float = MEMORY_BUDGET) -> int:
    """Threads for work each item of which holds about ``each_bytes`` while it runs: ``n_jobs``
    (None or 0: every core), but no more than ``budget`` holds, and at least one.

    So that memory stays bounded however many cores the machine has (the result never
    depends on the number of threads).
    """
    return max(1, min(resolve_jobs(n_jobs), int(budget // max(float(each_bytes), 1.0))))


def map_jobs(fn: Callable[[T], R], items: Iterable[T], n_jobs: int | None = None) -> list[R]:
    """``[fn(x) for x in items]``, on up to ``n_jobs`` threads (None/0: every core).

    The list is in the order of ``items``; an exception in any call is raised here (the first
    in input order). One thread, or a single item, runs inline with no pool.
    """
    seq = list(items)
    n = min(resolve_jobs(n_jobs), len(seq))
    if n <= 1:
        return [fn(x) for x in seq]
    with ThreadPoolExecutor(max_workers=n, thread_name_prefix="rinscal") as pool:
        return list(pool.map(fn, seq))


def in_background(fn: Callable[[], T], n_jobs: int | None = None) -> Callable[[], T]:
    """Start ``fn()`` on a thread of its own now (compiled kernels loaded while a file is
    read); the function returned waits for it and returns its result, or raises its error,
    each time it is called.

    With ``n_jobs`` 1 (:func:`resolve_jobs`: None/0 every core) nothing starts: ``fn`` runs
    on the caller's thread when its result is first asked for.
    """
    if resolve_jobs(n_jobs) <= 1:
        done: list[T] = []

        def inline() -> T:
            if not done:
                done.append(fn())
            return done[0]

        return inline
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rinscal-load")
    future = pool.submit(fn)
    pool.shutdown(wait=False)  # the thread ends with ``fn``
    return future.result


_END = object()


def read_ahead(items: Iterable[T], n_jobs: int | None = None, ahead: int = 1) -> Iterator[T]:
    """The items of ``items`` in order, the next ``ahead`` taken on a thread of its own while
    the caller works on the current one (a file's next run read while this one is fitted, a
    recording's next pieces while this one is navigated: pyarrow's decoding and numpy release
    the GIL).

    The first items are taken at once, before the caller asks for them (it can prepare in the
    meantime). Holds at most ``1 + ahead`` items: the caller's and those taken ahead.
    ``items`` is never advanced by two threads at once; an error taking an item is raised
    when the caller asks for that item. Closing the iterator early waits for the item in
    flight, then drops it and those taken ahead. With ``n_jobs`` 1 (:func:`resolve_jobs`:
    None/0 every core) the items are taken on the caller's thread, as without this function.
    """
    it = iter(items)
    if resolve_jobs(n_jobs) <= 1:
        return it
    if ahead < 1:
        raise ConfigError(f"read_ahead: ahead must be at least 1 item, got {ahead}")
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rinscal-read")
    return _ahead(pool, deque(pool.submit(next, it, _END) for _ in range(ahead)), it)


def _ahead(pool: ThreadPoolExecutor, pending: deque[Any], it: Iterator[T]) -> Iterator[T]:
    try:
        while True:
            item = pending.popleft().result()
            if item is _END:
                return
            pending.append(pool.submit(next, it, _END))
            yield item
            del item  # not held while the next is taken
    finally:
        for later in list(pending)[1:]:  # the item in flight is taken, those behind it not
            later.cancel()
        pool.shutdown(wait=True)


@contextmanager
def one_behind(fn: Callable[[T], object]) -> Iterator[Callable[[T], None]]:
    """``put(item)`` calls ``fn(item)`` on a thread of its own while the caller goes on (a
    run written while the next is compensated), one call at a time, in order.

    At most one call in flight: ``put`` waits for the previous call first, and raises its
    error. Leaving the context waits for the last call (and raises its error); leaving it
    on an error waits for the call in flight and drops what it returns.
    """
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rinscal-write")
    pending: Any = None

    def put(item: T) -> None:
        nonlocal pending
        if pending is not None:
            pending.result()
        pending = pool.submit(fn, item)

    try:
        yield put
        if pending is not None:
            pending.result()
    finally:
        pool.shutdown(wait=True)


class Lanes:
    """Tasks in lanes on up to ``n_jobs`` threads (None/0: every core): the tasks of one lane
    run one at a time, in the order they are given (a navigation variant's pieces: its state
    goes from one to the next), those of different lanes side by side. Each task is given
    with the number of its batch (a piece, numbered in order); :meth:`wait` waits for the
    batches up to one. Unlike a :func:`map_jobs` per batch, a thread that has finished its
    lane's task of this batch takes another lane's task of the next instead of waiting for
    the slowest lane: the caller bounds how many batches are in flight with :meth:`wait`.

    An error in a task: the tasks not yet started are dropped, the running ones finish, and
    :meth:`put`, :meth:`wait` or leaving the context raise the error of the first task given
    that failed. With one thread every task runs when it is given, on the caller's thread
    (its error raised there). Use as a context manager (leaving it waits for every task).
    """

    def __init__(self, n_jobs: int | None = None) -> None:
        jobs = resolve_jobs(n_jobs)
        self._inline = jobs <= 1
        self._pool = (
            None if self._inline else ThreadPoolExecutor(jobs, thread_name_prefix="rinscal")
        )
        self._cond = threading.Condition()
        self._busy: set[Hashable] = set()  # lanes with a task running or submitted
        self._queued: dict[Hashable, deque[tuple[int, int, Callable[[], object]]]] = {}
        self._left: dict[int, int] = {}  # batch -> its tasks not finished
        self._errors: list[tuple[int, BaseException]] = []  # (order given, error)
        self._given = 0

    def put(self, lane: Hashable, batch: int, fn: Callable[[], object]) -> None:
        """Run ``fn()`` after the lane's tasks given before, as part of batch ``batch`` (batch
        numbers do not decrease from one call to the next)."""
        if self._inline:
            fn()
            return
        with self._cond:
            if self._errors:
                self._raise_locked()
            order = self._given
            self._given += 1
            self._left[batch] = self._left.get(batch, 0) + 1
            if lane in self._busy:
                self._queued.setdefault(lane, deque()).append((order, batch, fn))
                return
            self._busy.add(lane)
        assert self._pool is not None
        self._pool.submit(self._run, lane, order, batch, fn)

    def wait(self, batch: float = math.inf) -> None:
        """Wait until every task of the batches up to ``batch`` has finished (default: all);
        raise the first error."""
        if self._inline:
            return
        with self._cond:
            while not self._errors and self._left and min(self._left) <= batch:
                self._cond.wait()
            if self._errors:
                self._raise_locked()

    def _raise_locked(self) -> None:
        while self._left:  # the running tasks finish, the others are dropped
            self._cond.wait()
        raise min(self._errors, key=lambda e: e[0])[1]

    def _run(self, lane: Hashable, order: int, batch: int, fn: Callable[[], object]) -> None:
        error = None
        if not self._errors:
            try:
                fn()
            except BaseException as exc:  # raised in the caller's thread
                error = exc
        with self._cond:
            if error is not None:
                self._errors.append((order, error))
            self._left[batch] -= 1
            if not self._left[batch]:
                del self._left[batch]
            queue = self._queued.get(lane)
            nxt = queue.popleft() if queue else None
            if nxt is None:
                self._busy.discard(lane)
            self._cond.notify_all()
        if nxt is not None:  # the lane's next task, behind the other lanes' given before it
            assert self._pool is not None
            self._pool.submit(self._run, lane, *nxt)

    def __enter__(self) -> Lanes:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            if kind is None:
                self.wait()
            elif not self._inline:  # the caller failed: drop what has not started
                with self._cond:
                    self._errors.append((-1, exc or RuntimeError("failed")))
                    while self._left:
                        self._cond.wait()
        finally:
            if self._pool is not None:
                self._pool.shutdown(wait=True)
