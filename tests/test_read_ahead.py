"""``rinscal.parallel.read_ahead``: a file's next run read on a thread while this one is
worked on (issue 39): the items in order, one ahead at most, errors where they belong."""

from __future__ import annotations

import threading
import time

import pytest

from rinscal.parallel import read_ahead


def test_items_come_in_order_taken_on_another_thread_one_ahead() -> None:
    taken: list[tuple[int, int]] = []  # (item, thread)

    def source():
        for k in range(5):
            taken.append((k, threading.get_ident()))
            yield k

    it = read_ahead(source())
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

    it = read_ahead(source())
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

    it = read_ahead(source())
    assert next(it) == 0
    it.close()  # type: ignore[attr-defined]
    time.sleep(0.05)
    assert taken == [0, 1]  # the one in flight, nothing after
