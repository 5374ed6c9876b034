"""The paper's tables beside ours: transcription, unit conversions, noise floor, and the
recovery of the plant's coefficients by method 2 (a quick soak on the `paper` plant)."""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from rinscal.calibration.thermal.model import ThermalModel
from rinscal.experiments.paper.config import PAPER_TABLES, load_plant
from rinscal.experiments.paper.paper_tables import (
    noise_floor,
    paper_pulse_scales,
    plant_coefficients,
    ramp_outside_training,
    regression_recovery,
    step_noise_sd,
    table9_vs_paper,
)
from rinscal.sim.config import EffectsConfig
from rinscal.sim.protocols import simulate_protocol

PAPER_NAME = "wang-cheng-du-2020-thermal-calibration-single-axis-rins.md"


def _paper_md() -> Path | None:
    """The paper's text in ``shared/paper/`` beside the repository (``../shared/paper`` from a
    clone's root; a worktree deeper down finds it in a folder further up), if any."""
    for parent in Path(__file__).resolve().parents:
        p = parent / "shared" / "paper" / PAPER_NAME
        if p.is_file():
            return p
    return None


def _paper_text() -> str:
    p = _paper_md()
    if p is None:
        pytest.skip(f"the paper's text ({PAPER_NAME}) is in no shared/paper/ above this checkout")
    return p.read_text(encoding="utf-8")


def test_transcription_spot_checks_against_the_paper_text() -> None:
    text = _paper_text()
    # Table 6: the constants and a few coefficients, as printed (thousands separator)
    assert "465,231.31" in text and PAPER_TABLES["table6"]["accel_z"]["a0"] == 465231.31
    assert "$A_{\\Delta T1x}$\t-533.16" in text
    assert PAPER_TABLES["table6"]["accel_x"]["ΔT"][0] == -533.16
    assert "$G_{\\dot{T}1x}$\t40.48" in text and PAPER_TABLES["table6"]["gyro_x"]["Ṫ"] == (40.48,)
    # Table 4: the last A0x and the gyro's Ṫ row
    assert "12,730.53" in text and PAPER_TABLES["table4"]["accel_x"]["a0"][-1] == 12730.53
    row = re.search(r"\$G_\{T2x\}\$\t([^\n]+)", text)
    assert row is not None
    assert (
        tuple(float(x) for x in row.group(1).split("\t"))
        == (PAPER_TABLES["table4"]["gyro_x"]["Ṫ^1"])
    )
    # Table 5 and 7 rows
    assert "$P = 3, q = 3, s = 3$\t34.00\t32.99\t39.37" in text
    assert [PAPER_TABLES["table5"][c][2] for c in ("accel_x", "accel_y", "accel_z")] == [
        34.00,
        32.99,
        39.37,
    ]
    assert "$n = 6$\t32.61\t32.20\t38.68\t$n = 3$\t24.14\t22.00\t14.04" in text
    assert PAPER_TABLES["table7"]["accel_y"][6] == 32.20
    assert PAPER_TABLES["table7"]["gyro_z"][3] == 14.04
    # Table 8: w_61 and v_4 of the accelerometer, the gyro's b'
    assert "$w_{61}$\t-17.37" in text and PAPER_TABLES["table8"]["accel_x"]["W"][5][0] == -17.37
    assert "$v_4$\t-10.00" in text and PAPER_TABLES["table8"]["accel_x"]["v"][3] == -10.0
    assert PAPER_TABLES["table8"]["gyro_x"]["b_out"] == 0.125


def test_pulse_scales_turn_the_static_outputs_into_gravity_and_earth_rate() -> None:
    s = paper_pulse_scales()
    lat = math.radians(32.06)
    # independent: Somigliana gravity at 32.06° N, 10 m; 1 µg = 9.80665e-6 m/s²
    s2 = math.sin(lat) ** 2
    g = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2)
    g -= 3.086e-6 * 10.0
    assert s["accel_x"] == pytest.approx(g / 9.80665e-6 / 465231.31, rel=1e-4)
    assert s["accel_z"] == pytest.approx(2.147, abs=5e-4)  # the README's figure
    assert 465231.31 * s["accel_z"] * 9.80665e-6 == pytest.approx(g, rel=1e-4)  # A0z = 1 g
    omega_dph = 7.292115e-5 * 180 / math.pi * 3600  # 15.041 °/h
    assert 7361.77 * s["gyro_x"] == pytest.approx(omega_dph * math.cos(lat), rel=1e-9)
    assert 3617.88 * s["gyro_z"] == pytest.approx(omega_dph * math.sin(lat), rel=1e-9)
    assert s["gyro_x"] == pytest.approx(0.0017, abs=5e-5)
    assert s["gyro_z"] == pytest.approx(0.0022, abs=5e-5)
    # the preset was converted with the same scales: Table 6's A_T1x and G_Ṫ1x
    imu = load_plant("paper")
    assert imu.thermal[3].t[0] == pytest.approx(-8.52 * s["accel_x"], rel=1e-3)
    assert imu.thermal[0].rate[0] == pytest.approx(40.48 * s["gyro_x"], rel=1e-3)


def test_noise_floor_is_the_white_noise_of_one_sample() -> None:
    imu = load_plant("paper")  # 0.0007 °/√h and 78 µg/√Hz
    for rate in (1.0, 2.0, 10.0):
        f = noise_floor(imu, rate)
        assert f["accel_x"] == pytest.approx(78.0 * math.sqrt(rate), rel=1e-12)
        # °/√h → (°/h)/√Hz: × 60
        assert f["gyro_z"] == pytest.approx(0.0007 * 60.0 * math.sqrt(rate), rel=1e-12)
    # and it is what white noise of that density gives per sample
    rng = np.random.default_rng(1)
    rate, dens = 4.0, 78.0
    fine = rng.normal(0.0, dens * math.sqrt(400.0), size=(20000, 100))  # 400 Hz white
    sample = fine.mean(axis=1)  # one 4 Hz sample = the mean over 1/4 s
    assert sample.std() == pytest.approx(dens * math.sqrt(rate), rel=0.03)


def test_step_noise_is_that_of_two_extrapolated_line_fits() -> None:
    rng = np.random.default_rng(2)
    n = 240
    t = np.arange(n, dtype=float)
    steps = []
    for _ in range(3000):
        a, b = rng.normal(size=n), rng.normal(size=n)
        ya = np.polyval(np.polyfit(t, a, 1), n - 0.5)  # before, extrapolated to the edge
        yb = np.polyval(np.polyfit(t + n, b, 1), n - 0.5)  # after, back to it
        steps.append(yb - ya)
    assert np.std(steps) == pytest.approx(step_noise_sd(1.0, 2.0, 120.0), rel=0.06)


def test_table9_holds_the_scenarios_reading() -> None:
    t = table9_vs_paper().set_index("axis")
    assert t.loc["heading", "ours: quasi-static [°]"] == 45.0
    assert list(t["ours: swing amplitude [°]"]) == [2.0, 2.0, 8.0]
    assert list(t["ours: swing period [s]"]) == [3.0, 3.0, 5.0]
    assert t.loc["roll", "paper (as printed)"] == "0 / 8 / 5"


def test_plant_coefficients_expand_the_reference_temperature() -> None:
    imu = load_plant("navigation_grade")
    th = imu.thermal[3]
    raw = plant_coefficients(imu, "accel_x")
    assert raw is not None
    x = np.linspace(-5, 45, 7)
    own = sum(c * (x - imu.t_ref_c) ** (k + 1) for k, c in enumerate(th.t))
    ours = sum(raw[f"T^{k}"] * x**k for k in range(1, len(th.t) + 1))
    # equal up to a constant (the shift's constant goes to a0)
    assert np.ptp(own - ours) < 1e-9 * np.max(np.abs(own))
    assert plant_coefficients(load_plant("paper_mechanistic"), "accel_x") is None


@pytest.fixture(scope="module")
def soak_off() -> tuple:
    """A 1 Hz soak of the `paper` plant with every effect beyond the polynomial off."""
    imu = load_plant("paper")
    off = EffectsConfig(**{f.name: False for f in dataclasses.fields(EffectsConfig)})
    imu = dataclasses.replace(imu, effects=off)
    log, truth, meta = simulate_protocol("soak", hours=3.0, rate_hz=1.0, seed=0, imu=imu)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = ThermalModel("regression").fit(log, meta).to_file()
    return imu, log, truth, model


def test_recovery_on_the_paper_plant(soak_off: tuple) -> None:
    imu, log, truth, model = soak_off
    r = regression_recovery(log, truth, model, imu, n_boot=200, seed=0).set_index(
        ["channel", "term"]
    )
    # the plant's law is Table 6 itself (converted): the truth column is the paper's
    s = paper_pulse_scales()
    assert r.loc[("accel_x", "T^2"), "true"] == pytest.approx(0.180 * s["accel_x"], rel=1e-3)
    # the same regression fitted to the noise-free bias recovers every temperature term of
    # the accelerometers (T, not collinear with anything) within 0.5 %
    for c in ("accel_x", "accel_y", "accel_z"):
        for k in (1, 2, 3):
            row = r.loc[(c, f"T^{k}")]
            assert row["noise-free fit"] == pytest.approx(row["true"], rel=5e-3), (c, k)
    # the bootstrap interval holds the noise-free fit (what this design can identify) for
    # most terms: 27 of 36 observed on seed 0 (75 %), asserted at two thirds
    nf_inside = (r["lo"] <= r["noise-free fit"]) & (r["noise-free fit"] <= r["hi"])
    assert nf_inside.mean() >= 2 / 3, nf_inside.mean()
    # the gyros, whose terms are not collinear at 1st order here: the plant's own
    # coefficient inside its interval for at least 7 of 9
    gy = r.loc[["gyro_x", "gyro_y", "gyro_z"]]
    assert gy["recovered"].astype(bool).sum() >= 7
    # and the intervals are not vacuous: narrower than the coefficient's size for T¹
    for c in ("accel_x", "accel_z"):
        row = r.loc[(c, "T^1")]
        assert row["hi"] - row["lo"] < abs(row["true"])
    assert r.attrs["n_runs"] == 7 and all(abs(v) < 1 for v in r.attrs["corr_rate_grad"].values())


def test_ramp_is_mostly_outside_the_soak_domain(soak_off: tuple) -> None:
    imu, log, _truth, model = soak_off
    ramp, _, _ = simulate_protocol("ramp", rate_hz=1.0, seed=0, imu=imu)
    frac = ramp_outside_training(log, ramp, model)
    assert set(frac) == {"T", "Ṫ", "ΔT", "flagged"}
    assert all(0.0 <= v <= 1.0 for v in frac.values())
    # the ramp goes to 50 °C, the hottest soak run at 42 °C warms to ~53 °C: only the hot
    # end leaves T's range, but the (T, Ṫ, ΔT) combinations are mostly new
    assert frac["T"] < 0.2
    assert frac["flagged"] > 0.5


def test_format_sig_is_one_positional_format() -> None:
    # deferred: the report layer is only needed by this test
    from rinscal.report.paper_cal_sections import format_sig

    assert format_sig(-0.000030302) == "-0.0000303"
    assert format_sig(998798.1) == "998800"
    assert format_sig(12.775) == "12.78"
    assert format_sig(float("nan")) == ""
