"""The field filter on the simulator's own parked cold starts (issue 38's bias recovery):
the thermal plant with every effect, written and read back as a user's recording, against
its truth file's total equivalent error on the static base (``static_*``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import rinscal
from rinscal.io.navopen import open_nav_log
from rinscal.nav.fieldbias import BiasSeries, estimate_bias_series
from rinscal.nav.fieldcal import calibrate_field, field_noise_of
from rinscal.schema import CHANNELS

HORIZONTAL = [0, 1, 3, 4]


def _z(s: BiasSeries, truth: pd.DataFrame, column: str = "static") -> np.ndarray:
    """|estimate − truth| / sd on the dwell epochs after the first rotation period."""
    tt = truth["time_s"].to_numpy()
    idx = np.searchsorted(tt, s.t)
    ok = (idx < tt.size) & (s.t >= s.first_period_s) & (s.table_rate == 0)
    table = np.unwrap(np.deg2rad(truth["table_deg"].to_numpy()))
    still = np.abs(np.gradient(table, tt)) < 1e-6
    ok[ok] &= still[idx[ok]]
    want = truth[[f"{column}_{c}" for c in CHANNELS]].to_numpy()[idx[ok]]
    return np.abs(s.bias[ok] - want) / s.sd[ok]


def _truth(path: Path) -> pd.DataFrame:
    return pd.read_parquet(path.with_name(path.name.replace(".parquet", ".truth.parquet")))


def test_a_cold_and_a_hot_start_of_the_plant(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Two 1 h starts at 0 and 42 °C (20 Hz): the horizontal channels within 2 sd of the
    equivalent error on ≥ 90 % of the dwell epochs after the first period (measured 0.88-1.0
    per start and channel, 0.94-0.99 pooled); the z gyro's scale factor against the table
    rate found; and the horizontal accelerometers' truth without −g k of the x and y gyros'
    table-rate misalignment (``error_*``) missed at 42 °C, where that k is large."""
    paths = rinscal.simulate_field_starts(
        tmp_path, runs=2, ambient_c=(0.0, 42.0), hours=1.0, rate_hz=20.0, seed=11
    )
    zs = []
    for p in paths:
        log = open_nav_log(p, None)
        s = estimate_bias_series(log.pieces(), site=log.site, noise=field_noise_of(p, log.noise))
        truth = _truth(p)
        zs.append(_z(s, truth))
        k_true = truth["rate_error_gyro_z"].to_numpy()[-1]
        assert abs(s.rate_error[-1, 2] - k_true) < 3 * s.rate_error_sd[-1, 2] + 2e-6
    z = np.concatenate(zs)
    within = np.mean(z <= 2, axis=0)
    assert np.all(within[HORIZONTAL] >= 0.9), within
    hot = open_nav_log(paths[1], None)
    s = estimate_bias_series(hot.pieces(), site=hot.site, noise=field_noise_of(paths[1], hot.noise))
    raw = np.mean(_z(s, _truth(paths[1]), "error") <= 2, axis=0)
    assert raw[3] < 0.5 or raw[4] < 0.5, raw


@pytest.mark.slow
def test_seven_parked_starts_at_table_3_ambients(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The issue's check: `paper`, 7 starts at 0, 7, … 42 °C, 4 h at 100 Hz, through
    `calibrate_field`: horizontal accelerometer and gyro series within 2 sd of the truth on
    ≥ 95 % of the dwell samples after the first rotation period (measured 1.000, 1.000,
    0.997, 0.999; 46 s of cpu for the 7 starts on one core)."""
    paths = rinscal.simulate_field_starts(tmp_path, runs=7, hours=4.0, rate_hz=100.0)
    fc = calibrate_field([str(p) for p in paths])
    z = np.concatenate([_z(fc.series[p.stem], _truth(p)) for p in paths])
    within = np.mean(z <= 2, axis=0)
    assert np.all(within[HORIZONTAL] >= 0.95), within
