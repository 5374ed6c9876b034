"""Evaluation: RMS about the run mean, and the step at a segment edge (Figure 7)."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.calibration.evaluate import StepConfig, edge_crossings, edge_steps, evaluate
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.errors import ConfigError


def test_crossings_count_once_with_hysteresis() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(2000.0)
    temp = 20.0 + 6.0 * np.sin(np.pi * t / 2000.0) + rng.normal(0, 0.03, t.size)  # up, down
    crossings = edge_crossings(temp, 23.0, hysteresis=0.2)
    assert crossings.size == 2
    up, down = crossings
    # the first sample on the new side (segment rule edges[k-1] < T <= edges[k]) ...
    assert temp[up] > 23.0 >= temp[up - 1]
    assert temp[down] <= 23.0 < temp[down - 1]
    # ... near where the noise-free curve crosses: sin(pi t / 2000) = 1/2
    assert abs(up - 2000 / 6) < 30 and abs(down - 2000 * 5 / 6) < 30
    # without hysteresis the thermometer noise makes the edge chatter
    assert edge_crossings(temp, 23.0, hysteresis=0.0).size > 2


def test_step_of_a_known_jump_on_a_trend() -> None:
    # a linear trend with a jump of 5 units where T crosses 23 °C: the step is exactly 5
    t = np.arange(0.0, 3600.0, 0.5)
    temp = 20.0 + t / 600.0  # crosses 23 °C at t = 1800 s
    y = 3.0 + 0.002 * t + 5.0 * (temp > 23.0)
    steps = edge_steps(t, y, temp, np.array([23.0, 40.0]), StepConfig(window_s=120.0))
    assert len(steps) == 1
    tc, edge, step = steps[0]
    assert edge == 23.0 and tc == pytest.approx(1800.5)
    assert step == pytest.approx(5.0, rel=1e-9)
    # a smooth curve has no step: the quadratic terms of the two one-sided extrapolations
    # cancel, leaving a third-order term of order y''' h³ (here ~1e-4 of the amplitude)
    smooth = edge_steps(t, np.sin(t / 900.0), temp, np.array([23.0]), StepConfig())
    assert abs(smooth[0][2]) < 2e-4
    # a crossing too close to the end of the run is skipped
    assert edge_steps(t[:3650], y[:3650], temp[:3650], np.array([23.0]), StepConfig()) == []


def test_step_config_is_checked() -> None:
    with pytest.raises(ConfigError, match="min_samples"):
        StepConfig(min_samples=1)


def test_sectional_steps_at_an_edge_regression_does_not(soak_quiet, repeat_quiet) -> None:
    # Section 5.1.1 / Figure 7: the repetition-priming start at 25 °C heats the sensors
    # through a segment edge; the sectional model's compensated output jumps there, the
    # regression model's does not (noise-free plant, so steps are the models' own)
    log, _, meta = soak_quiet
    rlog = repeat_quiet[0]
    sec = evaluate(rlog, ThermalModel("sectional").fit(log, meta).to_file())
    reg = evaluate(rlog, ThermalModel("regression").fit(log, meta).to_file())
    acc = sec["channel"].str.startswith("accel")
    assert (sec["crossings"] >= 1).all() and (reg["crossings"] >= 1).all()
    # the raw output is smooth across the edge: steps are tiny compared with the RMS
    assert (sec["max_step_before"] < 1e-3 * sec["rms_before"]).all()
    # sectional: a step of a good fraction of the remaining error; regression: none
    assert (sec["max_step_after"][acc] > 0.05 * sec["rms_after"][acc]).all()
    assert (sec["max_step_after"] > 100 * sec["max_step_before"]).all()
    assert (reg["max_step_after"] < 2 * reg["max_step_before"] + 1e-4 * reg["rms_before"]).all()
    # method 2 removes most of the thermal variation of the held-out run
    assert (reg["rms_after"] < 0.4 * reg["rms_before"]).all()
    assert (reg["rms_after"][acc].to_numpy() < sec["rms_after"][acc].to_numpy()).all()


def test_rms_is_about_the_run_mean(fitted_models, repeat_small) -> None:
    log = repeat_small[0].copy()
    mf = fitted_models["poly-t"]
    a = evaluate(log, mf)
    log["accel_x"] += 1000.0  # a turn-on offset changes nothing
    b = evaluate(log, mf)
    np.testing.assert_allclose(a["rms_before"], b["rms_before"], rtol=1e-9)
    np.testing.assert_allclose(a["rms_after"], b["rms_after"], rtol=1e-9)
    assert list(a.columns[:3]) == ["run", "channel", "unit"]
