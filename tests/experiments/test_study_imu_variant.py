"""A study can switch the scale-factor and axis drift with temperature in the plant (the
``*_signal_drift_scale`` sweep parameters) and in the model (the ``regression+sf``
variant: the unit's own multi-position calibration, then method 2 behind it)."""

from __future__ import annotations

import copy

import pytest

from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.experiments.paper.imucal import IMU_VARIANT
from rinscal.experiments.study.spec import spec_from_dict
from rinscal.experiments.study.tasks import calibrate_unit, plant_config, study_tasks
from rinscal.sim.sensor import sensor_law

from .test_study_spec import BASE


def _spec(**study):  # type: ignore[no-untyped-def]
    d = copy.deepcopy(BASE)
    d["study"].update(study)
    d["plants"] = [
        {
            "imu": "paper",
            "sweep": {
                "gyro_signal_drift_scale": [0.0, 1.0],
                "accel_signal_drift_scale": [0.0, 1.0],
            },
        }
    ]
    return spec_from_dict(d, "s.toml", quick=True)


def test_signal_drift_sweep_switches_the_plants_temperature_dependence_only() -> None:
    spec = _spec()
    off = next(p for p in spec.plants if all(f == 0.0 for _, f in p.params))
    on = next(p for p in spec.plants if all(f == 1.0 for _, f in p.params))
    law_off, law_on = sensor_law(plant_config(off)), sensor_law(plant_config(on))
    for name, coefs in law_on.t_coefs.items():
        assert law_off.t_coefs[name][0] == pytest.approx(coefs[0])  # value at t_cal kept
        assert law_off.t_coefs[name][1:] == pytest.approx([0.0] * (len(coefs) - 1))
    assert law_on.t_coefs["accel_sf_z"][1] == pytest.approx(120.0)  # the paper preset's slope
    # the thermal bias is untouched
    assert plant_config(off).thermal[5].t == plant_config(on).thermal[5].t


def test_imu_variant_fits_a_model_file_holding_the_units_calibration() -> None:
    spec = _spec(methods=["none", "regression", IMU_VARIANT, "true"])
    assert IMU_VARIANT in spec.models
    plant = next(p for p in spec.plants if all(f == 1.0 for _, f in p.params))
    cal_task = next(c for c, _ in study_tasks(spec) if c.plant == spec.plants.index(plant))
    out = calibrate_unit(spec, plant_config(plant), cal_task)
    mf = ThermalModelFile.loads(out["models"][IMU_VARIANT], IMU_VARIANT)
    cal = mf.imu_calibration
    assert cal is not None
    # its thermal part is zero at t_cal and carries the drift the plant has (accel z:
    # 120 ppm/°C in the paper preset), estimated from the unit's own calibration
    t_cal = plant_config(plant).t_cal_c
    assert cal.value("accel_sf_z", t_cal) == pytest.approx(0.0, abs=1e-9)
    slope = (cal.value("accel_sf_z", t_cal + 10.0) - cal.value("accel_sf_z", t_cal)) / 10.0
    assert slope == pytest.approx(120.0, rel=0.1)
    assert not any(n.startswith(("gyro_bias", "accel_bias")) for n in cal.t_coefs)
    assert ThermalModelFile.loads(out["models"]["regression"], "r").imu_calibration is None
