"""Guards on training data: each bad log gets a clear message naming the file, column, why.

A meaningless model is refused (ConfigError), a weak one is fitted with a
TrainingDataWarning; the inputs are built by hand so the cause is known.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.thermal.guards import (
    TrainingDataWarning,
    check_design,
    design_condition,
    temperature_resolution,
)
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.errors import ConfigError, LogError
from rinscal.io.tables import read_log
from rinscal.schema import CHANNELS

META = {"units": {"gyro": "deg/h", "accel": "ug"}}


def _log(runs: int = 4, n: int = 1500, seed: int = 0, **kw) -> pd.DataFrame:
    """Soak-like cold starts at several set points: output = cubic in T + Ṫ term + noise."""
    rng = np.random.default_rng(seed)
    frames = []
    for k in range(runs):
        t = (np.arange(n) + 1.0) * 2.0
        sp = 5.0 + 10.0 * k
        temp = sp + 12.0 * (1 - np.exp(-t / 900.0)) + 2.0 * np.sin(t / 400.0)
        tout = temp - 1.5 * np.exp(-t / 600.0) - 0.2
        cols = {"time_s": t, "run": f"r{k}"}
        for c in CHANNELS:
            cols[c] = 3.0 * (temp - 25) + 0.01 * (temp - 25) ** 2 + rng.normal(0, 0.5, n)
        cols["temp_in"] = temp
        cols["temp_out"] = tout
        cols["chamber_temp"] = np.full(n, sp)
        frames.append(pd.DataFrame(cols))
    out = pd.concat(frames, ignore_index=True)
    for k, v in kw.items():
        out[k] = v(out) if callable(v) else v
    return out


def test_quantised_temperatures_refuse_the_regression_and_warn() -> None:
    # 1 °C steps: the gradient ΔT = T − temp_out takes a handful of values; its cube cannot
    # be told from lower powers, and the regression would come out off by orders of magnitude
    log = _log(
        temp_in=lambda d: np.round(d["temp_in"]),
        temp_out=lambda d: np.round(d["temp_in"]) - np.round(d["temp_in"] - d["temp_out"]) * 0,
    )
    log["temp_out"] = log["temp_in"] - np.where(log["time_s"] < 1000, 1.0, 0.0)
    with pytest.warns(TrainingDataWarning, match=r"'temp_in': temperature resolution 1 °C is "):
        with pytest.raises(ConfigError) as exc:
            ThermalModel("regression").fit(log, META, source="chamber.csv")
    msg = str(exc.value)
    # the gyros' default orders (1, 1, 1) survive two ΔT values; the accelerometers' cubic not
    assert msg.startswith("chamber.csv: accel_x (T from column 'temp_in', ΔT = T − temp_out)")
    assert "rank-deficient design" in msg
    assert "ΔT takes only 2 distinct values (steps of 1), too few for a polynomial of order" in msg


def test_constant_temperature_is_refused() -> None:
    log = _log(temp_in=25.0, temp_out=24.0)
    span = r"too little temperature range to fit: the training data span 25\.00 \.\. 25\.00 °C"
    with pytest.raises(ConfigError, match=rf"log\.csv: gyro_x .*{span}"):
        ThermalModel("poly-t").fit(log, META, source="log.csv")


def test_single_exponential_warm_up_has_collinear_t_and_rate() -> None:
    # one warm-up T = 40 − 20 e^(−t/τ): Ṫ = (40 − T)/τ exactly, a rate term is arbitrary
    t = (np.arange(3000) + 1.0) * 2.0
    temp = 40.0 - 20.0 * np.exp(-t / 1800.0)
    cols = {"time_s": t, "run": "warmup", "temp_in": temp, "temp_out": temp - 1.0}
    for c in CHANNELS:
        cols[c] = 2.0 * temp
    log = pd.DataFrame(cols)
    collinear = r"T and Ṫ are collinear \(r = -(0\.99\d+|1\.00000)\), as on a"
    with pytest.raises(ConfigError, match=collinear):
        ThermalModel("regression", orders=(2, 1, 0)).fit(log, META)
    # a model of T alone is fine on it
    ThermalModel("poly-t").fit(log, META)


def test_implausible_temperature_names_column_and_row() -> None:
    log = _log()
    log.loc[1234, "temp_out"] = 1e300
    with pytest.raises(ConfigError) as exc:
        ThermalModel("poly-t").fit(log, META, source="bad.csv")
    msg = str(exc.value)
    assert msg.startswith("bad.csv: column 'temp_out': 1 reading(s) outside the plausible range")
    assert "first at data row 1235 (1e+300 °C)" in msg and "temp_range=" in msg
    # the range is configurable: a −80 °C reading is implausible only by default
    log = _log()
    log.loc[10, "temp_in"] = -80.0
    with pytest.raises(ConfigError, match="-60 … 150 °C"):
        ThermalModel("poly-t").fit(log, META)
    ThermalModel("poly-t", temp_range=(-100.0, 150.0)).fit(log, META)


def test_duplicated_column_name_is_refused(tmp_path) -> None:
    path = tmp_path / "dup.csv"
    _log(runs=1, n=20).to_csv(path, index=False)
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace("gyro_y", "gyro_x")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError, match=r"dup\.csv: column\(s\) 'gyro_x' appear more than once"):
        read_log(path)


def test_sectional_edges_outside_the_data_are_refused() -> None:
    log = _log()
    with pytest.raises(ConfigError, match=r"segment edge\(s\) 80 °C lie outside the training"):
        ThermalModel("sectional", edges=(20.0, 80.0)).fit(log, META)


def test_condition_number_of_a_design() -> None:
    # independent of column scale: [1, x] with x at 1e6 °C offset is still well posed once
    # equilibrated; [1, x, x] is singular
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, 200)
    r_ok = np.linalg.qr(np.column_stack([np.ones(200), 1e6 * x]), mode="r")
    assert design_condition(r_ok) < 3
    r_bad = np.linalg.qr(np.column_stack([np.ones(200), x, x]), mode="r")
    assert design_condition(r_bad) > 1e12


def test_ill_conditioned_design_warns() -> None:
    # three inputs nearly (not exactly, and no pair collinear) dependent: weak, not meaningless
    rng = np.random.default_rng(2)
    a, b = rng.uniform(-1, 1, 500), rng.uniform(-1, 1, 500)
    x = np.column_stack([a, b, a + b + 1e-5 * rng.normal(size=500)])
    design = np.column_stack([np.ones(500), x])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(TrainingDataWarning, match=r"weakly determined .*condition number 1"):
            check_design(np.linalg.qr(design, mode="r"), x, [1, 1, 1], "test")


def test_temperature_resolution() -> None:
    t = np.linspace(20, 30, 1000)
    assert temperature_resolution(np.round(t * 16) / 16) == pytest.approx(1 / 16)
    assert temperature_resolution(np.round(t)) == 1.0
    assert temperature_resolution(t) == pytest.approx(10 / 999)
    assert temperature_resolution(np.full(5, 3.0)) == np.inf
