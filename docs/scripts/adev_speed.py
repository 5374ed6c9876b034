"""Speed of rinscal's overlapping Allan deviation against ``allantools.oadev``.

Run from the repository root with the test extra installed (allantools is its oracle)::

    python docs/scripts/adev_speed.py [--samples N] [--repeats R]

One channel of white noise plus a random walk at 100 Hz (default 2**22 samples, 11.7 h),
octave and decade averaging times; each function is timed in this process
(``time.perf_counter``), ``R`` times after one warm-up call, and the median is printed,
with the largest relative difference of the two curves. :func:`allan_deviation` also
checks its input for gaps and computes IEEE 952 confidences, so it does a little more work
than ``oadev``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import allantools
import numpy as np

from rinscal.calibration.allan import allan_deviation

RATE_HZ = 100.0


def _median_s(fn: Callable[[], object], repeats: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2**22, help="series length")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls of each")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.samples
    y = 1.0e3 + rng.normal(0.0, 3.0, n) + np.cumsum(rng.normal(0.0, 0.01, n))
    print(f"{n} samples at {RATE_HZ:g} Hz, median of {args.repeats} calls")
    print("taus    rinscal [s]  allantools [s]  ratio  max rel. difference")
    for taus in ("octave", "decade"):
        curve = allan_deviation(y, RATE_HZ, taus=taus)
        _, dev, _, _ = allantools.oadev(y, rate=RATE_HZ, data_type="freq", taus=curve.tau_s)
        diff = float(np.max(np.abs(curve.adev / dev - 1.0)))
        ours = _median_s(lambda taus=taus: allan_deviation(y, RATE_HZ, taus=taus), args.repeats)
        theirs = _median_s(
            lambda c=curve: allantools.oadev(y, rate=RATE_HZ, data_type="freq", taus=c.tau_s),
            args.repeats,
        )
        print(f"{taus:7s} {ours:11.3f}  {theirs:14.3f}  {ours / theirs:5.2f}  {diff:.1e}")


if __name__ == "__main__":
    main()
