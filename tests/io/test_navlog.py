"""The recorded-navigation log reader (rinscal.io.navopen): files -> SI increments in frame r."""

from __future__ import annotations

import json
import math
from functools import reduce
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rinscal.errors import ConfigError, LogError
from rinscal.io.mapping import ColumnMapping, parse_weight, read_mapping
from rinscal.io.metadata import write_meta
from rinscal.io.navlog import Gap, NavLog
from rinscal.io.navopen import open_nav_log
from rinscal.io.track import read_track
from rinscal.schema import NAV_RATES, NavSamples
from rinscal.units import ARCSEC_TO_RAD, DEG_TO_RAD, DPH_TO_RPS, G0, UG_TO_MPS2

RATE = 200.0
N = 1200
W_GYRO = 0.1 * ARCSEC_TO_RAD  # rad per count
W_ACCEL = 125e-6 * G0  # m/s per count
DTHETA = ("dtheta_x", "dtheta_y", "dtheta_z")
DVEL = ("dvel_x", "dvel_y", "dvel_z")


def motion(n: int = N, seed: int = 3) -> dict[str, np.ndarray]:
    """Whole counts per interval (a turning, accelerating IMU), and their SI increments."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    cg = np.stack(
        [
            np.rint(2000 * np.sin(2 * np.pi * k / 400)) + rng.integers(-50, 50, n),
            rng.integers(-300, 300, n),
            np.full(n, 1500) + rng.integers(-5, 5, n),
        ],
        axis=1,
    ).astype(np.int64)
    ca = np.stack(
        [rng.integers(-40, 40, n), rng.integers(-40, 40, n), np.full(n, 392) + k % 3],
        axis=1,
    ).astype(np.int64)
    ticks = (k + 1) * 5000  # µs: 200 Hz, first sample at the end of the first interval
    return {
        "cg": cg,
        "ca": ca,
        "ticks": ticks,
        "t": ticks / 1e6,
        "dtheta": cg * W_GYRO,
        "dv": ca * W_ACCEL,
    }


def whole(log, **kw) -> NavSamples:
    """Every piece joined (the reader must give the same as one piece)."""
    ps = list(log.pieces(**kw))
    cat = {
        f: (None if getattr(ps[0], f) is None else np.concatenate([getattr(p, f) for p in ps]))
        for f in ("t", "dt", "dtheta", "dv", "table", "temps", "temp_out", "ref", "ref_heading")
    }
    return NavSamples(first_row=ps[0].first_row, **cat)


def rates_frame(m, unit_gyro: float, unit_accel: float) -> pd.DataFrame:
    dt = 1.0 / RATE
    df = pd.DataFrame({"time_s": m["t"]})
    for j, c in enumerate(NAV_RATES[:3]):
        df[c] = m["dtheta"][:, j] / dt / unit_gyro
    for j, c in enumerate(NAV_RATES[3:]):
        df[c] = m["dv"][:, j] / dt / unit_accel
    return df


def test_same_motion_as_rates_increments_and_counts(tmp_path: Path) -> None:
    m = motion()
    # 1: rates in the defaults (deg/h, µg), canonical names, no metadata
    a = tmp_path / "rates_dph.csv"
    rates_frame(m, DPH_TO_RPS, UG_TO_MPS2).assign(comment="x").to_csv(a, index=False)
    # 2: rates in rad/s and m/s², declared in the metadata
    b = tmp_path / "rates_si.csv"
    rates_frame(m, 1.0, 1.0).to_csv(b, index=False)
    write_meta({"units": {"gyro": "rad/s", "accel": "m/s^2"}, "rate_hz": RATE}, b)
    # 3: increments [rad, m/s], canonical
    c = tmp_path / "incr.parquet"
    df = pd.DataFrame({"time_s": m["t"]})
    for j in range(3):
        df[DTHETA[j]] = m["dtheta"][:, j]
        df[DVEL[j]] = m["dv"][:, j]
    df.to_parquet(c, index=False)
    # 4: integer counts with pulse weights, foreign names, µs time
    d = tmp_path / "counts.csv"
    raw = pd.DataFrame({"t_us": m["ticks"]})
    for j, ax in enumerate("xyz"):
        raw[f"g{ax}"] = m["cg"][:, j]
        raw[f"a{ax}"] = m["ca"][:, j]
    raw.to_csv(d, index=False)
    counts_map = ColumnMapping(
        columns={
            **{f"g{ax}": f"gyro_{ax}" for ax in "xyz"},
            **{f"a{ax}": f"accel_{ax}" for ax in "xyz"},
        },
        time="t_us",
        time_unit="us",
        weights={"gyro": "0.1 arcsec", "accel": "125 ug*s"},
    )
    logs = {
        "dph": open_nav_log(a),
        "si": open_nav_log(b),
        "incr": open_nav_log(c),
        "counts": open_nav_log(d, counts_map),
    }
    assert [lg.kind for lg in logs.values()] == ["rates", "rates", "increments", "counts"]
    assert logs["dph"].units["gyro_x"] == "deg/h" and logs["dph"].units["accel_z"] == "ug"
    assert logs["si"].units["gyro_y"] == "rad/s"
    got = {k: whole(lg) for k, lg in logs.items()}
    # counts times weights are the increments themselves (to the last bit or two)
    np.testing.assert_allclose(got["counts"].dtheta, m["dtheta"], rtol=1e-15, atol=0)
    np.testing.assert_allclose(got["counts"].dv, m["dv"], rtol=1e-15, atol=0)
    np.testing.assert_array_equal(got["incr"].dtheta, m["dtheta"])
    for k in ("dph", "si"):  # rate · dt gives the increments back to ~1e-12
        np.testing.assert_allclose(got[k].dtheta, m["dtheta"], rtol=1e-12, atol=1e-20)
        np.testing.assert_allclose(got[k].dv, m["dv"], rtol=1e-12, atol=1e-20)
    for s in got.values():
        np.testing.assert_allclose(s.t, m["t"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(s.dt, 1 / RATE, rtol=1e-9)  # first one: the nominal
        assert s.first_row == 1
    # the wrong unit gives a different answer: the units are really used
    wrong = open_nav_log(b, ColumnMapping(units={"gyro": "deg/s"}))
    assert not np.allclose(whole(wrong).dtheta, m["dtheta"])


def test_front_right_down_file_equals_right_forward_up(tmp_path: Path) -> None:
    m = motion(300)
    rfu = pd.DataFrame({"time_s": m["t"]})
    frd = pd.DataFrame({"time_s": m["t"]})
    temps = np.array([20.0, 21.0, 22.0, 30.0, 31.0, 32.0])  # per channel, r frame
    for j, ax in enumerate("xyz"):
        rfu[f"dtheta_{ax}"] = m["dtheta"][:, j]
        rfu[f"dvel_{ax}"] = m["dv"][:, j]
        rfu[f"temp_gyro_{ax}"] = temps[j]
        rfu[f"temp_accel_{ax}"] = temps[3 + j]
    # FRD: x forward (our y), y right (our x), z down (minus our z)
    src = {"x": (1, 1.0), "y": (0, 1.0), "z": (2, -1.0)}
    for ax, (j, s) in src.items():
        frd[f"dth_{ax}"] = s * m["dtheta"][:, j]
        frd[f"dv_{ax}"] = s * m["dv"][:, j]
        frd[f"tg_{ax}"] = temps[j]
        frd[f"ta_{ax}"] = temps[3 + j]
    rfu.to_csv(tmp_path / "rfu.csv", index=False)
    frd.to_csv(tmp_path / "frd.csv", index=False)
    cols = {}
    for ax in "xyz":
        cols |= {f"dth_{ax}": f"dtheta_{ax}", f"dv_{ax}": f"dvel_{ax}"}
        cols |= {f"tg_{ax}": f"temp_gyro_{ax}", f"ta_{ax}": f"temp_accel_{ax}"}
    want = whole(open_nav_log(tmp_path / "rfu.csv"))
    got = whole(
        open_nav_log(tmp_path / "frd.csv", ColumnMapping(columns=cols, axes=("y", "x", "-z")))
    )
    np.testing.assert_array_equal(got.dtheta, want.dtheta)
    np.testing.assert_array_equal(got.dv, want.dv)
    np.testing.assert_array_equal(got.temps, want.temps)  # temperatures follow their sensor
    np.testing.assert_array_equal(want.temps[0], temps)
    plain = whole(open_nav_log(tmp_path / "frd.csv", ColumnMapping(columns=cols)))
    assert not np.array_equal(plain.dtheta, want.dtheta)
    with pytest.raises(ConfigError, match="axes"):
        ColumnMapping(axes=("y", "y", "-z"))
    with pytest.raises(ConfigError, match="axes"):
        ColumnMapping(axes=("y", "x", "w"))
    # one flip too few: a mirror, which no mounting of a real IMU gives
    with pytest.raises(ConfigError, match="left-handed one"):
        ColumnMapping(axes=("y", "x", "z"))
    ColumnMapping(axes=("-x", "-y", "z"))  # a half turn about z is a rotation: fine


def test_table_sign_zero_and_unit(tmp_path: Path) -> None:
    m = motion(8)
    raw = np.array([170.0, 179.5, -179.5, -170.0, 0.0, 90.0, 359.0, 12.5])
    df = pd.DataFrame({"time_s": m["t"], "enc": raw})
    for j in range(3):
        df[DTHETA[j]], df[DVEL[j]] = m["dtheta"][:, j], m["dv"][:, j]
    df.to_csv(tmp_path / "t.csv", index=False)
    mp = ColumnMapping(columns={"enc": "table_deg"}, table_sign=-1, table_zero_deg=12.5)
    got = whole(open_nav_log(tmp_path / "t.csv", mp)).table
    np.testing.assert_allclose(got, (-raw - 12.5) * DEG_TO_RAD, rtol=1e-15)
    df["enc"] = raw * DEG_TO_RAD
    df.to_csv(tmp_path / "r.csv", index=False)
    mp_rad = ColumnMapping(columns={"enc": "table_deg"}, table_unit="rad", table_zero_deg=12.5)
    got = whole(open_nav_log(tmp_path / "r.csv", mp_rad)).table
    np.testing.assert_allclose(got, (raw - 12.5) * DEG_TO_RAD, rtol=1e-14, atol=1e-15)
    canon = whole(open_nav_log(tmp_path / "t.csv", ColumnMapping(columns={"enc": "table_deg"})))
    np.testing.assert_allclose(canon.table, raw * DEG_TO_RAD)
    with pytest.raises(ConfigError, match="table_sign"):
        ColumnMapping(table_sign=2)
    df.loc[4, "enc"] = np.nan
    df.to_csv(tmp_path / "nan.csv", index=False)
    with pytest.raises(LogError, match=r"'table_deg' \(from 'enc'\), data row 5"):
        whole(open_nav_log(tmp_path / "nan.csv", mp_rad))


def test_gaps_reported_refused_and_allowed(tmp_path: Path) -> None:
    m = motion(400)
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2)
    keep = np.ones(400, bool)
    keep[100:103] = False  # 3 samples missing: reported, allowed (max 5)
    keep[250:260] = False  # 10 missing: refused unless allow_gaps
    df = df[keep].reset_index(drop=True)
    path = tmp_path / "gaps.csv"
    df.to_csv(path, index=False)
    log = open_nav_log(path)
    with pytest.raises(LogError) as err:
        whole(log)
    msg = str(err.value)
    row = 1 + int(np.flatnonzero(df["time_s"].to_numpy() > m["t"][259])[0])
    assert f"data row {row}" in msg and "allow_gaps=True" in msg and "10 samples" in msg
    assert f"{m['t'][260]:.10g} s" in msg
    assert [(g.row, g.missing_samples) for g in log.gaps] == [(101, 3), (row, 10)]
    assert isinstance(log, NavLog) and all(isinstance(g, Gap) for g in log.gaps)
    assert log.gaps[0].time_s == pytest.approx(m["t"][103])  # the sample that ends the gap
    s = whole(log, allow_gaps=True)
    assert [g.missing_samples for g in log.gaps] == [3, 10]
    assert log.gaps[1].length_s == pytest.approx(11 / RATE)
    # rates are held over the gap: the increment is the rate times the whole interval
    np.testing.assert_allclose(s.dt[100], 4 / RATE)
    np.testing.assert_allclose(s.dtheta[100], m["dtheta"][103] * 4, rtol=1e-12)
    s = whole(log, max_gap_samples=10)
    assert len(log.gaps) == 2  # emptied and filled again
    with pytest.raises(LogError, match="data row 101"):
        whole(log, max_gap_samples=2)


def test_time_not_increasing_names_the_row_across_pieces(tmp_path: Path) -> None:
    m = motion(50)
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2)
    df.loc[20, "time_s"] = df.loc[19, "time_s"]  # row 21 repeats row 20's time
    df.to_csv(tmp_path / "t.csv", index=False)
    for rows in (1000, 20, 7):  # inside a piece and on a piece boundary (rows 20|21)
        with pytest.raises(LogError, match=r"'time_s', data row 21: time not strictly"):
            whole(open_nav_log(tmp_path / "t.csv"), piece_rows=rows)


def test_nan_in_gyro_names_file_column_and_row(tmp_path: Path) -> None:
    m = motion(30)
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2).rename(columns={"gyro_y": "Gy"})
    df.loc[16, "Gy"] = np.nan
    path = tmp_path / "nan.csv"
    df.to_csv(path, index=False)
    with pytest.raises(LogError) as err:
        whole(open_nav_log(path, ColumnMapping(columns={"Gy": "gyro_y"})), piece_rows=8)
    assert str(path) in str(err.value)
    assert "'gyro_y' (from 'Gy'), data row 17: missing value" in str(err.value)
    df.loc[16, "Gy"] = 1.0
    df.loc[9, "time_s"] = np.inf
    df.to_csv(path, index=False)
    with pytest.raises(LogError, match=r"'time_s', data row 10: value inf; time must be finite"):
        whole(open_nav_log(path, ColumnMapping(columns={"Gy": "gyro_y"})))
    df.loc[9, "time_s"] = m["t"][9]
    df["temp_in"] = 20.0
    df.loc[3, "temp_in"] = np.nan  # a missing temperature passes (held by the navigator)
    df.to_csv(path, index=False)
    s = whole(open_nav_log(path, ColumnMapping(columns={"Gy": "gyro_y"})))
    assert np.isnan(s.temps[3]).all() and (s.temps[4] == 20.0).all()


def runs_frame(m, runs: list[str]) -> pd.DataFrame:
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2)
    df.insert(1, "run", runs)
    return df


def test_runs_refused_listed_chosen_and_contiguous(tmp_path: Path) -> None:
    m = motion(60)
    labels = ["a"] * 20 + ["b"] * 25 + ["c"] * 15
    df = runs_frame(m, labels)
    df.loc[20:44, "time_s"] -= df.loc[20, "time_s"]  # each run its own clock
    for suffix in ("csv", "parquet"):
        path = tmp_path / f"runs.{suffix}"
        df.to_csv(path, index=False) if suffix == "csv" else df.to_parquet(path, index=False)
        with pytest.raises(LogError, match=r"3 run\(s\): 'a', 'b', 'c'; choose one with run="):
            whole(open_nav_log(path), piece_rows=8)
        s = whole(open_nav_log(path, run="b"), piece_rows=8)
        assert s.first_row == 21 and s.n == 25
        np.testing.assert_allclose(s.dtheta, m["dtheta"][20:45], rtol=1e-12)
        assert s.dt[0] == pytest.approx(1 / RATE)  # the run's first sample: nominal interval
        with pytest.raises(LogError, match="no run 'z'"):
            whole(open_nav_log(path, ColumnMapping(select_run="z")))
    # 'a' resumes after 'b': refused at the row where it resumes
    bad = runs_frame(m, ["a"] * 20 + ["b"] * 25 + ["a"] * 15)
    bad.to_csv(tmp_path / "split.csv", index=False)
    for rows in (100, 8):
        with pytest.raises(LogError, match=r"data row 46: run 'a' resumes"):
            whole(open_nav_log(tmp_path / "split.csv", run="a"), piece_rows=rows)
    numbered = runs_frame(m, [7] * 20 + [8] * 40)  # run numbers, not names: chosen as text
    numbered.to_parquet(tmp_path / "num.parquet", index=False)
    assert whole(open_nav_log(tmp_path / "num.parquet", run="8")).first_row == 21
    one = runs_frame(m, ["only"] * 60)
    one.to_csv(tmp_path / "one.csv", index=False)
    assert whole(open_nav_log(tmp_path / "one.csv")).n == 60
    one.drop(columns="run").to_csv(tmp_path / "norun.csv", index=False)
    with pytest.raises(LogError, match="no 'run' column"):
        whole(open_nav_log(tmp_path / "norun.csv", run="only"))


def test_mixed_partial_and_fractional_counts_refused(tmp_path: Path) -> None:
    m = motion(20)
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2)
    df.assign(dtheta_x=0.0).to_csv(tmp_path / "mixed.csv", index=False)
    with pytest.raises(LogError, match=r"both rates .* and increments .*'dtheta_x'"):
        open_nav_log(tmp_path / "mixed.csv")
    df.drop(columns=["accel_y", "gyro_z"]).to_csv(tmp_path / "part.csv", index=False)
    with pytest.raises(LogError, match="but not 'gyro_z', 'accel_y': all six"):
        open_nav_log(tmp_path / "part.csv")
    df[["time_s"]].assign(other=1).to_csv(tmp_path / "none.csv", index=False)
    with pytest.raises(LogError, match="no IMU output columns"):
        open_nav_log(tmp_path / "none.csv")
    counts = pd.DataFrame({"time_s": m["t"]})
    for j, ax in enumerate("xyz"):
        counts[f"gyro_{ax}"] = m["cg"][:, j].astype(float)
        counts[f"accel_{ax}"] = m["ca"][:, j].astype(float)
    counts.loc[12, "accel_y"] += 0.25
    counts.to_csv(tmp_path / "frac.csv", index=False)
    mp = ColumnMapping(weights={"gyro": "0.1 arcsec", "accel": "125 ug*s"})
    with pytest.raises(
        LogError, match=r"'accel_y', data row 13: value -?\d+\.(25|75) is not a whole"
    ):
        whole(open_nav_log(tmp_path / "frac.csv", mp))
    with pytest.raises(ConfigError, match=r"weights\.gyro"):
        ColumnMapping(weights={"gyro": "0.1 furlong", "accel": "125 ug*s"})
    with pytest.raises(ConfigError, match="no weight for accel_x"):
        ColumnMapping(weights={"gyro": "0.1 arcsec"})
    with pytest.raises(ConfigError, match="units"):
        open_nav_log(_incr(tmp_path, m), ColumnMapping(units={"gyro": "rad/s"}))


def _incr(tmp_path: Path, m) -> Path:
    df = pd.DataFrame({"time_s": m["t"]})
    for j in range(3):
        df[DTHETA[j]], df[DVEL[j]] = m["dtheta"][:, j], m["dv"][:, j]
    path = tmp_path / "incr.csv"
    df.to_csv(path, index=False)
    return path


def test_pieces_are_bounded_and_join_to_the_whole(tmp_path: Path) -> None:
    m = motion(2500)  # more than the samples that fix the nominal interval
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2).assign(temp_in=25.0, temp_out=24.0)
    path = tmp_path / "p.parquet"
    df.to_parquet(path, index=False, row_group_size=300)
    log = open_nav_log(path)
    assert log.n_rows == 2500 and log.has_temps and log.has_temp_out and not log.has_table
    ref = whole(log, piece_rows=10**6)
    small = list(log.pieces(piece_rows=7))
    assert len(small) == math.ceil(2500 / 7) and max(p.n for p in small) == 7
    assert [p.first_row for p in small[:3]] == [1, 8, 15]
    joined = whole(log, piece_rows=7)
    for f in ("t", "dt", "dtheta", "dv", "temps", "temp_out"):
        np.testing.assert_array_equal(getattr(joined, f), getattr(ref, f))


def test_parquet_and_csv_give_identical_pieces(tmp_path: Path) -> None:
    m = motion(500)
    df = rates_frame(m, DPH_TO_RPS, UG_TO_MPS2)
    df["table_deg"] = np.linspace(-180, 180, 500)
    df[[f"temp_{c}" for c in NAV_RATES]] = np.linspace(10, 20, 6)
    df["ref_lat_deg"], df["ref_lon_deg"], df["ref_h_m"] = 45.5, 7.25, 300.0
    df["ref_heading_deg"] = 30.0
    df.to_csv(tmp_path / "a.csv", index=False)
    df.to_parquet(tmp_path / "a.parquet", index=False)
    a = list(open_nav_log(tmp_path / "a.csv").pieces(piece_rows=64))
    b = list(open_nav_log(tmp_path / "a.parquet").pieces(piece_rows=64))
    assert len(a) == len(b) == 8
    for pa_, pb in zip(a, b, strict=True):
        assert pa_.first_row == pb.first_row
        for f in ("t", "dt", "dtheta", "dv", "table", "temps", "ref", "ref_heading"):
            np.testing.assert_array_equal(getattr(pa_, f), getattr(pb, f))
    np.testing.assert_allclose(a[0].ref[0], [45.5 * DEG_TO_RAD, 7.25 * DEG_TO_RAD, 300.0])
    assert a[0].ref_heading[0] == pytest.approx(30 * DEG_TO_RAD)
    df.loc[70, "ref_lat_deg"] = 91.0
    df.to_parquet(tmp_path / "b.parquet", index=False)
    with pytest.raises(LogError, match=r"'ref_lat_deg', data row 71: latitude 91"):
        whole(open_nav_log(tmp_path / "b.parquet"), piece_rows=64)


def nmea(body: str) -> str:
    """A sentence with its checksum: XOR of the characters between '$' and '*'."""
    return f"${body}*{reduce(lambda x, c: x ^ ord(c), body, 0):02X}"


def gga(hhmmss: str, lat: str, ns: str, lon: str, ew: str, q: int, alt: float, sep: float) -> str:
    return nmea(f"GPGGA,{hhmmss},{lat},{ns},{lon},{ew},{q},08,0.9,{alt},M,{sep},M,,")


def test_nmea_gga_track_checksums_fix_and_midnight(tmp_path: Path) -> None:
    lines = [
        gga("235958.50", "4807.038", "N", "01131.000", "E", 1, 545.4, 46.9),
        nmea("GPRMC,235959,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W"),
        gga("235959.50", "4807.038", "N", "01131.000", "E", 0, 545.4, 46.9),  # no fix
        gga("235959.75", "4807.100", "N", "01131.000", "E", 1, 545.0, 46.9)[:-2] + "00",
        "garbage line",
        gga("000000.50", "4807.138", "S", "01131.500", "W", 2, 546.0, 46.9),
        gga("000001.50", "4807.238", "S", "01131.500", "W", 4, 547.0, -2.5),
    ]
    path = tmp_path / "gnss.nmea"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError, match="track_utc_start="):
        read_track(path)
    tr = read_track(path, utc_start="2024-03-09T23:59:58Z")
    np.testing.assert_allclose(tr.t, [0.5, 2.5, 3.5])  # across midnight
    assert tr.used == 3
    assert tr.skipped == {"checksum": 1, "no_fix": 1, "not_gga": 1, "unparsable": 1}
    lat0 = 48 + 7.038 / 60
    np.testing.assert_allclose(
        tr.lat, np.array([lat0, -(48 + 7.138 / 60), -(48 + 7.238 / 60)]) * DEG_TO_RAD, rtol=1e-12
    )
    np.testing.assert_allclose(tr.lon[1], -(11 + 31.5 / 60) * DEG_TO_RAD, rtol=1e-12)
    np.testing.assert_allclose(tr.h, [545.4 + 46.9, 546.0 + 46.9, 547.0 - 2.5])
    # content sniffed for an unknown suffix; the start given with an offset is converted
    other = tmp_path / "gnss.dat"
    other.write_text(path.read_text())
    tr2 = read_track(other, utc_start="2024-03-10T01:59:58+02:00")
    np.testing.assert_array_equal(tr2.t, tr.t)


def test_csv_track_and_bad_latitude(tmp_path: Path) -> None:
    df = pd.DataFrame(
        {"time_s": [0.0, 1.0, 2.0], "ref_lat_deg": [10.0, 10.1, 10.2],
         "ref_lon_deg": [-5.0, -5.0, -5.0], "ref_h_m": [1.0, 2.0, 3.0]}
    )  # fmt: skip
    df.to_csv(tmp_path / "tr.csv", index=False)
    tr = read_track(tmp_path / "tr.csv")
    np.testing.assert_allclose(tr.lat, np.deg2rad([10.0, 10.1, 10.2]))
    np.testing.assert_allclose(tr.h, [1, 2, 3])
    df.loc[2, "ref_lat_deg"] = -90.5
    df.to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(LogError, match=r"'ref_lat_deg', data row 3: latitude"):
        read_track(tmp_path / "bad.csv")
    df.loc[2, "ref_lat_deg"], df.loc[2, "time_s"] = 0.0, 1.0
    df.to_csv(tmp_path / "t.csv", index=False)
    with pytest.raises(LogError, match=r"data row 3: time not strictly"):
        read_track(tmp_path / "t.csv")


def test_metadata_site_heading_noise_units(tmp_path: Path) -> None:
    m = motion(20)
    path = tmp_path / "log.csv"
    rates_frame(m, 1.0, UG_TO_MPS2).to_csv(path, index=False)
    meta = {
        "units": {"gyro_x": "rad/s", "gyro_y": "rad/s", "gyro_z": "rad/s"},
        "site": {"lat_deg": 45.0, "lon_deg": -73.5, "h_m": 120.0},
        "heading_deg": 91.5,
        "noise": {"gyro_noise_density": 1e-6, "accel_noise_density": 2e-4},
        "utc_start": "2024-03-09T23:59:58Z",
        "rate_hz": RATE,
    }
    write_meta(meta, path)
    log = open_nav_log(path)
    assert log.site == pytest.approx((math.radians(45.0), math.radians(-73.5), 120.0))
    assert log.heading_deg == 91.5 and log.rate_hz == RATE
    assert log.noise == {"gyro_noise_density": 1e-6, "accel_noise_density": 2e-4}
    assert log.utc_start.isoformat() == "2024-03-09T23:59:58+00:00"
    assert log.units["gyro_z"] == "rad/s" and log.units["accel_x"] == "ug"  # default kept
    np.testing.assert_allclose(whole(log).dtheta, m["dtheta"], rtol=1e-12)
    meta["site"]["lat_deg"] = 95.0
    (tmp_path / "log.csv.meta.json").write_text(json.dumps(meta))
    with pytest.raises(LogError, match=r"site\.lat_deg"):
        open_nav_log(path)
    meta["site"]["lat_deg"] = 45.0
    meta["units"]["gyro_x"] = "pulse"
    (tmp_path / "log.csv.meta.json").write_text(json.dumps(meta))
    with pytest.raises(LogError, match="weights"):
        open_nav_log(path)


DOC_MAPPING = """
separator = "comma"
time = "t_us"
time_unit = "us"
temperature = "imu_temp"
axes = ["y", "x", "-z"]
table_sign = -1
table_zero_deg = 12.5

[columns]
cnt_gx = "gyro_x"
cnt_gy = "gyro_y"
cnt_gz = "gyro_z"
cnt_ax = "accel_x"
cnt_ay = "accel_y"
cnt_az = "accel_z"
encoder = "table_deg"

[weights]
gyro = "0.1 arcsec"
accel = "125 ug*s"
"""


def test_toml_mapping_of_the_docs_reads_an_frd_counts_log(tmp_path: Path) -> None:
    (tmp_path / "map.toml").write_text(DOC_MAPPING)
    mp = read_mapping(tmp_path / "map.toml", "navigation")
    m = motion(100)
    raw = pd.DataFrame({"t_us": m["ticks"], "imu_temp": 31.5, "encoder": 12.5})
    frd = {"x": (1, 1), "y": (0, 1), "z": (2, -1)}  # file axis -> (our axis, sign)
    for ax, (j, s) in frd.items():
        raw[f"cnt_g{ax}"] = s * m["cg"][:, j]
        raw[f"cnt_a{ax}"] = s * m["ca"][:, j]
    raw.to_csv(tmp_path / "frd.csv", index=False)
    s = whole(open_nav_log(tmp_path / "frd.csv", mp))
    np.testing.assert_allclose(s.dtheta, m["dtheta"], rtol=1e-15, atol=0)
    np.testing.assert_allclose(s.dv, m["dv"], rtol=1e-15, atol=0)
    np.testing.assert_allclose(s.table, -25.0 * DEG_TO_RAD)
    assert (s.temps == 31.5).all()
    assert parse_weight("0.1 arcsec", "gyro") == pytest.approx(W_GYRO, rel=1e-15)
    assert parse_weight("125 ug*s", "accel") == pytest.approx(W_ACCEL, rel=1e-15)
    (tmp_path / "bad.toml").write_text(DOC_MAPPING.replace("table_sign", "table_sgn"))
    with pytest.raises(ConfigError, match=r"bad\.toml: unknown key\(s\) table_sgn"):
        read_mapping(tmp_path / "bad.toml", "navigation")
    (tmp_path / "w.toml").write_text(DOC_MAPPING.replace('"125 ug*s"', '"125 deg"'))
    with pytest.raises(ConfigError, match=r"w\.toml: weights\.accel"):
        read_mapping(tmp_path / "w.toml", "navigation")
    with pytest.raises(LogError, match=r"'cnt_gx'.* named in the mapping are not in the file"):
        open_nav_log(_incr(tmp_path, m), mp)
