"""``rinscal.parallel.read_ahead``: a stream one item ahead on a thread, in order, its errors
where they belong, and on the caller's thread with one job."""

import threading

import pytest

from rinscal.parallel import read_ahead


def _stream(n, seen, fail_at=None):  # type: ignore[no-untyped-def]
    for i in range(n):
        seen.append((i, threading.current_thread().name))
        if i == fail_at:
            raise ValueError(f"item {i}")
        yield i


def test_read_ahead_keeps_order_and_makes_the_next_item_on_a_thread_meanwhile():
    seen: list = []
    got, made_before_asked = [], []
    for x in read_ahead(_stream(5, seen), n_jobs=2):
        # the next item is being (or has been) made while this one is worked on
        threading.Event().wait(0.02)
        made_before_asked.append(len(seen) > x + 1)
        got.append(x)
    assert got == [0, 1, 2, 3, 4]
    assert all(made_before_asked[:-1])  # the last one has no next
    assert {name for _, name in seen} != {threading.current_thread().name}


def test_read_ahead_raises_the_streams_error_at_its_item():
    seen: list = []
    got = []
    with pytest.raises(ValueError, match="item 3"):
        for x in read_ahead(_stream(6, seen, fail_at=3), n_jobs=2):
            got.append(x)
    assert got == [0, 1, 2]


def test_read_ahead_with_one_job_stays_on_the_callers_thread():
    seen: list = []
    assert list(read_ahead(_stream(4, seen), n_jobs=1)) == [0, 1, 2, 3]
    assert {name for _, name in seen} == {threading.current_thread().name}


def test_read_ahead_of_an_empty_stream_and_a_consumer_that_stops_early():
    assert list(read_ahead(iter(()), n_jobs=2)) == []
    seen: list = []
    for x in read_ahead(_stream(100, seen), n_jobs=2):
        if x == 1:
            break
    assert len(seen) <= 3  # at most one item made beyond the last asked for
