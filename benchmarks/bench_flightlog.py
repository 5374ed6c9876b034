"""Reading speed of PX4 ULog and ArduPilot DataFlash logs (issue 13), against their peers.

Write the two logs of docs/flightlogs.md (a one-hour, three-instance 1 kHz ULog, 1.0 GB; a
one-hour, three-IMU 400 Hz DataFlash log, 233 MB), then time each reader as a whole process,
paired with its peer::

    python benchmarks/bench_flightlog.py write /tmp/fl
    taskset -c 0 /usr/bin/time -v python benchmarks/bench_flightlog.py read /tmp/fl/ulog1h.ulg
    taskset -c 0 /usr/bin/time -v python benchmarks/bench_flightlog.py pyulog /tmp/fl/ulog1h.ulg
    taskset -c 0 /usr/bin/time -v rinscal plot /tmp/fl/ulog1h.ulg --out /tmp/fl/imus.png
    taskset -c 0 /usr/bin/time -v ulog2csv -m sensor_gyro,sensor_accel -o /tmp/fl/csv \
        /tmp/fl/ulog1h.ulg
    taskset -c 0 /usr/bin/time -v python benchmarks/bench_flightlog.py read /tmp/fl/df1h.bin
    taskset -c 0 /usr/bin/time -v python benchmarks/bench_flightlog.py pymavlink /tmp/fl/df1h.bin

each several times, rinscal and its peer in turn (A B A B), quoting medians.

``read`` is rinscal's reader (every instance into one canonical frame); ``pyulog`` is
pyulog's parse of the two topics; ``pymavlink`` is the message loop ArduPilot's
``tempcal_IMU.py`` reads a log with.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def write(folder: Path) -> None:
    """The one-hour logs: a slow warm-up per instance, white noise, float32 as logged."""
    from tests._flightlogs import DataFlashImu, px4_topics, write_dataflash, write_ulog

    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    topics, imus = [], []
    for rate, kind in ((1000, "ulog"), (400, "df")):
        n = 3600 * rate
        t = 1.0 + np.arange(n) / rate
        for k in range(3):
            temp = (25 + 20 * (1 - np.exp(-t / 900)) + k).astype(np.float32)
            gyro = (rng.normal(0, 0.01, (n, 3)) + 1e-4 * (temp[:, None] - 25)).astype(np.float32)
            accel = (rng.normal(0, 0.05, (n, 3)) + np.array([0, 0, -9.81])).astype(np.float32)
            if kind == "ulog":
                topics += px4_topics(t, gyro, accel, temp, k, 2424842 + k, 2424942 + k)
            else:
                imus.append(DataFlashImu(k, t, gyro, accel, temp))
    write_ulog(folder / "ulog1h.ulg", topics, {"TC_G_ENABLE": 0, "TC_A_ENABLE": 0})
    write_dataflash(folder / "df1h.bin", imus, {"INS_TCAL1_ENABLE": 0, "AHRS_ORIENTATION": 0})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["write", "read", "pyulog", "pymavlink"])
    ap.add_argument("path", type=Path)
    args = ap.parse_args()
    if args.what == "write":
        write(args.path)
    elif args.what == "read":
        from rinscal.io.flightinfo import FlightLogOptions
        from rinscal.io.flightlog import read_flight_log

        print(read_flight_log(args.path, FlightLogOptions(instance="all")).frame.shape)
    elif args.what == "pyulog":
        from pyulog import ULog

        ulog = ULog(str(args.path), message_name_filter_list=["sensor_gyro", "sensor_accel"])
        print(sum(len(d.data["timestamp"]) for d in ulog.data_list))
    else:
        from pymavlink import mavutil

        log = mavutil.mavlink_connection(str(args.path))
        rows: dict[int, list[tuple[float, ...]]] = {}
        while (msg := log.recv_match(type=["IMU", "PARM"])) is not None:
            if msg.get_type() == "IMU":
                rows.setdefault(msg.I, []).append(
                    (msg.TimeUS, msg.GyrX, msg.GyrY, msg.GyrZ, msg.AccX, msg.AccY, msg.AccZ, msg.T)
                )
        print({k: len(v) for k, v in rows.items()})


if __name__ == "__main__":
    main()
