"""The in-process thread fan-out: order kept, errors raised, n_jobs checked."""

import threading
import time

import numpy as np
import pytest

from rinscal.errors import ConfigError
from rinscal.parallel import available_cores, map_jobs, resolve_jobs


def test_resolve_jobs_default_is_every_core():
    assert resolve_jobs(None) == available_cores() >= 1
    assert resolve_jobs(0) == available_cores()
    assert resolve_jobs(3) == 3


@pytest.mark.parametrize("bad", [-1, 1.5, True])
def test_resolve_jobs_refuses_nonsense_naming_it(bad):
    with pytest.raises(ConfigError, match="n_jobs"):
        resolve_jobs(bad)


def test_map_jobs_keeps_input_order_when_later_items_finish_first():
    def slow_first(i):
        time.sleep(0.02 * (5 - i))
        return i * i

    assert map_jobs(slow_first, range(5), n_jobs=5) == [0, 1, 4, 9, 16]


def test_map_jobs_runs_on_several_threads_and_inline_for_one():
    seen = set()

    def who(_):
        seen.add(threading.get_ident())
        time.sleep(0.05)

    map_jobs(who, range(4), n_jobs=4)
    assert len(seen) > 1
    seen.clear()
    map_jobs(who, range(4), n_jobs=1)
    assert seen == {threading.get_ident()}


def test_map_jobs_results_bit_identical_to_serial():
    rng = np.random.default_rng(0)
    mats = [rng.standard_normal((200, 6)) for _ in range(8)]

    def qr_r(a):
        return np.linalg.qr(a, mode="r")

    one = map_jobs(qr_r, mats, n_jobs=1)
    many = map_jobs(qr_r, mats, n_jobs=4)
    assert all(np.array_equal(a, b) for a, b in zip(one, many, strict=True))


def test_map_jobs_raises_the_callers_error():
    def boom(i):
        if i == 2:
            raise ValueError("item 2")
        return i

    with pytest.raises(ValueError, match="item 2"):
        map_jobs(boom, range(4), n_jobs=2)
