"""The robust limit of a statistic of motion (``rinscal.nav.recorded.motion``): set by the
quiet part of a recording, whatever the size of its disturbances."""

from __future__ import annotations

import math

import numpy as np

from rinscal.nav.recorded.motion import MOTION_K, robust_limit


def test_a_disturbance_of_any_size_leaves_the_limit_where_the_quiet_part_puts_it() -> None:
    rng = np.random.default_rng(7)
    quiet = 1.0 + 0.1 * rng.standard_normal(900)
    found = [robust_limit(np.concatenate([quiet, np.full(100, size)])) for size in (10, 1e3, 1e6)]
    assert found[0] == found[1]  # only the disturbance's rank counts, not its size
    # at 1e6 the level and scale still hold, but not the limit's count term: values under 1e-6
    # of the largest count as round-off, which drops the quiet values under 1 (limit 4.05)
    assert found[2][:2] == found[0][:2]
    c, s, limit = found[0]
    assert abs(c - 1.0) < 0.02 and abs(s - 0.1) < 0.02  # median and 1.4826 MAD of N(1, 0.1)
    # here 4 × the 10th percentile (4 × (1 - 1.2816 × 0.1) = 3.49) beats 3 c and c + K s
    assert c + MOTION_K * s < 3.0 * c < limit and abs(limit - 3.49) < 0.05


def test_a_coarse_count_and_the_floor_raise_the_limit() -> None:
    c, s, limit = robust_limit(np.array([1.0] * 90 + [100.0] * 10))
    assert (c, s, limit) == (1.0, 0.0, 4.0)  # median 1, MAD 0: 4 × the 10th percentile, 1
    assert robust_limit(np.array([1.0] * 90), floor=10.0)[2] == 10.0
    assert all(math.isnan(v) for v in robust_limit(np.array([np.nan, np.inf])))
