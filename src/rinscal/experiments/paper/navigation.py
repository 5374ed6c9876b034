"""The reproduction's navigation stage: its jobs (the chamber ramp, the lab cold starts, the
vehicle runs), one job with every variant on the same raw output, the thermal residual a
model leaves over a cold start, and the per-run tables (thermal part, maximum error,
heading error)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from rinscal import earth, units
from rinscal.calibration.compensator import Compensator
from rinscal.calibration.modelfile import FittedModel
from rinscal.cluster import dask_client
from rinscal.experiments.paper.config import METHODS, VARIANTS, ReproConfig, load_plant
from rinscal.experiments.paper.mechanism import ORACLE_NO_OFFSETS, alignment_mechanism
from rinscal.sim.config import ImuConfig
from rinscal.sim.field import ChamberProfile
from rinscal.sim.scenario import (
    LAB_C,
    VEHICLE_CABIN_C,
    VEHICLE_WARMUP_S,
    ModelCompensator,
    ThermalPlant,
    align_for,
    oracle_compensator,
    preset,
    run_scenario,
    temperature_frame,
)

__all__ = [
    "RESIDUAL_COLUMNS",
    "NavJob",
    "NavRunResult",
    "alignment_config",
    "heading_error_table",
    "max_error_table",
    "navigation_jobs",
    "navigation_stage",
    "run_navigation_job",
    "thermal_part_m",
    "thermal_part_table",
    "thermal_residual",
    "variant_table",
]


# --------------------------------------------------------------------------- navigation
@dataclass(frozen=True)
class NavJob:
    """One navigation run of the reproduction."""

    experiment: str  # "ramp", "lab", "vehicle"
    scenario: str  # quasi-static, swing, vehicle, ramp
    index: int  # experiment number (1-based, as in Figure 13 / Table 10)
    ambient_c: float | None
    hours: float
    rate_hz: float
    seed: int


def navigation_jobs(cfg: ReproConfig) -> list[NavJob]:
    """Every navigation run of the reproduction, numbered as in the paper."""
    jobs = [NavJob("ramp", "ramp", 1, None, cfg.ramp_hours, cfg.nav_rate_hz, cfg.seed + 100)]
    n_lab = len(cfg.lab_temps_c)
    # (experiment, scenario, ambients, hours, rate, seed offset, first experiment number - 1)
    groups = (
        ("lab", "quasi-static", cfg.lab_temps_c, cfg.qs_hours, cfg.nav_rate_hz, 200, 0),
        ("lab", "swing", cfg.lab_temps_c, cfg.swing_hours, cfg.swing_rate_hz, 300, n_lab),
        ("vehicle", "vehicle", cfg.vehicle_ambient_c, cfg.vehicle_hours, cfg.nav_rate_hz, 400, 0),
    )
    for exp, scen, temps, hours, rate, seed_offset, first in groups:
        jobs += [
            NavJob(exp, scen, first + i + 1, t, hours, rate, cfg.seed + seed_offset + i)
            for i, t in enumerate(temps)
        ]
    return jobs


@dataclass
class NavRunResult:
    """Outcome of one navigation run (picklable, small)."""

    job: NavJob
    summary: dict[str, Any]
    # time_s; per variant v: v (horizontal [m]), v_east, v_north [m], v_heading [rad]
    # (INS minus truth, clockwise), v_ve, v_vn [m/s] (velocity error), every out_dt
    errors: pd.DataFrame
    track: pd.DataFrame | None  # vehicle: true and INS east/north per variant [m]
    temperatures: pd.DataFrame  # time_s, chamber, outer, sensor_gyro_z ... [°C]
    # per variant: the thermal model's held-out residual on this cold start (thermal_residual)
    residual: dict[str, dict[str, float]] | None = None
    # per variant: the mechanism numbers (experiments.paper.mechanism.alignment_mechanism)
    mechanism: dict[str, dict[str, float]] | None = None


def alignment_config(imu: ImuConfig, total_s: float, start_s: float = 0.0) -> Any:
    """Alignment settings of the cold starts: :func:`rinscal.sim.scenario.align_for` with the
    plant's noise, ``total_s`` [s] of coarse plus fine alignment starting ``start_s`` [s]
    after power-on (free navigation starts at ``start_s + total_s``)."""
    return align_for(imu, total_s=total_s, start_s=start_s)


def run_navigation_job(
    job: NavJob,
    model_texts: Mapping[str, str],
    imu: ImuConfig,
    align_s: float = 600.0,
    align_start_s: float = 0.0,
    out_dt_s: float = 10.0,
    counterfactual: bool = False,
) -> NavRunResult:
    """Run one navigation job with every variant on the same raw IMU output.

    ``model_texts`` maps each method to navigate with to its model file's JSON text (so that
    worker processes need nothing but strings and the plant's configuration); ``none`` and
    the oracle ``true`` are always navigated too. ``imu`` is the plant the
    calibration data came from; the navigation plant is built from it for the scenario
    (its chamber, duration, rate and turntable schedule) with the job's seed.

    ``counterfactual`` adds the variant ``true-no-offsets``
    (:data:`rinscal.experiments.paper.mechanism.ORACLE_NO_OFFSETS`): the true thermal
    errors and the power-on's constant turn-on offsets removed, what noise and the
    alignment alone give (one more navigation of the same raw output).
    """
    align = alignment_config(imu, align_s, align_start_s)
    cfg = preset(job.scenario, hours=job.hours, rate_hz=job.rate_hz, align=align)
    if job.scenario in ("quasi-static", "swing"):
        cfg = replace(cfg, chamber=ChamberProfile.constant(job.ambient_c or LAB_C))
    elif job.scenario == "vehicle" and job.ambient_c is not None:
        cfg = replace(
            cfg, chamber=ChamberProfile((0.0, VEHICLE_WARMUP_S), (job.ambient_c, VEHICLE_CABIN_C))
        )
    out_every = max(1, round(out_dt_s * job.rate_hz))
    cfg = replace(cfg, out_dt_s=out_every / job.rate_hz)
    plant = ThermalPlant.for_scenario(imu, cfg, seed=job.seed)
    comps: dict[str, Any] = {"none": None}
    for m, text in model_texts.items():
        # the one compensator (clamp), fed the plant's 1 s thermometer readings
        comps[m] = ModelCompensator(Compensator(FittedModel.loads(text, m)), plant)
    comps["true"] = oracle_compensator(plant)
    if counterfactual:
        comps[ORACLE_NO_OFFSETS] = _without_offsets(plant)
    res = run_scenario(cfg, plant, comps)
    errors = pd.DataFrame({"time_s": res.errors["none"]["time_s"].to_numpy()})
    for v in comps:
        errors[v] = res.errors[v]["horizontal_m"].to_numpy()
        errors[f"{v}_east"] = res.errors[v]["east_m"].to_numpy()
        errors[f"{v}_north"] = res.errors[v]["north_m"].to_numpy()
        errors[f"{v}_heading"] = res.errors[v]["heading_err"].to_numpy()
        errors[f"{v}_ve"] = res.errors[v]["v_e_err"].to_numpy()
        errors[f"{v}_vn"] = res.errors[v]["v_n_err"].to_numpy()
    track = None
    if job.scenario == "vehicle":
        lat0 = np.deg2rad(res.truth["lat_deg"].iloc[0])
        rn, re = earth.principal_radii(lat0)
        track = pd.DataFrame(
            {
                "time_s": res.truth["time_s"].to_numpy(),
                "true_east_m": np.deg2rad(res.truth["lon_deg"] - res.truth["lon_deg"].iloc[0])
                * re
                * np.cos(lat0),
                "true_north_m": np.deg2rad(res.truth["lat_deg"] - res.truth["lat_deg"].iloc[0])
                * rn,
            }
        )
        for v in comps:
            e = res.errors[v]
            track[f"{v}_east_m"] = track["true_east_m"] + e["east_m"].to_numpy()
            track[f"{v}_north_m"] = track["true_north_m"] + e["north_m"].to_numpy()
    temps = temperature_frame(plant, step_s=60.0)
    grid = np.arange(cfg.align_start_s, float(plant.field.t[-1]) - 1.0, 1.0)
    truth = plant.thermal_bias(grid)
    estimates = {v: _estimate_on(c, grid, truth) for v, c in comps.items()}
    residual = {v: thermal_residual(est, truth) for v, est in estimates.items()}
    mech = alignment_mechanism(
        cfg, grid, {v: truth - est for v, est in estimates.items()}, plant.offsets
    )
    return NavRunResult(job, res.summary(), errors, track, temps, residual, mech)


def _without_offsets(plant: ThermalPlant) -> Any:
    """The oracle plus the run's turn-on offsets, as a compensator (see
    :func:`run_navigation_job`'s ``counterfactual``)."""

    def comp(t: np.ndarray, omega_r: np.ndarray, f_r: np.ndarray) -> np.ndarray:
        return plant.oracle(t, omega_r, f_r) + plant.offsets

    return comp


def _estimate_on(comp: Any, grid: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """A variant's thermal-bias estimate on ``grid`` [s], (n, 6) SI: none (zero), a model
    (what its compensator subtracts, the 1 s thermometer readings held) or the oracle."""
    if comp is None:
        return np.zeros_like(truth)
    if isinstance(comp, ModelCompensator):
        return np.asarray(comp(grid), dtype=float)  # its reading held, as in navigation
    return truth


#: Columns of :func:`thermal_residual`, with their units.
RESIDUAL_COLUMNS = {
    "gyro_residual_dph": "deg/h",
    "accel_residual_ug": "ug",
    "accel_residual_pct": "%",
}


def thermal_residual(estimate: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """How well a thermal model followed the true thermal bias over one cold start.

    The measure is the one of the held-out fractions of ``docs/plant.md``: the residual
    (estimate − truth) about its mean over the run, RMS, against the true bias's own swing
    (RMS about its mean). The mean is left out because the alignment absorbs a constant
    (levelling takes up a horizontal accelerometer bias, gyrocompassing turns an east gyro
    bias into heading error, which the heading-error column shows); what the model gets
    wrong *during* the run is what modulation and the INS then integrate. The vertical
    accelerometer is left out: its model also holds the scale-factor error at 1 g, which
    the plant applies to the signal, not to the bias, and the vertical channel is damped.

    Parameters
    ----------
    estimate, truth : ndarray, shape (n, 6) [rad/s ×3, m/s² ×3]
        The model's bias estimate and the plant's true thermal bias (Shupe and hysteresis
        included) on one time grid from the alignment start to the end of the run.

    Returns
    -------
    dict
        ``gyro_residual_dph`` [°/h]: the largest of the three gyros' residual RMS;
        ``accel_residual_ug`` [µg]: the largest of the horizontal accelerometers' (x, y);
        ``accel_residual_pct`` [%]: the larger of x's and y's residual as a percentage of
        that channel's true swing (100 % for no compensation, 0 for the oracle).
    """
    d = estimate - truth
    d = d - d.mean(axis=0)
    rms = np.sqrt(np.mean(d**2, axis=0))
    swing = np.sqrt(np.mean((truth - truth.mean(axis=0)) ** 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        pct = np.where(swing[3:5] > 0, 100.0 * rms[3:5] / swing[3:5], np.nan)
    return {
        "gyro_residual_dph": float(rms[:3].max() / units.DPH_TO_RPS),
        "accel_residual_ug": float(rms[3:5].max() / units.UG_TO_MPS2),
        "accel_residual_pct": float(np.nanmax(pct)) if np.any(np.isfinite(pct)) else math.nan,
    }


def navigation_stage(
    cfg: ReproConfig,
    models: Mapping[str, FittedModel],
    done: Callable[[NavRunResult], None] | None = None,
    imu: ImuConfig | None = None,
    extra: Mapping[str, FittedModel] | None = None,
    client: Any = None,
) -> list[NavRunResult]:
    """Run every navigation job; on the Dask ``client``'s workers, else with ``cfg.jobs > 1``
    on a Dask ``LocalCluster`` of that many worker processes
    (:func:`rinscal.cluster.dask_client`); the results in job order.

    ``imu`` is the plant (default: :func:`load_plant` of ``cfg.imu``); pass the one the
    calibration stage simulated so that both stages run the same IMU. ``extra`` models are
    navigated beside :data:`METHODS` on the same raw output (e.g. ``regression+sf``).
    """
    imu = imu or load_plant(cfg.imu)
    texts = {m: json.dumps(models[m].to_dict()) for m in METHODS}
    texts.update({m: json.dumps(mf.to_dict()) for m, mf in (extra or {}).items()})
    jobs = navigation_jobs(cfg)
    alignment_config(imu, cfg.align_s, cfg.align_start_s)  # refuse bad settings before forking
    args = (texts, imu, cfg.align_s, cfg.align_start_s, 10.0, True)
    if client is None and cfg.jobs == 1:
        results: list[NavRunResult] = []
        for job in jobs:
            r = run_navigation_job(job, *args)
            results.append(r)
            if done:
                done(r)
        return results
    if client is None:
        with dask_client(workers=cfg.jobs) as own:
            return _on_cluster(own, jobs, args, done)
    return _on_cluster(client, jobs, args, done)


def _on_cluster(
    client: Any,
    jobs: Sequence[NavJob],
    args: tuple[Any, ...],
    done: Callable[[NavRunResult], None] | None,
) -> list[NavRunResult]:
    """The jobs on the client's workers; the results in job order."""
    from distributed import as_completed  # deferred: Dask only for parallel jobs

    futures = [
        client.submit(run_navigation_job, j, *args, key=f"nav-{i:03d}", pure=False)
        for i, j in enumerate(jobs)
    ]
    done_by_key = {}
    for fut in as_completed(futures):
        r = fut.result()
        done_by_key[fut.key] = r
        if done:
            done(r)
    return [done_by_key[f.key] for f in futures]


def thermal_part_m(errors: pd.DataFrame, variant: str) -> np.ndarray:
    """Horizontal position error a variant owes to its thermal-model error alone [m].

    Every variant navigates on the same raw output, and the navigation errors are linear in
    small sensor errors, so the difference between a variant's position error and the
    oracle's (compensated with the true thermal bias) is the error caused by what the model
    got wrong; noise, turn-on offsets and alignment errors cancel out of it.
    """
    de = errors[f"{variant}_east"] - errors["true_east"]
    dn = errors[f"{variant}_north"] - errors["true_north"]
    return np.hypot(de.to_numpy(), dn.to_numpy())


def _run_key(r: NavRunResult) -> dict[str, Any]:
    """The columns that name a navigation run in every per-run table."""
    return {"experiment": r.job.experiment, "scenario": r.job.scenario, "number": r.job.index}


def thermal_part_table(results: Sequence[NavRunResult]) -> pd.DataFrame:
    """Maximum of :func:`thermal_part_m` per run and variant [nmi]."""
    rows = []
    for r in results:
        row = _run_key(r)
        for v in VARIANTS:
            if v != "true":
                row[v] = float(thermal_part_m(r.errors, v).max()) / units.NMI_TO_M
        rows.append(row)
    return pd.DataFrame(rows)


def max_error_table(results: Sequence[NavRunResult]) -> pd.DataFrame:
    """Maximum horizontal position error per run and variant [nmi] (Figure 13, Table 10)."""
    rows = []
    for r in results:
        row = _run_key(r)
        row["ambient_c"] = r.job.ambient_c if r.job.ambient_c is not None else float("nan")
        row["hours"] = r.summary["duration_s"] / units.HOUR_TO_S
        for v in VARIANTS:
            row[v] = r.summary["variants"][v]["max_error_nmi"]
        rows.append(row)
    return pd.DataFrame(rows)


def variant_table(results: Sequence[NavRunResult], variants: Sequence[str]) -> pd.DataFrame:
    """Maximum horizontal position error [nmi] and heading error at the start of free
    navigation [arcsec] per run of the given variants (those a run navigated)."""
    rows = []
    for r in results:
        row = _run_key(r)
        got = r.summary.get("variants", {})
        for v in variants:
            s = got.get(v, {})
            att = s.get("attitude_error_at_nav_start") or {}
            row[v] = s.get("max_error_nmi", float("nan"))
            row[f"{v} heading [arcsec]"] = float(att.get("heading_arcsec", float("nan")))
        rows.append(row)
    return pd.DataFrame(rows)


def heading_error_table(results: Sequence[NavRunResult]) -> pd.DataFrame:
    """Heading error at the start of free navigation per run and variant [arcsec].

    Read from each run's navigation summary (``attitude_error_at_nav_start``); NaN where
    the summary does not report it.
    """
    rows = []
    for r in results:
        row = _run_key(r)
        variants = r.summary.get("variants", {})
        for v in VARIANTS:
            att = variants.get(v, {}).get("attitude_error_at_nav_start") or {}
            h = att.get("heading_arcsec")
            row[v] = float(h) if h is not None else float("nan")
        rows.append(row)
    return pd.DataFrame(rows)
