"""The tasks of a study and the pure functions that run them.

A spec (:mod:`rinscal.experiments.study.spec`) expands into a calibration task per plant
variant and unit (:func:`calibrate_unit`) and a navigation task per plant variant, unit,
scenario and cold start (:func:`navigate_unit`), unit by unit (:func:`study_tasks`). Each
task is a pure function of the spec, its key and the seeds derived from the spec's seed and
the key (:func:`task_seed`); a unit's IMU is its plant variant's (:func:`plant_config`) with
the spec's coefficient spread drawn from the unit's own seed (:func:`unit_config`).
"""

from __future__ import annotations

import json
import math
import tempfile
import time
import warnings
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from rinscal import units
from rinscal.calibration.modelfile import FittedModel
from rinscal.calibration.thermal.features import build_features
from rinscal.calibration.thermal.model import ThermalFitter
from rinscal.experiments.paper.config import load_plant
from rinscal.experiments.paper.imucal import IMU_VARIANT, imu_variant_model
from rinscal.experiments.paper.navigation import (
    RESIDUAL_COLUMNS,
    NavJob,
    run_navigation_job,
    thermal_part_m,
)
from rinscal.experiments.study.compare import DESIGN_COLUMNS, FIELD_VARIANT, NO_DT_VARIANT
from rinscal.experiments.study.spec import (
    MECH_SPREAD_FIELDS,
    SPREAD_FIELDS,
    SWEEP_PARAMETERS,
    PlantVariant,
    ScenarioSpec,
    StudySpec,
)
from rinscal.nav.fieldcal import calibrate_field
from rinscal.sim.config import ImuConfig
from rinscal.sim.fieldstarts import simulate_field_starts
from rinscal.sim.protocols import simulate_protocol

__all__ = [
    "RESULT_COLUMNS",
    "CalTask",
    "NavTask",
    "calibrate_unit",
    "field_model",
    "navigate_unit",
    "plant_config",
    "soak_design",
    "study_tasks",
    "task_seed",
    "unit_config",
]


# --------------------------------------------------------------------------- tasks
@dataclass(frozen=True)
class CalTask:
    """Calibration of one unit of one plant variant."""

    plant: int
    unit: int

    @property
    def key(self) -> str:
        return f"cal-p{self.plant:03d}-u{self.unit:05d}"


@dataclass(frozen=True)
class NavTask:
    """One cold start of one unit: scenario ``scenario`` (index in the spec), start
    ``start`` (index into its ``ambient_c``)."""

    plant: int
    unit: int
    scenario: int
    start: int

    @property
    def key(self) -> str:
        return f"nav-p{self.plant:03d}-u{self.unit:05d}-s{self.scenario:02d}-r{self.start:02d}"

    @property
    def cal(self) -> CalTask:
        return CalTask(self.plant, self.unit)


def study_tasks(spec: StudySpec) -> list[tuple[CalTask, list[NavTask]]]:
    """Every task, unit by unit: each calibration task with the navigation tasks that use
    its models (in the order they are best submitted: a unit's runs right after its
    calibration, so that results stream in from the first minutes)."""
    out = []
    for u in range(spec.units):
        for p in range(len(spec.plants)):
            navs = [
                NavTask(p, u, s, r)
                for s, sc in enumerate(spec.scenarios)
                for r in range(len(sc.ambient_c))
            ]
            out.append((CalTask(p, u), navs))
    return out


def task_seed(spec_seed: int, *key: int) -> int:
    """A 32-bit seed from the study's seed and an integer key path (numpy's SeedSequence
    spawn keys: independent streams, the same on every machine)."""
    ss = np.random.SeedSequence(spec_seed, spawn_key=tuple(int(k) for k in key))
    return int(ss.generate_state(1)[0])


def _scenario_key(sc: ScenarioSpec) -> int:
    """Stable integer of a scenario group (its name), so that adding a scenario to a spec
    does not change the seeds of the others."""
    return zlib.crc32(sc.name.encode())


def plant_config(variant: PlantVariant) -> ImuConfig:
    """The IMU of a plant variant: the preset or file with the sweep factors applied (to the
    fields of its thermal law, :data:`SWEEP_PARAMETERS`)."""
    imu = load_plant(variant.imu)
    if not variant.params:
        return imu
    thermal = list(imu.thermal)
    mech = list(imu.mechanistic or ())
    for name, factor in variant.params:
        sensors, poly_fields, mech_fields = SWEEP_PARAMETERS[name]
        idx = range(0, 3) if sensors == "gyro" else range(3, 6)
        for j in idx:
            if imu.thermal_law == "mechanistic":
                mech[j] = _scaled(mech[j], mech_fields, lambda _k, f=factor: f)
            # (under the mechanistic law the polynomial fields are zero: only Shupe scales)
            thermal[j] = _scaled(thermal[j], poly_fields, lambda _k, f=factor: f)
    return replace(
        imu,
        name=f"{imu.name} ({variant.label})",
        thermal=tuple(thermal),
        mechanistic=tuple(mech) if imu.mechanistic is not None else None,
    )


def _scaled(ch: Any, names: Sequence[str], factor: Any) -> Any:
    """``ch`` (a frozen dataclass: ``ChannelThermal`` or ``MechanisticThermal``) with each
    field in ``names`` multiplied by ``factor(k)`` (k counts the scalars scaled so far, so a
    random factor per coefficient can be drawn)."""
    k = 0
    new: dict[str, Any] = {}
    for n in names:
        v = getattr(ch, n)
        if isinstance(v, tuple):
            vals = []
            for x in v:
                vals.append(float(x * factor(k)))
                k += 1
            new[n] = tuple(vals)
        else:
            new[n] = float(v * factor(k))
            k += 1
    return replace(ch, **new)


def unit_config(spec: StudySpec, plant: ImuConfig, unit: int) -> ImuConfig:
    """Unit ``unit`` of a plant: each coefficient of :data:`SPREAD_FIELDS` (and, under the
    mechanistic law, of :data:`MECH_SPREAD_FIELDS`) multiplied by ``1 + coefficient_spread·z``
    with ``z`` standard normal from the unit's seed (the same ``z`` in every plant variant;
    the hysteresis width by ``|1 + spread·z|``)."""
    if spec.coefficient_spread == 0.0:
        return plant
    rng = np.random.default_rng(task_seed(spec.seed, unit, 0))
    z = rng.standard_normal((6, 64))
    sd = spec.coefficient_spread
    thermal = tuple(
        _scaled(ch, SPREAD_FIELDS, lambda k, j=j: 1.0 + sd * z[j, k])
        for j, ch in enumerate(plant.thermal)
    )
    thermal = tuple(replace(ch, hysteresis=abs(ch.hysteresis)) for ch in thermal)
    mech = None
    if plant.mechanistic is not None:
        # the columns after the polynomial law's (at most 32 scalars): independent draws
        mech = tuple(
            _scaled(m, MECH_SPREAD_FIELDS, lambda k, j=j: 1.0 + sd * z[j, 32 + k])
            for j, m in enumerate(plant.mechanistic)
        )
    return replace(plant, thermal=thermal, mechanistic=mech)


def calibrate_unit(spec: StudySpec, plant: ImuConfig, task: CalTask) -> dict[str, Any]:
    """Simulate a unit's soak calibration and fit every model of the spec.

    The ``field`` variant is not fitted on the soak: it learns from the unit's own parked
    cold starts (:func:`field_model`), drawn from their own seed, so the study's navigation
    starts (other seeds, other scenarios) are held out from it.

    Returns
    -------
    dict
        ``models``: method → model file JSON text; ``warnings``: method → the warnings its
        fit raised (a weak fit is kept and flagged); ``design``: the soak design
        (:func:`soak_design`); ``field`` (with the field variant): what its starts did not
        determine (``fallback``: channel → the inputs it was restricted to) and each
        channel's chosen model (``chosen``); ``elapsed_s`` [s]: the task's run time.
    """
    t0 = time.perf_counter()
    imu = unit_config(spec, plant, task.unit)
    seed = task_seed(spec.seed, task.unit, 1)
    log, _, meta = simulate_protocol(
        "soak",
        hours=spec.calibration.hours,
        rate_hz=spec.calibration.rate_hz,
        seed=seed,
        imu=imu,
    )
    models: dict[str, str] = {}
    caught: dict[str, list[str]] = {}
    extra: dict[str, Any] = {}
    for m in spec.models:
        params = {"max_samples": spec.calibration.neural_max_samples} if m == "neural" else {}
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            if m == FIELD_VARIANT:
                mf, extra["field"] = field_model(spec, imu, task)
            elif m == IMU_VARIANT:  # the unit's own multi-position calibration, then method 2
                mf = imu_variant_model(imu, log, meta, seed, quick=spec.quick)
            else:
                # the ablation: method 2 fitted without its ΔT terms (T and Ṫ only)
                no_dt = m == NO_DT_VARIANT
                fitted = ThermalFitter(
                    "regression" if no_dt else m,
                    random_state=seed,
                    estimator_params=params,
                    use_gradient=False if no_dt else None,
                )
                mf = fitted.fit(log, meta).to_file(
                    source={"log": f"study {spec.name}, unit {task.unit}, soak"}
                )
        models[m] = json.dumps(mf.to_dict())
        msgs = sorted({str(x.message) for x in w if not issubclass(x.category, RuntimeWarning)})
        if msgs:
            caught[m] = msgs
    return {
        "models": models,
        "warnings": caught,
        "design": soak_design(log),
        **extra,
        "elapsed_s": time.perf_counter() - t0,
    }


def field_model(
    spec: StudySpec, imu: ImuConfig, task: CalTask
) -> tuple[FittedModel, dict[str, Any]]:
    """The ``field`` variant of a unit: its parked cold starts (``spec.calibration``'s
    ``field_*`` sizes, the unit's own plant ``imu`` and seed ``task_seed(seed, unit, 3)``)
    simulated into a temporary folder, then calibrated by
    :func:`rinscal.nav.fieldcal.calibrate_field` with the unit's datasheet (``imu=``: its
    noise and turn-on repeatability, as its user knows them) and ``field_method``.

    Returns
    -------
    (FittedModel, dict)
        The model file (``source.protocol`` ``field``) and a summary: ``fallback``
        (channel → the inputs it was restricted to), ``chosen`` (channel → its model),
        ``runs``.
    """
    c = spec.calibration
    seed = task_seed(spec.seed, task.unit, 3)
    with tempfile.TemporaryDirectory(prefix="rinscal-field-") as d:
        paths = simulate_field_starts(
            d,
            runs=c.field_runs,
            ambient_c=c.field_ambient_c,
            hours=c.field_hours,
            rate_hz=c.field_rate_hz,
            imu=imu,
            seed=seed,
        )
        # one thread: the study already runs a task per core
        fc = calibrate_field(paths, imu=imu, method=c.field_method, seed=seed, n_jobs=1)
    src = {**fc.model.source, "log": f"study {spec.name}, unit {task.unit}, parked starts"}
    summary = {
        "fallback": dict(fc.fallback),
        "chosen": dict(zip(fc.table["channel"], fc.table["model"].astype(str), strict=True)),
        "runs": c.field_runs,
    }
    return replace(fc.model, source=src), summary


def soak_design(log: pd.DataFrame) -> dict[str, float]:
    """How separable the temperature rate and the gradient are in a soak design.

    Over the log's runs (features as the fits see them, :func:`build_features`), for each
    horizontal accelerometer: the correlation of ``Ṫ`` [°C/min] and ``ΔT`` [°C], and the
    condition number (2-norm) of the design ``[T, Ṫ, ΔT]`` with each column standardised
    (mean 0, standard deviation 1). 1 means orthogonal columns; the larger, the less the
    data can tell a ``Ṫ`` term from a ``ΔT`` term.

    Returns
    -------
    dict
        ``soak_rate_grad_corr`` (the channel's with the larger magnitude) and
        ``soak_design_cond`` (the larger); NaN without a ``temp_out`` column.
    """
    nan = dict.fromkeys(DESIGN_COLUMNS, math.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = build_features(log, channels=("accel_x", "accel_y"))
    if f.grad is None:
        return nan
    best = nan
    for j in range(len(f.channels)):
        ok = f.inlier[:, j]
        x = np.column_stack([f.temp[ok, j], f.rate[ok, j], f.grad[ok, j]])
        sd = x.std(axis=0)
        if x.shape[0] < 3 or np.any(sd == 0):
            continue
        z = (x - x.mean(axis=0)) / sd
        corr = float(np.corrcoef(z[:, 1], z[:, 2])[0, 1])
        cond = float(np.linalg.cond(z))
        if not math.isfinite(best["soak_design_cond"]) or cond > best["soak_design_cond"]:
            best = {**best, "soak_design_cond": cond}
        if not math.isfinite(best["soak_rate_grad_corr"]) or abs(corr) > abs(
            best["soak_rate_grad_corr"]
        ):
            best = {**best, "soak_rate_grad_corr": corr}
    return best


#: Columns of a navigation task's result rows (one row per variant).
RESULT_COLUMNS = (
    "plant",
    "plant_label",
    "unit",
    "scenario",
    "kind",
    "start",
    "ambient_c",
    "align_start_s",
    "align_s",
    "variant",
    "max_error_nmi",
    "final_error_nmi",
    "thermal_part_nmi",
    "heading_error_arcsec",
    *RESIDUAL_COLUMNS,
    *DESIGN_COLUMNS,
    "seed",
    "elapsed_s",
)


def navigate_unit(
    spec: StudySpec, plant: ImuConfig, task: NavTask, calibration: Mapping[str, Any]
) -> pd.DataFrame:
    """Navigate one cold start of a unit with every variant on the same raw output.

    ``calibration`` is :func:`calibrate_unit`'s result for ``task.cal``. Returns one row per
    variant (:data:`RESULT_COLUMNS`): the maximum and final horizontal position error
    [nmi], the maximum of its thermal part (variant minus oracle, see
    :func:`rinscal.experiments.paper.navigation.thermal_part_m`) [nmi], the heading error
    at the start of free navigation [arcsec] and the model's held-out thermal residual on
    this cold start (:func:`rinscal.experiments.paper.navigation.thermal_residual`: gyros
    [°/h], horizontal accelerometers [µg] and [% of the true swing]), and the unit's soak
    design (:data:`rinscal.experiments.study.compare.DESIGN_COLUMNS`, from ``calibration``).
    """
    t0 = time.perf_counter()
    sc = spec.scenarios[task.scenario]
    imu = unit_config(spec, plant, task.unit)
    seed = task_seed(spec.seed, task.unit, 2, _scenario_key(sc), task.start)
    job = NavJob(
        sc.name, sc.kind, task.start + 1, sc.ambient_c[task.start], sc.hours, sc.rate_hz, seed
    )
    res = run_navigation_job(job, calibration["models"], imu, sc.align_s, sc.align_start_s)
    rows = []
    for v, s in res.summary["variants"].items():
        rows.append(
            {
                "variant": v,
                "max_error_nmi": s["max_error_nmi"],
                "final_error_nmi": s["final_error_m"] / units.NMI_TO_M,
                "thermal_part_nmi": float(thermal_part_m(res.errors, v).max()) / units.NMI_TO_M,
                "heading_error_arcsec": s["attitude_error_at_nav_start"]["heading_arcsec"],
                **(res.residual or {}).get(v, dict.fromkeys(RESIDUAL_COLUMNS, math.nan)),
            }
        )
    df = pd.DataFrame(rows)
    amb = sc.ambient_c[task.start]
    df.insert(0, "plant", task.plant)
    df.insert(1, "plant_label", spec.plants[task.plant].label)
    df.insert(2, "unit", task.unit)
    df.insert(3, "scenario", sc.name)
    df.insert(4, "kind", sc.kind)
    df.insert(5, "start", task.start)
    df.insert(6, "ambient_c", float("nan") if amb is None else amb)
    df.insert(7, "align_start_s", sc.align_start_s)
    df.insert(8, "align_s", sc.align_s)
    for c in DESIGN_COLUMNS:  # the unit's soak design (NaN from a calibration without it)
        df[c] = float(calibration.get("design", {}).get(c, math.nan))
    df["seed"] = seed
    df["elapsed_s"] = time.perf_counter() - t0
    return df[list(RESULT_COLUMNS)]
