"""``rinscal.parallel.read_ahead``, ``one_behind`` and ``in_background``: a file's next run
read, the last written, a compiled kernel loaded, on threads of their own while this one is
worked on (issue 39): in order, one ahead (behind) at most, errors where they belong."""

from __future__ import annotations

import threading
import time

import pytest

from rinscal.errors import ConfigError
from rinscal.parallel import in_background, one_behind, read_ahead


def test_items_come_in_order_taken_on_another_thread_one_ahead() -> None:
    taken: list[tuple[int, int]] = []  # (item, thread)

    def source():
        for k in range(5):
            taken.append((k, threading.get_ident()))
            yield k

    it = read_ahead(source(), 2)
    time.sleep(0.05)
    assert [k for k, _ in taken] == [0]  # the first is taken at once, before it is asked for
    got = []
    for k in it:
        time.sleep(0.02)  # the caller works on k: k + 1 is taken meanwhile, not k + 2
        assert [v for v, _ in taken][-1] <= k + 1
        got.append(k)
    assert got == [0, 1, 2, 3, 4]
    assert {th for _, th in taken} != {threading.get_ident()}


def test_an_error_is_raised_when_its_item_is_asked_for() -> None:
    def source():
        yield 1
        yield 2
        raise ValueError("run 3 is unreadable")

    it = read_ahead(source(), 2)
    assert next(it) == 1
    assert next(it) == 2
    with pytest.raises(ValueError, match="run 3"):
        next(it)


def test_closing_early_stops_taking_items() -> None:
    taken = []

    def source():
        for k in range(100):
            taken.append(k)
            yield k

    it = read_ahead(source(), 2)
    assert next(it) == 0
    it.close()  # type: ignore[attr-defined]
    time.sleep(0.05)
    assert taken == [0, 1]  # the one in flight, nothing after


def test_one_behind_writes_in_order_on_another_thread_one_at_a_time() -> None:
    written: list[tuple[int, int]] = []
    busy = threading.Lock()

    def write(k: int) -> None:
        assert busy.acquire(blocking=False), "two writes at once"
        time.sleep(0.01)
        written.append((k, threading.get_ident()))
        busy.release()

    with one_behind(write) as put:
        for k in range(6):
            put(k)
            assert len(written) >= k - 1  # at most the call just made is in flight
    assert [k for k, _ in written] == list(range(6))  # the last one waited for on leaving
    assert {th for _, th in written} != {threading.get_ident()}


def test_one_behind_raises_a_write_s_error() -> None:
    def write(k: int) -> None:
        if k == 1:
            raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"), one_behind(write) as put:
        put(0)
        put(1)
        put(2)  # waits for the failed call: its error is raised here
    with pytest.raises(OSError, match="disk full"), one_behind(write) as put:
        put(1)  # the last call: its error is raised on leaving


def test_threads_are_bounded_by_the_memory_of_the_items_in_flight() -> None:
    from rinscal.parallel import MEMORY_BUDGET, available_cores, jobs_within

    assert jobs_within(8, MEMORY_BUDGET / 4) == 4  # four such items fill the budget
    assert jobs_within(2, MEMORY_BUDGET / 4) == 2  # fewer asked: as asked
    assert jobs_within(8, 10 * MEMORY_BUDGET) == 1  # one at least, however large
    assert jobs_within(None, 1.0) == available_cores()
    assert jobs_within(8, 1e6, budget=3e6) == 3


def test_read_ahead_takes_as_many_items_ahead_as_asked() -> None:
    taken: list[int] = []

    def source():
        for k in range(8):
            taken.append(k)
            yield k

    it = read_ahead(source(), 2, ahead=3)
    deadline = time.monotonic() + 10
    while len(taken) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.05)
    assert taken == [0, 1, 2]  # three taken before the first is asked for, no more
    got = []
    for k in it:
        time.sleep(0.02)  # the caller works on k: up to k + 3 is taken meanwhile, no more
        assert taken[-1] <= k + 3
        got.append(k)
    assert got == list(range(8))
    with pytest.raises(ConfigError, match="ahead"):
        read_ahead(source(), 2, ahead=0)


def test_in_background_starts_at_once_on_another_thread_and_gives_its_result() -> None:
    started = threading.Event()
    where: list[int] = []

    def load() -> int:
        where.append(threading.get_ident())
        started.set()
        return 42

    wait = in_background(load, n_jobs=2)
    assert started.wait(5.0)  # begun before anyone asks for it
    assert wait() == 42
    assert wait() == 42  # asked again: the same result, not run again
    assert len(where) == 1 and where[0] != threading.get_ident()


def test_in_background_raises_its_error_when_waited_for() -> None:
    def boom() -> None:
        raise ValueError("no kernel")

    wait = in_background(boom, n_jobs=2)
    with pytest.raises(ValueError, match="no kernel"):
        wait()


def test_in_background_on_one_thread_runs_when_first_asked_for() -> None:
    calls: list[int] = []

    def load() -> int:
        calls.append(threading.get_ident())
        return 7

    wait = in_background(load, n_jobs=1)
    assert calls == []
    assert wait() == 7 and wait() == 7
    assert calls == [threading.get_ident()]
