"""The paper's Tables 4-9 beside the true plant's values and ours, in physical units, and
the recovery of the plant's coefficients by method 2.

The paper prints its coefficients and RMS in the IMU's output pulses. Its own static
outputs give their scale (:func:`paper_pulse_scales`): ``A0z`` is gravity at the lab, so
one accelerometer pulse is ``g / A0z`` ≈ 2.147 µg; ``G0x`` and ``G0z`` are the Earth rate's
north and up components ``Ω cos L`` and ``Ω sin L``, so one x pulse is ≈ 0.00173 °/h and one
z pulse ≈ 0.00221 °/h (y, with no static reference, their mean). These are the scales the
``paper`` preset was converted with (``src/rinscal/data/paper.toml``).

:func:`table4_vs_paper`, :func:`selection_vs_paper` (Tables 5 and 7), :func:`table6_vs_paper`,
:func:`table8_vs_paper`, :func:`table9_vs_paper`
    Each table as the paper lays it out, the paper's value, the true plant's (where the
    plant has one) and ours side by side, every value in µg, °/h and their powers of °C
    and °C/min.
:func:`noise_floor`
    The white-noise RMS of each channel per sample at the log's rate: the floor under any
    RMS of Tables 5 and 7.
:func:`regression_recovery`
    Method 2's fitted coefficients against the plant's, with 95 % intervals from a
    bootstrap over the soak runs (each run's residual series resampled whole), and the same
    regression fitted to the noise-free true thermal bias.
:func:`ramp_outside_training`
    The fraction of the chamber ramp's samples whose inputs lie outside the soak training
    range (what Figure 9 tests: the clamp).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from rinscal import earth, units
from rinscal.calibration.allan_units import datasheet_units
from rinscal.calibration.compensate import model_features, predict_log
from rinscal.calibration.inference import raw_polynomial
from rinscal.calibration.modelfile import FittedModel
from rinscal.calibration.selection.heldout import SelectionResult
from rinscal.calibration.thermal.features import OutlierConfig
from rinscal.experiments.paper.config import PAPER_TABLES
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig
from rinscal.sim.trajectory import (
    QUASI_STATIC_HEADING_DEG,
    SWING_AMPLITUDES_DEG,
    SWING_PERIODS_S,
)

__all__ = [
    "INPUTS",
    "allan_by_sensor",
    "coefficient_unit",
    "noise_floor",
    "paper_pulse_scales",
    "plant_coefficients",
    "ramp_outside_training",
    "regression_recovery",
    "selection_vs_paper",
    "sensor_unit",
    "step_noise_sd",
    "table4_vs_paper",
    "table6_vs_paper",
    "table8_vs_paper",
    "table9_vs_paper",
]

#: The thermal inputs, in the order of every model: temperature, its rate, the gradient.
INPUTS = ("T", "Ṫ", "ΔT")
_SUP = {1: "", 2: "²", 3: "³", 4: "⁴"}


def sensor_unit(channel: str) -> str:
    """The physical log unit of a channel: ``"°/h"`` for gyros, ``"µg"`` for accelerometers."""
    return "°/h" if channel.startswith("gyro") else "µg"


def coefficient_unit(channel: str, term: str) -> str:
    """Unit of a polynomial coefficient: ``a0`` → µg; ``T^2`` → µg/°C²; ``Ṫ^1`` →
    µg/(°C/min); ``ΔT^3`` → µg/°C³ (°/h for gyros)."""
    u = sensor_unit(channel)
    if term == "a0":
        return u
    var, k = term.split("^")
    if var == "Ṫ":
        return f"{u}/(°C/min){_SUP[int(k)]}"
    return f"{u}/°C{_SUP[int(k)]}"


def paper_pulse_scales() -> dict[str, float]:
    """The physical value of one of the paper's pulses, per channel [µg or °/h per pulse].

    Read from the paper's own Table 6: ``A0z`` is gravity at the lab (Nanjing, 32.06° N,
    10 m), ``G0x`` the north Earth rate ``Ω cos L`` (x pointed north), ``G0z`` the vertical
    ``Ω sin L``; the y gyro, with no static reference, takes the mean of x and z.
    """
    t6 = PAPER_TABLES["table6"]
    lat = math.radians(PAPER_TABLES["lab_latitude_deg"])
    g_ug = float(earth.gravity(lat, PAPER_TABLES["lab_altitude_m"])) / units.UG_TO_MPS2
    omega_dph = earth.RATE / units.DPH_TO_RPS
    accel = g_ug / t6["accel_z"]["a0"]
    gx = omega_dph * math.cos(lat) / t6["gyro_x"]["a0"]
    gz = omega_dph * math.sin(lat) / t6["gyro_z"]["a0"]
    return {
        "gyro_x": gx,
        "gyro_y": 0.5 * (gx + gz),
        "gyro_z": gz,
        "accel_x": accel,
        "accel_y": accel,
        "accel_z": accel,
    }


def noise_floor(imu: ImuConfig, rate_hz: float) -> dict[str, float]:
    """White-noise RMS of one sample per channel at ``rate_hz`` [°/h or µg].

    A sample is the mean over its interval ``1/rate_hz`` of white noise of density ``N``
    (the plant's angle or velocity random walk), so its standard deviation is
    ``N √rate_hz``: the smallest RMS any thermal model can leave on a log of that rate.
    """
    dens = imu.noise.white_density_si() * math.sqrt(rate_hz)
    scale = [units.DPH_TO_RPS] * 3 + [units.UG_TO_MPS2] * 3
    return {c: float(d / s) for c, d, s in zip(CHANNELS, dens, scale, strict=True)}


def step_noise_sd(floor: float, rate_hz: float, window_s: float) -> float:
    """Standard deviation of a step measured on white noise alone [unit of ``floor``].

    A step at a crossing is the difference of two straight lines, fitted on ``window_s``
    before and after it and each extrapolated to the crossing: a line fitted to ``n``
    evenly spaced samples of noise ``σ`` has variance ``σ²(1/n + 3/n) = 4σ²/n`` at the end
    of its window, so the difference has ``σ √(8/n)`` with ``n = window_s · rate_hz``.
    """
    n = window_s * rate_hz
    return float(floor * math.sqrt(8.0 / n))


def allan_by_sensor(allan: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """The Allan noise parameters of :func:`rinscal.calibration.evaluate.allan_table` (log
    units deg/h and ug) per sensor, each in the unit its data sheet uses.

    Gyros: N, the angle random walk [°/√h] (= N [(°/h)·√s] / 60), B [°/h], K, the rate
    random walk [°/h/√h] (= K [(°/h)/√s] · 60). Accelerometers: N, the velocity random walk
    [µg/√Hz] (= µg·√s), B [µg], K [µg/√s].

    Returns
    -------
    dict of str to DataFrame
        ``gyro`` and ``accel``: ``axis, output, N [...], B [...], τ(B) [s], K [...]``.
    """
    out = {}
    for sensor, log_unit in (("gyro", "deg/h"), ("accel", "ug")):
        u = datasheet_units(log_unit)
        t = allan[allan["channel"].str.startswith(sensor)]
        out[sensor] = pd.DataFrame(
            {
                "axis": t["channel"].str.split("_").str[1].to_numpy(),
                "output": t["output"].to_numpy(),
                f"N [{u.n_unit}]": t["n"].to_numpy(dtype=float) * u.n_factor,
                f"B [{u.b_unit}]": t["b"].to_numpy(dtype=float),
                "τ(B) [s]": t["b_tau_s"].to_numpy(dtype=float),
                f"K [{u.k_unit}]": t["k"].to_numpy(dtype=float) * u.k_factor,
            }
        )
    return out


# --------------------------------------------------------------------------- the plant's law
def plant_coefficients(imu: ImuConfig, channel: str) -> dict[str, float] | None:
    """The plant's thermal-bias polynomial of a channel in the paper's raw form.

    Powers of the absolute temperature ``T`` [°C] (the plant's polynomial in ``T − t_ref``
    expanded), of ``Ṫ`` [°C/min] and ``ΔT`` [°C], in log units (°/h, µg): keys ``T^k``,
    ``Ṫ^k``, ``ΔT^k``. None for a mechanistic plant (no such coefficients exist).
    """
    if imu.thermal_law != "polynomial":
        return None
    th = imu.thermal[CHANNELS.index(channel)]
    out: dict[str, float] = {}
    t = np.asarray(th.t, dtype=float)
    raw = np.zeros(t.size + 1)
    for k, c in enumerate(t, start=1):  # c (T − t0)^k = Σ_i c C(k,i) T^i (−t0)^(k−i)
        for i in range(k + 1):
            raw[i] += c * math.comb(k, i) * (-imu.t_ref_c) ** (k - i)
    for k in range(1, t.size + 1):
        out[f"T^{k}"] = float(raw[k])
    for name, coefs in (("Ṫ", th.rate), ("ΔT", th.grad)):
        for k, c in enumerate(coefs, start=1):
            out[f"{name}^{k}"] = float(c)
    return out


def _terms(orders: tuple[int, ...] | list[int]) -> list[str]:
    return ["a0"] + [f"{INPUTS[v]}^{k}" for v, p in enumerate(orders) for k in range(1, p + 1)]


def _flat(raw: Mapping[str, Any]) -> dict[str, float]:
    out = {"a0": float(raw["a0"])}
    for v, coefs in enumerate(raw["coef"]):
        for k, c in enumerate(coefs, start=1):
            out[f"{INPUTS[v]}^{k}"] = float(c)
    return out


# --------------------------------------------------------------------------- Table 4
def table4_vs_paper(models: Mapping[str, FittedModel]) -> dict[str, pd.DataFrame]:
    """Table 4 as the paper's grid: per x channel, one row per coefficient and source
    (paper, ours), one column per temperature segment (S1..S7), physical units.

    The first two rows give each segment's upper edge [°C] (the paper's and ours: we cut
    at the midpoints of the set points, it at its own points). ``a0`` of the paper holds
    its raw output's static value and bias at 0 °C (15 mg on accel x); ours, a calibrated
    output's: they are not comparable.

    Returns
    -------
    dict of str to DataFrame
        ``accel_x`` and ``gyro_x``: ``term, unit, source, S1 ... S7``.
    """
    scales = paper_pulse_scales()
    out = {}
    for c in ("accel_x", "gyro_x"):
        paper = PAPER_TABLES["table4"][c]
        raw = raw_polynomial(models["sectional"].models[c].params)
        segs = [_flat(s) for s in raw["segments"]]
        n = len(segs)
        cols = [f"S{k + 1}" for k in range(max(n, 7))]
        rows: list[dict[str, Any]] = []

        def row(
            term: str,
            unit: str,
            source: str,
            vals: Any,
            cols: list[str] = cols,
            rows: list[dict[str, Any]] = rows,
        ) -> None:
            v = list(vals) + [float("nan")] * (len(cols) - len(vals))
            rows.append(
                {"term": term, "unit": unit, "source": source, **dict(zip(cols, v, strict=True))}
            )

        row("upper edge", "°C", "paper", [*paper["edges"], float("nan")])
        row("upper edge", "°C", "ours", [*map(float, raw["edges"]), float("nan")])
        for term in [k for k in paper if k != "edges"]:
            unit = coefficient_unit(c, term)
            row(term, unit, "paper", [x * scales[c] for x in paper[term]])
            row(term, unit, "ours", [s.get(term, float("nan")) for s in segs])
        out[c] = pd.DataFrame(rows)
    return out


# --------------------------------------------------------------------------- Tables 5, 7
def selection_vs_paper(
    sel: SelectionResult, imu: ImuConfig, rate_hz: float, table: str
) -> pd.DataFrame:
    """Table 5 (``table="table5"``) or 7 (``"table7"``) in physical units: the paper's
    training RMS beside ours, training and held out, and our noise floor.

    Returns
    -------
    DataFrame
        ``sensor, setting, axis, unit, paper training, ours training, ours held-out,
        noise floor``: RMS [µg or °/h] of Eq. 16; ``paper training`` is the paper's pulses
        times :func:`paper_pulse_scales` (blank where it printed no such setting);
        ``noise floor`` is :func:`noise_floor` at ``rate_hz``, the log rate of our fit.
    """
    scales = paper_pulse_scales()
    floor = noise_floor(imu, rate_hz)
    paper = PAPER_TABLES[table]
    rows = []
    t = sel.table
    for sensor in ("accel", "gyro"):
        for setting in sorted(t["setting"].unique()):
            for c in CHANNELS:
                if not c.startswith(sensor):
                    continue
                r = t[(t["channel"] == c) & (t["setting"] == setting)]
                if r.empty:
                    continue
                p = paper[c]
                pv = (
                    p.get(int(setting))
                    if isinstance(p, Mapping)
                    else (p[int(setting) - 1] if 1 <= setting <= len(p) else None)
                )
                rows.append(
                    {
                        "sensor": sensor,
                        "setting": int(setting),
                        "axis": c.split("_")[1],
                        "unit": sensor_unit(c),
                        "paper training": float("nan") if pv is None else pv * scales[c],
                        "ours training": float(r["rms_train"].iloc[0]),
                        "ours held-out": float(r["rms_heldout"].iloc[0]),
                        "noise floor": floor[c],
                    }
                )
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------- Table 6
def table6_vs_paper(models: Mapping[str, FittedModel], imu: ImuConfig | None) -> pd.DataFrame:
    """Table 6 as a grid per sensor: one row per coefficient and source (paper, true
    plant, ours), one column per axis (x, y, z), physical units.

    The plant's ``a0`` is blank: the constant holds the static output (gravity, Earth rate)
    and each run's turn-on offset, not a thermal coefficient. For a mechanistic plant every
    true value is blank (its law has no such coefficients).

    Returns
    -------
    DataFrame
        ``sensor, term, unit, source, x, y, z``.
    """
    scales = paper_pulse_scales()
    rows = []
    for sensor in ("accel", "gyro"):
        chans = [c for c in CHANNELS if c.startswith(sensor)]
        ours = {c: _flat(raw_polynomial(models["regression"].models[c].params)) for c in chans}
        true = {c: (plant_coefficients(imu, c) if imu is not None else None) for c in chans}
        paper = {
            c: _flat(
                {
                    "a0": PAPER_TABLES["table6"][c]["a0"],
                    "coef": [PAPER_TABLES["table6"][c][v] for v in INPUTS],
                }
            )
            for c in chans
        }
        terms = list(dict.fromkeys(t for c in chans for t in [*paper[c], *ours[c]]))
        for term in terms:
            unit = coefficient_unit(chans[0], term)
            for source in ("paper", "true plant", "ours"):
                vals = {}
                for c in chans:
                    if source == "paper":
                        v = paper[c].get(term)
                        v = None if v is None else v * scales[c]
                    elif source == "ours":
                        v = ours[c].get(term)
                    else:
                        tr = true[c]
                        v = None if (tr is None or term == "a0") else tr.get(term, 0.0)
                    vals[c.split("_")[1]] = float("nan") if v is None else float(v)
                rows.append(
                    {"sensor": sensor, "term": term, "unit": unit, "source": source, **vals}
                )
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------- Table 8
def table8_vs_paper(models: Mapping[str, FittedModel]) -> dict[str, pd.DataFrame]:
    """Table 8: the paper's x-axis network weights beside ours, per hidden neuron.

    Weights of two trainings are not comparable one to one (hidden neurons can be
    permuted, a sigmoid's sign flipped, and each training normalises its inputs its own
    way); what compares is the structure: the count of weights, ``n·3 + n + n + 1``.

    Returns
    -------
    dict of str to DataFrame
        ``accel_x`` and ``gyro_x``: ``neuron, source, w(T), w(Ṫ), w(ΔT), b, v``; a last
        row per source ``output`` holds the output bias ``b′`` in column ``b``.
        ``attrs["n_weights"]`` is ``{"paper": int, "ours": int}``.
    """
    out = {}
    for c in ("accel_x", "gyro_x"):
        p = PAPER_TABLES["table8"][c]
        q = models["neural"].models[c].params
        rows = []
        counts = {}
        for source, W, b, v, b_out in (
            ("paper", p["W"], p["b"], p["v"], p["b_out"]),
            ("ours", q["W"], q["b"], q["v"], q["b_out"]),
        ):
            W = np.asarray(W, dtype=float)
            for i in range(W.shape[0]):
                rows.append(
                    {
                        "neuron": str(i + 1),
                        "source": source,
                        **{f"w({INPUTS[j]})": float(W[i, j]) for j in range(W.shape[1])},
                        "b": float(b[i]),
                        "v": float(v[i]),
                    }
                )
            rows.append({"neuron": "output", "source": source, "b": float(b_out)})
            counts[source] = int(W.size + len(b) + len(v) + 1)
        df = pd.DataFrame(rows)
        df.attrs["n_weights"] = counts
        out[c] = df
    return out


# --------------------------------------------------------------------------- Table 9
def table9_vs_paper() -> pd.DataFrame:
    """Table 9: the turntable's quasi-static and swing conditions, the paper's numbers as
    printed beside the ones our scenarios use (:mod:`rinscal.sim.trajectory`).

    Returns
    -------
    DataFrame
        ``axis, paper (as printed), ours: quasi-static [°], ours: swing amplitude [°],
        ours: swing period [s], ours: swing frequency [Hz]``.
    """
    rows = []
    held = (QUASI_STATIC_HEADING_DEG, 0.0, 0.0)
    for i, axis in enumerate(("heading", "pitch", "roll")):
        printed = PAPER_TABLES["table9"][axis]
        rows.append(
            {
                "axis": axis,
                "paper (as printed)": " / ".join(f"{x:g}" for x in printed),
                "ours: quasi-static [°]": float(held[i]),
                "ours: swing amplitude [°]": float(SWING_AMPLITUDES_DEG[i]),
                "ours: swing period [s]": float(SWING_PERIODS_S[i]),
                "ours: swing frequency [Hz]": 1.0 / float(SWING_PERIODS_S[i]),
            }
        )
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------- recovery
def _design(feats: Any, j: int, params: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """The scaled design matrix of channel ``j`` (as the fit builds it) and its rows."""
    x = [feats.temp[:, j], feats.rate[:, j]]
    if feats.grad is not None:
        x.append(feats.grad[:, j])
    cols = [np.ones(len(x[0]))]
    for v, order in enumerate(params["orders"]):
        z = (x[v] - float(params["center"][v])) / float(params["scale"][v])
        cols += [z**k for k in range(1, order + 1)]
    X = np.column_stack(cols)
    ok = feats.inlier[:, j] & np.all(np.isfinite(X), axis=1)
    return X, ok


def _raw_map(params: Mapping[str, Any]) -> np.ndarray:
    """The linear map from (intercept, scaled coefficients) to the raw coefficients."""
    k = 1 + sum(params["orders"])
    cols = []
    for i in range(k):
        e = np.zeros(k)
        e[i] = 1.0
        p = dict(params)
        p["intercept"] = e[0]
        coef, at = [], 1
        for order in params["orders"]:
            coef.append(e[at : at + order].tolist())
            at += order
        p["coef"] = coef
        cols.append(list(_flat(raw_polynomial(p)).values()))
    return np.asarray(cols).T


def regression_recovery(
    log: pd.DataFrame,
    truth: pd.DataFrame,
    model: FittedModel,
    imu: ImuConfig | None,
    n_boot: int = 400,
    seed: int = 0,
    level: float = 0.95,
) -> pd.DataFrame:
    """Method 2's coefficients against the plant's, with bootstrap intervals.

    The interval: the fitted residuals are cut into runs, and each bootstrap replicate
    gives every soak run the whole residual series of a run drawn at random (with
    replacement), refits on the same design and takes the percentiles of the raw
    coefficients. Resampling runs whole keeps what a white-noise covariance ignores: each
    power-on's own turn-on offset, the hysteresis and random walk within a run. The
    noise-free fit is the same regression on the same inputs fitted to the plant's true
    thermal bias (no noise, no turn-on offsets): where it misses the plant's coefficient,
    no amount of data recovers it with these inputs (the rate estimated from measured
    temperatures, the effects outside the polynomial, collinear inputs).

    Parameters
    ----------
    log, truth : DataFrame
        The soak log the model was fitted on, and its true thermal bias
        (``bias_<channel>``, log units), row for row.
    model : FittedModel
        The fitted ``regression`` model.
    imu : ImuConfig or None
        The plant (None or mechanistic: no true coefficients).
    n_boot : int
        Bootstrap replicates.
    seed : int
        Seed of the resampling.
    level : float
        Coverage of the interval.

    Returns
    -------
    DataFrame
        ``channel, term, unit, true, noise-free fit, ours, lo, hi, recovered`` (log units;
        ``recovered`` is True where ``lo ≤ true ≤ hi``, None where there is no truth). The
        constant ``a0`` is left out (static output and turn-on offsets, not thermal).
        ``attrs``: ``method`` (words), ``n_runs``, ``corr_rate_grad`` (per channel, the
        correlation of Ṫ and ΔT over the fitted rows), ``cond`` (condition number of the
        scaled design).
    """
    feats = model_features(log, model, outliers=OutlierConfig())
    rng = np.random.default_rng(seed)
    runs = feats.run_codes
    rows = []
    corr, cond = {}, {}
    for j, c in enumerate(feats.channels):
        params = model.models[c].params
        X, ok = _design(feats, j, params)
        y = feats.output[:, j]
        Xo, yo, ro = X[ok], y[ok], runs[ok]
        Q, R = np.linalg.qr(Xo)
        theta = np.linalg.solve(R, Q.T @ yo)
        resid = yo - Xo @ theta
        M = _raw_map(params)
        names = _terms(params["orders"])
        ours = M @ theta
        groups = [np.flatnonzero(ro == g) for g in np.unique(ro)]
        # Qᵀe* is a sum over runs g of Q_gᵀ (residual of the run drawn for g): every
        # pairing (g, h) once, then each replicate only adds its draws' terms
        pair = np.array(
            [[Q[ig].T @ np.resize(resid[ih], ig.size) for ih in groups] for ig in groups]
        )
        draws = rng.integers(len(groups), size=(n_boot, len(groups)))
        qe = pair[np.arange(len(groups))[None, :], draws].sum(axis=1)
        boot = theta + np.linalg.solve(R, qe.T).T
        raw_boot = boot @ M.T
        a = (1.0 - level) / 2.0
        lo, hi = np.quantile(raw_boot, [a, 1.0 - a], axis=0)
        tb = truth[f"bias_{c}"].to_numpy(dtype=float)[ok]
        fin = np.isfinite(tb)
        nf = M @ np.linalg.lstsq(Xo[fin], tb[fin], rcond=None)[0]
        true = plant_coefficients(imu, c) if imu is not None else None
        if feats.grad is not None and len(params["orders"]) > 2:
            r, d = feats.rate[ok, j], feats.grad[ok, j]
            corr[c] = float(np.corrcoef(r, d)[0, 1])
        cond[c] = float(np.linalg.cond(Xo))
        for i, term in enumerate(names):
            if term == "a0":
                continue
            tv = None if true is None else true.get(term, 0.0)
            rows.append(
                {
                    "channel": c,
                    "term": term,
                    "unit": coefficient_unit(c, term),
                    "true": float("nan") if tv is None else tv,
                    "noise-free fit": float(nf[i]),
                    "ours": float(ours[i]),
                    "lo": float(lo[i]),
                    "hi": float(hi[i]),
                    "recovered": None if tv is None else bool(lo[i] <= tv <= hi[i]),
                }
            )
    df = pd.DataFrame(rows)
    df.attrs.update(
        method=(
            f"{level:.0%} percentile interval of {n_boot} bootstrap refits, the soak runs' "
            "residual series resampled whole"
        ),
        n_runs=len(np.unique(runs)),
        corr_rate_grad=corr,
        cond=cond,
    )
    return df


def ramp_outside_training(
    train_log: pd.DataFrame, ramp_log: pd.DataFrame, model: FittedModel
) -> dict[str, float]:
    """Fraction of the ramp's samples whose inputs leave the training data.

    Per input (``T``, ``Ṫ``, ``ΔT``): the share of the ramp's samples, over every channel
    of ``model``, outside that input's [min, max] on the training log. ``flagged``: the
    share of the ramp's rows the model itself flags (:func:`rinscal.calibration.compensate.
    predict_log`'s ``out_of_range``, any channel): an input outside its range or the
    combination (T, Ṫ, ΔT) outside the joint domain of the training data. There a clamped
    model does not model, it holds its edge, so Figure 9 tests the clamp more than the model.

    Returns
    -------
    dict of str to float
        ``T``, ``Ṫ``, ``ΔT`` (absent without a gradient) and ``flagged``, each in [0, 1].
    """
    tr = model_features(train_log, model)
    te = model_features(ramp_log, model)
    out: dict[str, float] = {}
    for name, a, b in (
        ("T", tr.temp, te.temp),
        ("Ṫ", tr.rate, te.rate),
        ("ΔT", tr.grad, te.grad),
    ):
        if a is None or b is None:
            continue
        lo, hi = np.nanmin(a, axis=0), np.nanmax(a, axis=0)
        out[name] = float(((b < lo) | (b > hi)).mean())
    _, flag = predict_log(ramp_log, model, policy="clamp")
    out["flagged"] = float(np.asarray(flag).reshape(len(ramp_log), -1).any(axis=1).mean())
    return out
