"""Benchmark the recorded-navigation log reader (rinscal.io.navlog) on an 8 h, 200 Hz recording.

``--make FILE`` writes a 5.76 M-row Parquet log of rates (``time_s``, the six ``gyro_*`` /
``accel_*`` in deg/h and µg, ``table_deg``, ``temp_in``, ``temp_out``, a ``comment`` column
the reader must not read) in row groups of :data:`rinscal.io.streaming.PIECE_ROWS`, piece by
piece; ``--read FILE`` reads it with :meth:`rinscal.io.navlog.NavLog.pieces` and prints the
wall time, the samples read and the peak resident memory. Run the two as separate processes so that
the reading peak is the reader's own::

    taskset -c 0 python benchmarks/bench_navlog.py --make /tmp/nav8h.parquet
    taskset -c 0 /usr/bin/time -v python benchmarks/bench_navlog.py --read /tmp/nav8h.parquet

``--navigate FILE [--model M.json ...]`` times the stages of ``navigate --log`` in one
process on a recording written by ``rinscal navigate --scenario ... --record FILE`` (it has
the metadata): the first pass (reading and the per-second sums), the window, and the second
pass (reading, compensation, alignment and navigation of every variant)::

    rinscal navigate --scenario quasi-static --hours 8 --rate 200 --no-oracle --out sim \
                     --record /tmp/run8h.parquet
    taskset -c 0 python benchmarks/bench_navlog.py --navigate /tmp/run8h.parquet \
                     --model reg.json --model polyt.json

The figures of ``--read`` and ``--navigate`` are also appended to ``benchmarks/results.csv``
(:mod:`record`; ``--results FILE`` writes elsewhere): the reading, and each stage of the
navigation, as one kernel row each.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np

import record

RATE_HZ = 200.0
HOURS = 8.0


def make(path: str, rows: int) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from rinscal.io.streaming import PIECE_ROWS

    rng = np.random.default_rng(1)
    writer = None
    for a in range(0, rows, PIECE_ROWS):
        k = np.arange(a, min(a + PIECE_ROWS, rows))
        n = k.size
        t = (k + 1) / RATE_HZ
        cols = {"time_s": t}
        for j, ax in enumerate("xyz"):
            cols[f"gyro_{ax}"] = 10.0 * np.sin(t / (100 + j)) + rng.normal(0, 0.01, n)
        for j, ax in enumerate("xyz"):
            cols[f"accel_{ax}"] = (1e6 if ax == "z" else 0.0) + rng.normal(0, 20, n) + j
        cols["table_deg"] = ((t * 10.0 + 180.0) % 360.0) - 180.0
        cols["temp_in"] = 20.0 + 10.0 * (1 - np.exp(-t / 3600))
        cols["temp_out"] = cols["temp_in"] - 1.0
        cols["comment"] = np.full(n, "x", dtype=object)
        table = pa.table(cols)
        if writer is None:
            writer = pq.ParquetWriter(path, table.schema)
        writer.write_table(table, row_group_size=PIECE_ROWS)
    assert writer is not None
    writer.close()


def _record(
    results: Path | None, figures: list[tuple[str, float, float]], note: str, load_before: float
) -> None:
    """Append each (name, wall [s], process CPU [s]) as a kernel row, ``note`` on each."""
    if results is None:
        return
    rows = [
        record.kernel_row(
            name,
            record.script_command(sys.argv),
            [wall],
            cpus=[cpu],
            rss_mib=record.process_rss_mib(),
            load_before=load_before,
            load_after=record.load(),
            note=note,
        )
        for name, wall, cpu in figures
    ]
    record.append_rows(rows, results)


def read(path: str, results: Path | None = None) -> None:
    from rinscal.io.navopen import open_nav_log

    load0, c0 = record.load(), time.process_time()
    t0 = time.perf_counter()
    log = open_nav_log(path)
    n = 0
    acc = np.zeros(3)
    for piece in log.pieces():
        n += piece.n
        acc += piece.dtheta.sum(axis=0)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    print(
        f"read {n} samples ({log.kind}, table {log.has_table}, temps {log.has_temps}) in "
        f"{wall:.2f} s; peak RSS {peak:.2f} GB; gaps {len(log.gaps)}; sum dtheta {acc}"
    )
    _record(results, [("kernel: navlog read (pieces)", wall, cpu)], f"{n} samples", load0)


def navigate(path: str, models: list[str], results: Path | None = None) -> None:
    from rinscal.calibration.modelfile import ThermalModelFile
    from rinscal.io.navopen import open_nav_log
    from rinscal.nav.recorded.blocks import BlockStats
    from rinscal.nav.recorded.compensation import CausalModelCompensator
    from rinscal.nav.recorded.navigate import Reference, navigate_recording
    from rinscal.nav.recorded.window import Noise, align_config, find_window

    load0 = record.load()
    c0, t0 = time.process_time(), time.perf_counter()
    log = open_nav_log(path)
    st = BlockStats()
    for piece in log.pieces():
        st.add(piece)
    blocks = st.finish()
    c1, t1 = time.process_time(), time.perf_counter()
    win = find_window(blocks, 600.0)
    nz = log.noise or {}
    noise = Noise(nz["gyro_noise_density"], nz["accel_noise_density"])
    lat, lon, h = log.site  # type: ignore[misc]
    comps = {"none": None}
    for m in models:
        comps[m] = CausalModelCompensator(ThermalModelFile.load(m))  # type: ignore[assignment]
    c2, t2 = time.process_time(), time.perf_counter()
    res = navigate_recording(
        log.pieces(),
        Reference(lat, lon, h),
        win,
        align_config(noise, win),
        1.0 / (log.rate_hz or 1.0),
        comps,
    )
    c3, t3 = time.process_time(), time.perf_counter()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    worst = {k: round(float(v["horizontal_m"].max()) / 1852.0, 3) for k, v in res.errors.items()}
    print(
        f"first pass {t1 - t0:.2f} s, window + models {t2 - t1:.2f} s, second pass "
        f"{t3 - t2:.2f} s ({len(comps)} variants, {blocks.n.sum():.0f} samples); peak RSS "
        f"{peak:.2f} GB; max error [nmi] {worst}; window {win.start_s:g} s"
    )
    stages = [
        ("kernel: navlog first pass", t1 - t0, c1 - c0),
        ("kernel: navlog window + models", t2 - t1, c2 - c1),
        ("kernel: navlog second pass", t3 - t2, c3 - c2),
    ]
    _record(results, stages, f"{len(comps)} variants, {blocks.n.sum():.0f} samples", load0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--make", metavar="FILE")
    ap.add_argument("--read", metavar="FILE")
    ap.add_argument("--rows", type=int, default=int(HOURS * 3600 * RATE_HZ))
    ap.add_argument("--navigate", metavar="FILE")
    ap.add_argument("--model", action="append", default=[])
    ap.add_argument("--results", type=Path, default=record.RESULTS, help="results file")
    args = ap.parse_args()
    if args.read or args.navigate:
        record.read_rows(args.results)  # refuse a bad file before the timing
    if args.make:
        make(args.make, args.rows)
    if args.read:
        read(args.read, args.results)
    if args.navigate:
        navigate(args.navigate, args.model, args.results)


if __name__ == "__main__":
    main()
