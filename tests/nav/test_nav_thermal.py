"""The thermal plant in the navigation loop: what compensation is worth in position error."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.errors import ModelFileError
from rinscal.sim.config import ImuConfig
from rinscal.sim.scenario import (
    ModelCompensator,
    ThermalPlant,
    oracle_compensator,
    preset,
    run_scenario,
)
from rinscal.sim.workflow import model_compensator

IMU = ImuConfig.navigation_grade()


@pytest.fixture(scope="module")
def cold_start():  # type: ignore[no-untyped-def]
    cfg = preset("quasi-static", hours=4.0, rate_hz=10.0)
    assert cfg.chamber is not None
    return cfg


def _plant(cfg, seed: int = 2, **kw) -> ThermalPlant:  # type: ignore[no-untyped-def]
    return ThermalPlant(IMU, cfg.chamber, cfg.duration_s, cfg.rate_hz, seed=seed, **kw)


def test_true_bias_compensation_equals_an_imu_without_thermal_errors(cold_start) -> None:  # type: ignore[no-untyped-def]
    """Quasi-static cold start (20 °C lab, power-on heating, four-position modulation).

    Subtracting the true thermal bias leaves noise and turn-on offset only: the position
    error equals that of the same IMU (same seed) without thermal errors; without
    compensation the error is clearly larger.
    """
    plant = _plant(cold_start)
    r = run_scenario(cold_start, plant, {"none": None, "true": oracle_compensator(plant)})
    ref = run_scenario(cold_start, _plant(cold_start, thermal=False))
    e_true = r.errors["true"]["horizontal_m"].to_numpy()
    e_ref = ref.errors["none"]["horizontal_m"].to_numpy()
    np.testing.assert_allclose(e_true, e_ref, atol=1e-5)
    assert r.max_error_m("none") > 2.5 * r.max_error_m("true")
    # and the thermal bias really did change during the run (cold start)
    b = plant.thermal_bias(np.array([0.0, 3600.0]))
    assert np.all(np.abs(b[1, 3:] - b[0, 3:]) > 1e-5)  # > 1 µg on every accelerometer


@pytest.fixture(scope="module")
def regression_model(tmp_path_factory):  # type: ignore[no-untyped-def]
    from rinscal.calibration.thermal.model import ThermalModel
    from rinscal.sim.protocols import simulate_protocol

    log, _, meta = simulate_protocol("soak", hours=3.0, rate_hz=1.0, seed=5, imu=IMU)
    path = tmp_path_factory.mktemp("model") / "regression.json"
    ThermalModel("regression").fit(log, meta).to_file().save(path)
    return path


def test_model_file_compensation_subtracts_only_the_thermal_bias(  # type: ignore[no-untyped-def]
    cold_start, regression_model
) -> None:
    """A regression model fitted on a simulated soak calibration (Table 3 set points) cuts
    the cold-start position error; its file's static reference (Earth rate and gravity at
    the calibration site) must be subtracted, or navigation is destroyed."""
    from rinscal.calibration.modelfile import ThermalModelFile

    plant = _plant(cold_start)
    comp = model_compensator(str(regression_model), plant)
    model = ThermalModelFile.load(regression_model)
    ref = np.array(
        [model.models[c].static_reference * model.models[c].unit_to_si for c in model.channels]
    )
    assert ref[5] == pytest.approx(9.79, abs=0.01)  # gravity on accel_z of a level table

    def without_reference(t: np.ndarray, *signal: np.ndarray) -> np.ndarray:  # the mistake
        return comp(t, *signal) + ref  # the design avoids

    r = run_scenario(
        cold_start, plant, {"none": None, "model": comp, "no-reference": without_reference}
    )
    assert r.max_error_m("model") < 0.6 * r.max_error_m("none")
    assert r.max_error_m("no-reference") > 10 * r.max_error_m("none")
    # the compensation is causal: held between thermometer readings
    t = np.array([100.0, 100.5, 100.999])
    np.testing.assert_array_equal(comp(t)[0], comp(t)[2])


def test_model_without_static_reference_is_refused(cold_start, regression_model) -> None:  # type: ignore[no-untyped-def]
    from rinscal.calibration.modelfile import ThermalModelFile

    m = ThermalModelFile.load(regression_model)
    models = {c: m.models[c] for c in m.channels}
    import dataclasses

    bare = dataclasses.replace(
        m, models={c: dataclasses.replace(cm, static_reference=None) for c, cm in models.items()}
    )
    with pytest.raises(ModelFileError, match="static_reference"):
        ModelCompensator(bare, _plant(cold_start))


def test_every_compensator_reads_the_same_thermometers(cold_start, regression_model) -> None:  # type: ignore[no-untyped-def]
    """The navigation computer reads its thermometers once: a model's compensation (and so a
    variant's navigation) must not depend on which other models were set up before it, or
    comparisons between methods are not paired."""
    plant = _plant(cold_start)
    first = model_compensator(str(regression_model), plant)
    for _ in range(3):
        model_compensator(str(regression_model), plant)
    again = model_compensator(str(regression_model), plant)
    np.testing.assert_array_equal(first.bias, again.bias)
    grid = np.arange(0.0, 600.0, 1.0)
    a, b = plant.measured_temperatures(grid)[0], plant.measured_temperatures(grid)[0]
    np.testing.assert_array_equal(a, b)
    # still noisy readings: not the true temperature, and another seed reads differently
    true = plant.field.at(grid).sensor
    assert 0 < np.std(a - true) < 0.1
    other = _plant(cold_start, seed=3).measured_temperatures(grid)[0]
    assert not np.array_equal(a, other)


def _drift_law(imu: ImuConfig):  # type: ignore[no-untyped-def]
    """The plant's scale-factor and axis drift as an IMU calibration, written here from the
    configuration's per-°C coefficients (zero at t_cal, linear in T)."""
    from rinscal.sensormodel import AXES, ImuCalibration

    coefs: dict[str, tuple[float, ...]] = {}
    for j, ch in enumerate(imu.thermal):
        sensor, ax = ("gyro" if j < 3 else "accel"), AXES[j % 3]
        coefs[f"{sensor}_sf_{ax}"] = (0.0, ch.scale_factor_ppm_per_c)
        for k, other in enumerate(AXES):
            if k != j % 3:
                coefs[f"{sensor}_mis_{ax}{other}"] = (0.0, ch.misalignment_arcsec_per_c[k])
    return ImuCalibration(imu.t_cal_c, (-60.0, 100.0), coefs)


def test_imu_calibration_in_the_compensator_removes_the_signal_errors(  # type: ignore[no-untyped-def]
    cold_start, regression_model
) -> None:
    """With the plant's own scale-factor and axis drift as its IMU calibration, the model
    compensator's signal part equals the plant's signal errors on the raw signal, to the
    thermometers' noise (0.01 °C × 100 ppm/°C × g ≈ 1 µg)."""
    from rinscal.calibration.modelfile import ThermalModelFile

    plant = _plant(cold_start)
    model = ThermalModelFile.load(regression_model)
    comp = ModelCompensator(model, plant, imu_calibration=_drift_law(IMU))
    bias_only = ModelCompensator(model, plant)
    rng = np.random.default_rng(0)
    t = np.arange(700.0, 9000.0, 7.3)
    omega = rng.normal(0, 0.3, (t.size, 3))  # rad/s, a turning table
    f = rng.normal(0, 9.8, (t.size, 3)) * 0.6
    true = plant.thermal_errors(t, omega, f) - plant.thermal_bias(t)
    assert np.abs(true[:, 3:]).max() > 50e-6 * 9.8  # the drift is there: > 50 µg
    raw_w, raw_f = omega + true[:, :3], f + true[:, 3:]
    np.testing.assert_array_equal(comp(t), bias_only(t))  # without the signal: the bias
    est = comp(t, raw_w, raw_f) - bias_only(t)
    np.testing.assert_allclose(est[:, 3:], true[:, 3:], rtol=0, atol=3e-6 * 9.8)
    # gyros: the same reading noise is 1 % of a 3 ppm/°C drift over ~1 °C of self-heating
    assert np.abs(est[:, :3] - true[:, :3]).max() < 0.02 * np.abs(true[:, :3]).max()
