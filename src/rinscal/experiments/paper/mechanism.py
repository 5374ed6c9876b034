"""Why navigation runs differ: the mechanism numbers of each run and variant, and the
oracle's decomposition of each run's error into the thermal part and the rest.

The chain a navigation engineer checks, per run and variant, on the *residual* thermal bias
(the plant's true thermal bias minus what the variant subtracts, i.e. what the alignment
and the navigation see):

1. the horizontal accelerometer residual's rate and the horizontal gyro residual during the
   fine alignment, in the IMU frame [µg/min, °/h];
2. the heading error measured at the start of free navigation, and beside it, only where
   the table held still through the fine alignment, the one the textbook gyrocompass
   formula predicts (:func:`rinscal.nav.metrics.gyrocompass_heading_error`, the residual
   resolved with the attitude at each instant): with the table indexing the filter
   estimates the horizontal biases and the formula does not apply;
3. the bias change within one modulation period (rotation modulation assumes it constant);
4. the error growth: drift rate [nmi/h] beside the maximum, and the CEP of each group.

The oracle's decomposition uses one more variant navigated on the same raw output,
``true-no-offsets`` (the true thermal errors *and* the power-on's constant turn-on offsets
removed): what noise and the alignment alone give. Because every variant navigates the
same raw output and the errors are linear in small sensor errors, a run's error vector is
the sum of its thermal part (none − oracle), the turn-on offsets' part (oracle −
true-no-offsets) and the rest (true-no-offsets: noise, bias random walk, outliers, the
size effect and the alignment's own errors).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal import earth, units
from rinscal.experiments.paper.config import VARIANTS, group_label
from rinscal.nav.metrics import (
    cep50,
    drift_rate,
    gyrocompass_heading_error,
    max_change_within,
    slope,
)
from rinscal.nav.rotation import C_br
from rinscal.sim.scenario_config import ScenarioConfig
from rinscal.sim.trajectory import C_nb_from_euler

__all__ = [
    "MIN_CEP_RUNS",
    "ORACLE_NO_OFFSETS",
    "ORACLE_NO_OFFSETS_LABEL",
    "PREDICTED_COLUMN",
    "alignment_mechanism",
    "error_growth_table",
    "fixed_imu_heading_error",
    "group_cep_table",
    "mechanism_summary",
    "mechanism_table",
    "mechanism_tables",
    "modulation_table",
    "oracle_decomposition_table",
    "oracle_loss_reasons",
]

#: The counterfactual variant: true thermal errors and turn-on offsets removed.
ORACLE_NO_OFFSETS = "true-no-offsets"
#: Its name in the report.
ORACLE_NO_OFFSETS_LABEL = "oracle without turn-on offsets"
#: The fewest runs a CEP is given for (the median of fewer is one run's error).
MIN_CEP_RUNS = 2


def _C_nr(config: ScenarioConfig, t: np.ndarray) -> np.ndarray:
    """True attitude of the IMU frame at ``t`` [s], (n, 3, 3)."""
    kin = config.trajectory.kinematics(t)
    return C_nb_from_euler(kin.euler) @ C_br(config.schedule.angle(t))


def alignment_mechanism(
    config: ScenarioConfig,
    grid: np.ndarray,
    residual: Mapping[str, np.ndarray],
    offsets: np.ndarray,
) -> dict[str, dict[str, float]]:
    """The mechanism numbers of one run, per variant.

    The residual is a bias in the IMU frame ``r``; the gyrocompass formula
    (:func:`rinscal.nav.metrics.gyrocompass_heading_error`) needs it levelled, in ``n``.
    Each sample of the fine alignment is resolved with the true attitude at its own
    instant (``C_nr(t)``, trajectory and table angle), never with one attitude for the
    whole alignment. The formula's prediction is given only where the table holds still
    through the fine alignment: with the table indexing, the filter of
    :mod:`rinscal.nav.align` separates the horizontal biases from the tilt and its
    Gauss-Markov bias states follow a drift, so its heading error is set by how they
    follow it, which the formula does not describe (``tests/experiments/
    test_mechanism_prediction.py`` measures both cases against the filter).

    Parameters
    ----------
    config : ScenarioConfig
        The run (trajectory, turntable schedule, alignment).
    grid : ndarray, shape (n,) [s]
        Uniform times (since power-on) from the alignment start to the end of the run.
    residual : mapping of str to ndarray, shape (n, 6) [rad/s ×3, m/s² ×3]
        Per variant, the residual thermal bias on ``grid`` in ``r``: true thermal bias
        minus what the variant subtracts.
    offsets : ndarray, shape (6,) [rad/s ×3, m/s² ×3]
        The run's turn-on offsets.

    Returns
    -------
    dict of str to dict
        Per variant: ``accel_rate_ug_min`` (the horizontal accelerometers' residual rate
        in the IMU frame, the length of the least-squares slopes of x and y over the fine
        alignment) [µg/min]; ``gyro_h_dph`` (the horizontal gyros' residual in the IMU
        frame, length of their means over the fine alignment) [°/h];
        ``predicted_heading_arcsec`` (the fixed-IMU gyrocompass formula with the levelled
        north accelerometer rate, the east gyro residual and the east accelerometer
        residual at the hand-over, each resolved at its instant; NaN where the table
        turns during the fine alignment) [″]; ``accel_change_period_ug`` and
        ``gyro_change_period_dph`` (largest peak-to-peak change of a horizontal residual
        within any window of one modulation period during free navigation) [µg, °/h];
        ``accel_change_period_align_ug`` (the same for the accelerometers during the
        alignment, warm-up transient included) [µg]; ``gyro_z_nav_dph`` (the vertical
        gyro's residual, mean over free navigation: unmodulated, it turns heading at that
        rate) [°/h]; ``gyro_z_offset_dph`` (the vertical gyro's turn-on offset) [°/h].
    """
    al = config.align
    lat = config.trajectory.lat0
    a0 = config.align_start_s + (al.coarse_s if al is not None else 0.0)
    t_nav = config.nav_start_s
    fine = (grid >= a0) & (grid <= t_nav)
    nav = grid >= t_nav
    period = config.schedule.period if config.schedule.period > 0 else 60.0
    g = float(earth.gravity(lat, config.trajectory.alt0))
    t_fine = grid[fine]
    still = t_fine.size >= 2 and np.ptp(config.schedule.angle(t_fine)) == 0.0
    C_fine = _C_nr(config, t_fine) if still else None
    out: dict[str, dict[str, float]] = {}
    for v, d in residual.items():
        k_r = slope(t_fine, d[fine, 3:5]) if t_fine.size >= 2 else np.full(2, np.nan)
        eps_r = d[fine, 0:2].mean(axis=0) if t_fine.size else np.full(2, np.nan)
        pred = math.nan
        if C_fine is not None:
            pred = fixed_imu_heading_error(lat, g, t_fine, C_fine, d[fine])
        ch = (
            max_change_within(grid[nav], d[nav][:, [0, 1, 3, 4]], period)
            if np.count_nonzero(nav) >= 2
            else np.full(4, np.nan)
        )
        ch_al = max_change_within(grid[~nav], d[~nav][:, [3, 4]], period)
        out[v] = {
            "accel_rate_ug_min": float(np.hypot(*k_r) * 60.0 / units.UG_TO_MPS2),
            "gyro_h_dph": float(np.hypot(*eps_r) / units.DPH_TO_RPS),
            "predicted_heading_arcsec": float(pred / units.ARCSEC_TO_RAD),
            "accel_change_period_ug": float(ch[2:].max() / units.UG_TO_MPS2),
            "gyro_change_period_dph": float(ch[:2].max() / units.DPH_TO_RPS),
            "accel_change_period_align_ug": float(ch_al.max() / units.UG_TO_MPS2),
            "gyro_z_nav_dph": float(d[nav, 2].mean() / units.DPH_TO_RPS)
            if np.any(nav)
            else math.nan,
            "gyro_z_offset_dph": float(offsets[2] / units.DPH_TO_RPS),
        }
    return out


def fixed_imu_heading_error(
    lat: float, g: float, t: np.ndarray, C_nr: np.ndarray, d: np.ndarray
) -> float:
    """The gyrocompass formula on a residual resolved at each instant [rad].

    ``t`` [s] the fine alignment's times, ``C_nr`` (n, 3, 3) the true attitude at each,
    ``d`` (n, 6) [rad/s ×3, m/s² ×3] the residual in ``r``: the levelled north
    accelerometer's least-squares rate, the east gyro's mean and the east accelerometer at
    the hand-over (last sample) go into
    :func:`rinscal.nav.metrics.gyrocompass_heading_error`.
    """
    eps_n = np.einsum("kij,kj->ki", C_nr, d[:, 0:3])
    f_n = np.einsum("kij,kj->ki", C_nr, d[:, 3:6])
    return gyrocompass_heading_error(
        lat,
        accel_rate_n=float(slope(t, f_n[:, 1])),
        gyro_e=float(eps_n[:, 0].mean()),
        accel_e=float(f_n[-1, 0]),
        g=g,
    )


def _run_name(r: Any) -> str:
    short = {"quasi-static": "quasi-static", "swing": "swing", "vehicle": "vehicle"}
    return f"{short.get(r.job.scenario, r.job.scenario)} {r.job.index}"


def _variants_of(r: Any, variants: Sequence[str] | None) -> list[str]:
    got = r.summary.get("variants", {})
    want = list(variants) if variants is not None else [*VARIANTS, ORACLE_NO_OFFSETS]
    return [v for v in want if v in got]


def _heading(r: Any, v: str) -> float:
    att = r.summary["variants"].get(v, {}).get("attitude_error_at_nav_start") or {}
    return float(att.get("heading_arcsec", math.nan))


#: The mechanism table's column of the fixed-IMU prediction (present only where a run's
#: table held still through its fine alignment).
PREDICTED_COLUMN = "predicted δψ, table still [″]"


def mechanism_table(results: Sequence[Any], variants: Sequence[str] | None = None) -> pd.DataFrame:
    """Alignment mechanism per run and variant: the residual's horizontal accelerometer rate
    and gyro bias in the IMU frame [µg/min, °/h], the measured heading error at the start of
    navigation and its thermal part (variant − oracle) [″]; beside them
    :data:`PREDICTED_COLUMN`, the fixed-IMU formula's heading error [″], only when some run's
    table held still through its fine alignment (the formula does not describe an indexing
    alignment, see :func:`alignment_mechanism`)."""
    rows = []
    for r in results:
        mech = r.mechanism or {}
        h_true = _heading(r, "true")
        for v in _variants_of(r, variants):
            m = mech.get(v)
            if m is None:
                continue
            h = _heading(r, v)
            rows.append(
                {
                    "run": _run_name(r),
                    "variant": v,
                    "accel rate, IMU x-y [µg/min]": m["accel_rate_ug_min"],
                    "gyro, IMU x-y [°/h]": m["gyro_h_dph"],
                    PREDICTED_COLUMN: m["predicted_heading_arcsec"],
                    "measured δψ [″]": h,
                    "thermal part of δψ [″]": h - h_true,
                }
            )
    df = pd.DataFrame(rows)
    if PREDICTED_COLUMN in df and not np.isfinite(df[PREDICTED_COLUMN].to_numpy(float)).any():
        df = df.drop(columns=PREDICTED_COLUMN)
    return df


def modulation_table(results: Sequence[Any], variants: Sequence[str] | None = None) -> pd.DataFrame:
    """Bias change within one modulation period and the vertical gyro's residual per run
    and variant."""
    rows = []
    for r in results:
        mech = r.mechanism or {}
        for v in _variants_of(r, variants):
            m = mech.get(v)
            if m is None:
                continue
            rows.append(
                {
                    "run": _run_name(r),
                    "variant": v,
                    "accel Δb in a period, alignment [µg]": m["accel_change_period_align_ug"],
                    "accel Δb in a period, nav [µg]": m["accel_change_period_ug"],
                    "gyro Δb in a period, nav [°/h]": m["gyro_change_period_dph"],
                    "z gyro residual in nav [°/h]": m["gyro_z_nav_dph"],
                    "z gyro turn-on offset [°/h]": m["gyro_z_offset_dph"],
                }
            )
    return pd.DataFrame(rows)


def error_growth_table(
    results: Sequence[Any], variants: Sequence[str] | None = None
) -> pd.DataFrame:
    """Maximum, final radial error and drift rate (least-squares slope of the radial error
    against time over free navigation) per run and variant [nmi, nmi/h]."""
    rows = []
    for r in results:
        e = r.errors
        t = e["time_s"].to_numpy()
        for v in _variants_of(r, variants):
            h = e[v].to_numpy()
            rows.append(
                {
                    "run": _run_name(r),
                    "variant": v,
                    "max [nmi]": float(h.max()) / units.NMI_TO_M,
                    "final [nmi]": float(h[-1]) / units.NMI_TO_M,
                    "drift rate [nmi/h]": drift_rate(t, h) * units.HOUR_TO_S / units.NMI_TO_M,
                }
            )
    return pd.DataFrame(rows)


def group_cep_table(growth: pd.DataFrame, results: Sequence[Any]) -> pd.DataFrame:
    """CEP per group of runs and variant: the median of the runs' final radial errors
    [nmi], beside the median maximum and the median drift rate; ``n runs`` the group size.
    A group of fewer than :data:`MIN_CEP_RUNS` runs has no CEP (NaN): one run's error is
    not a circle holding half the runs."""
    group = {_run_name(r): group_label(r.job.experiment, r.job.scenario) for r in results}
    g = growth.assign(group=growth["run"].map(group))
    rows = []
    for (grp, v), d in g.groupby(["group", "variant"], sort=False):
        rows.append(
            {
                "runs": grp,
                "variant": v,
                "n runs": len(d),
                "CEP (median final) [nmi]": (
                    cep50(d["final [nmi]"]) if len(d) >= MIN_CEP_RUNS else float("nan")
                ),
                "median max [nmi]": float(d["max [nmi]"].median()),
                "median drift [nmi/h]": float(d["drift rate [nmi/h]"].median()),
            }
        )
    return pd.DataFrame(rows)


def _vec(e: pd.DataFrame, v: str) -> np.ndarray:
    return np.column_stack([e[f"{v}_east"].to_numpy(), e[f"{v}_north"].to_numpy()])


def oracle_decomposition_table(results: Sequence[Any]) -> pd.DataFrame:
    """Each run's error split into the thermal part and the rest [nmi].

    ``none``, ``oracle`` and ``oracle w/o offsets`` are maximum radial errors;
    ``thermal part (none − oracle)`` is the signed difference of the maxima (negative:
    compensating the true thermal bias made the run worse); ``angle thermal/rest [°]`` is
    the angle between the thermal part's error vector (none − oracle) and the rest's (the
    oracle's) at the time of the oracle's maximum: above 90° they cancel, so the run
    without compensation navigates better than the oracle.
    """
    rows = []
    for r in results:
        e = r.errors
        if "true" not in r.summary.get("variants", {}):
            continue
        k = int(np.argmax(e["true"].to_numpy()))
        thermal = _vec(e, "none")[k] - _vec(e, "true")[k]
        rest = _vec(e, "true")[k]
        den = float(np.linalg.norm(thermal) * np.linalg.norm(rest))
        ang = math.degrees(math.acos(np.clip(thermal @ rest / den, -1, 1))) if den > 0 else math.nan
        none = float(e["none"].max()) / units.NMI_TO_M
        orc = float(e["true"].max()) / units.NMI_TO_M
        nooff = (
            float(e[ORACLE_NO_OFFSETS].max()) / units.NMI_TO_M
            if ORACLE_NO_OFFSETS in e
            else math.nan
        )
        rows.append(
            {
                "run": _run_name(r),
                "none [nmi]": none,
                "oracle [nmi]": orc,
                "oracle w/o offsets [nmi]": nooff,
                "thermal part (none − oracle) [nmi]": none - orc,
                "angle thermal/rest [°]": ang,
                "oracle δψ [″]": _heading(r, "true"),
                "w/o offsets δψ [″]": _heading(r, ORACLE_NO_OFFSETS),
            }
        )
    return pd.DataFrame(rows)


def oracle_loss_reasons(
    decomposition: pd.DataFrame, modulation: pd.DataFrame
) -> list[dict[str, Any]]:
    """The runs where the oracle loses to no compensation, with the numbers that say why.

    Returns
    -------
    list of dict
        One per such run: ``run``, ``none_nmi``, ``oracle_nmi``, ``no_offsets_nmi``,
        ``angle_deg`` (thermal part against the rest, see
        :func:`oracle_decomposition_table`), ``offsets_cost_nmi`` (oracle − oracle without
        offsets, maxima), ``gyro_z_thermal_dph`` (none's vertical gyro thermal residual in
        navigation) and ``gyro_z_offset_dph`` (the turn-on offset), ``z_cancel`` (True
        when the two have opposite signs: the uncompensated thermal drift of the vertical
        gyro partly cancelled the offset, which the oracle leaves alone).
    """
    out = []
    mod = modulation[modulation["variant"] == "none"].set_index("run")
    for row in decomposition.itertuples(index=False):
        d = row._asdict()
        vals = list(d.values())
        run, none, orc, nooff, _, ang = vals[:6]
        if not (orc > none):
            continue
        zt = float(mod.loc[run, "z gyro residual in nav [°/h]"]) if run in mod.index else math.nan
        zo = float(mod.loc[run, "z gyro turn-on offset [°/h]"]) if run in mod.index else math.nan
        out.append(
            {
                "run": run,
                "none_nmi": none,
                "oracle_nmi": orc,
                "no_offsets_nmi": nooff,
                "angle_deg": ang,
                "offsets_cost_nmi": orc - nooff,
                "gyro_z_thermal_dph": zt,
                "gyro_z_offset_dph": zo,
                "z_cancel": bool(np.isfinite(zt) and np.isfinite(zo) and zt * zo < 0),
            }
        )
    return out


def mechanism_summary(
    mechanism: pd.DataFrame, decomposition: pd.DataFrame, modulation: pd.DataFrame
) -> dict[str, Any]:
    """The numbers the report words the mechanism and the oracle with.

    Returns
    -------
    dict
        ``n_runs``; over the runs' uncompensated variant: ``median_accel_rate_ug_min``
        (horizontal accelerometer residual rate in the IMU frame) [µg/min],
        ``median_abs_thermal_heading_arcsec`` (measured thermal part of δψ, absolute) [″];
        ``n_predicted`` (runs with a fixed-IMU prediction: the table held still through the
        fine alignment) and over those ``median_abs_predicted_arcsec`` [″], ``same_sign``
        (predicted and measured thermal part share a sign) and ``attenuation`` (median
        |measured thermal part| / |predicted|); ``oracle_loses`` (runs where the oracle's
        maximum exceeds no compensation's), ``oracle_losses`` (:func:`oracle_loss_reasons`),
        ``median_offsets_cost_nmi`` (oracle − oracle without offsets, maxima, median over
        runs) [nmi].
    """
    none = mechanism[mechanism["variant"] == "none"]
    meas_all = none["thermal part of δψ [″]"].to_numpy(dtype=float)
    pred = (
        none[PREDICTED_COLUMN].to_numpy(dtype=float)
        if PREDICTED_COLUMN in none
        else np.full(len(none), np.nan)
    )
    ok = np.isfinite(pred)
    pred, meas = pred[ok], meas_all[ok]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(meas) / np.abs(pred)
    losses = oracle_loss_reasons(decomposition, modulation)
    d = decomposition
    cost = (d["oracle [nmi]"] - d["oracle w/o offsets [nmi]"]).to_numpy(dtype=float)
    return {
        "n_runs": len(d),
        "median_accel_rate_ug_min": float(np.median(none["accel rate, IMU x-y [µg/min]"]))
        if len(none)
        else math.nan,
        "median_abs_thermal_heading_arcsec": float(np.median(np.abs(meas_all)))
        if meas_all.size
        else math.nan,
        "n_predicted": int(ok.sum()),
        "median_abs_predicted_arcsec": float(np.median(np.abs(pred))) if pred.size else math.nan,
        "same_sign": int(np.sum(np.sign(pred) == np.sign(meas))),
        "attenuation": float(np.nanmedian(ratio)) if np.any(np.isfinite(ratio)) else math.nan,
        "oracle_loses": len(losses),
        "oracle_losses": losses,
        "median_offsets_cost_nmi": float(np.nanmedian(cost))
        if np.any(np.isfinite(cost))
        else math.nan,
    }


def mechanism_tables(results: Sequence[Any]) -> dict[str, pd.DataFrame]:
    """The mechanism and oracle tables of the reproduction: ``mechanism``, ``modulation``,
    ``error_growth``, ``cep`` and ``oracle_decomposition`` (every variant)."""
    growth = error_growth_table(results)
    return {
        "mechanism": mechanism_table(results),
        "modulation": modulation_table(results),
        "error_growth": growth,
        "cep": group_cep_table(growth, results),
        "oracle_decomposition": oracle_decomposition_table(results),
    }
