"""``rinscal.parallel.Lanes``: each lane's tasks one at a time in the order given, the lanes
side by side, a thread done with its lane's task of one batch taking another lane's of the
next (no wait for the slowest), errors raised in the caller's thread, inline with one job."""

import threading
import time

import pytest

from rinscal.parallel import Lanes


def test_each_lane_runs_in_order_one_task_at_a_time():
    log: dict[str, list[int]] = {"a": [], "b": [], "c": []}
    running: dict[str, int] = {"a": 0, "b": 0, "c": 0}
    overlap = []
    lock = threading.Lock()

    def task(lane: str, batch: int) -> None:
        with lock:
            running[lane] += 1
            overlap.append(running[lane])
        time.sleep(0.002 * (1 + batch % 3))
        with lock:
            log[lane].append(batch)
            running[lane] -= 1

    with Lanes(2) as lanes:
        for batch in range(12):
            for lane in log:
                lanes.put(lane, batch, lambda lane=lane, batch=batch: task(lane, batch))
            lanes.wait(batch - 2)
    assert all(v == list(range(12)) for v in log.values())
    assert max(overlap) == 1  # never two tasks of one lane at once


def test_a_free_thread_takes_the_next_batch_before_the_slowest_lane_ends():
    started: list[tuple[str, int]] = []
    slow_done = threading.Event()

    def task(lane: str, batch: int) -> None:
        started.append((lane, batch))
        if (lane, batch) == ("slow", 0):
            time.sleep(0.3)
            slow_done.set()

    with Lanes(2) as lanes:
        lanes.put("slow", 0, lambda: task("slow", 0))
        lanes.put("fast", 0, lambda: task("fast", 0))
        lanes.put("fast", 1, lambda: task("fast", 1))
        time.sleep(0.1)
        # batch 1 of the fast lane ran while batch 0 of the slow one still runs
        assert ("fast", 1) in started and not slow_done.is_set()
        lanes.wait(0)
        assert slow_done.is_set()


def test_wait_waits_for_the_batches_up_to_the_one_named():
    done: list[int] = []
    gate = threading.Event()

    def task(batch: int) -> None:
        if batch == 1:
            gate.wait(5)
        done.append(batch)

    with Lanes(3) as lanes:
        lanes.put("a", 0, lambda: task(0))
        lanes.put("b", 1, lambda: task(1))
        lanes.wait(0)
        assert done == [0]
        gate.set()
        lanes.wait(1)
        assert sorted(done) == [0, 1]


def test_one_job_runs_each_task_when_given_on_the_callers_thread():
    seen: list[str] = []
    with Lanes(1) as lanes:
        for batch in range(3):
            lanes.put("a", batch, lambda: seen.append(threading.current_thread().name))
            assert len(seen) == batch + 1
    assert set(seen) == {threading.current_thread().name}


def test_the_first_error_given_is_raised_and_later_tasks_are_dropped():
    ran: list[int] = []

    def task(batch: int) -> None:
        if batch == 0:
            time.sleep(0.05)  # fails after batch 1 has
            raise ValueError("batch 0")
        if batch == 1:
            raise ValueError("batch 1")
        ran.append(batch)

    with pytest.raises(ValueError, match="batch 0"), Lanes(2) as lanes:
        lanes.put("a", 0, lambda: task(0))
        lanes.put("b", 1, lambda: task(1))
        lanes.put("a", 2, lambda: task(2))  # behind the failing one in its lane: dropped
        lanes.wait()
    assert ran == []


def test_an_error_in_the_caller_waits_for_the_running_tasks():
    finished = threading.Event()

    def task() -> None:
        time.sleep(0.1)
        finished.set()

    with pytest.raises(RuntimeError, match="caller"), Lanes(2) as lanes:
        lanes.put("a", 0, task)
        raise RuntimeError("caller")
    assert finished.is_set()  # the context left only once the running task had finished
