"""Calibration experiments: held-out thermal residual on the simulated plant, and the real log.

:func:`heldout_table`
    Fit every method on training runs (the soak protocol) and, on runs it never saw (the
    ``repeat`` and ``ramp`` protocols), compare the modelled bias with the simulator's true
    thermal bias: the RMS of ``predicted − true`` with each run's mean removed (the turn-on
    offset of a power-on is not thermal), and the largest step of that residual where the
    temperature crosses a segment edge (Figure 7). "uncompensated" is the true bias itself.
:func:`real_log_table`
    The real MEMS thermal-cycle log (``tests/data/real``): the single recording is cut at
    its temperature turning points into legs (cooling, heating, cooling); models are fitted
    on some legs and judged on another by the RMS (Eq. 16) of the compensated output about
    the leg's mean. There is no truth: what remains includes noise.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal.calibration.compensate import model_features, predict_log
from rinscal.calibration.evaluate import StepConfig, edge_steps, evaluate
from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.calibration.thermal.features import MissingGradientWarning
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.schema import RUN

__all__ = [
    "METHODS",
    "fit_all",
    "heldout_table",
    "real_log_legs",
    "real_log_table",
    "tofupilot_mapping",
    "wide",
]

#: Methods compared, in table order.
METHODS: tuple[str, ...] = ("poly-t", "sectional", "regression", "neural")


def fit_all(
    train_log: pd.DataFrame,
    meta: Mapping[str, Any] | None = None,
    methods: Sequence[str] = METHODS,
    estimator_params: Mapping[str, Mapping[str, Any]] | None = None,
    edges: Sequence[float] | None = None,
) -> dict[str, ThermalModelFile]:
    """Fit every method on a training log with the paper's defaults.

    Parameters
    ----------
    train_log : DataFrame
        Validated calibration log.
    meta : mapping, optional
        Its metadata (units, latitude, heading).
    methods : sequence of str
        Methods to fit.
    estimator_params : mapping of str to mapping, optional
        Extra hyper-parameters per method, e.g. ``{"neural": {"max_samples": 50000}}``.
    edges : sequence of float, optional [°C]
        Segment edges of the sectional model (default: set-point midpoints).

    Returns
    -------
    dict of str to ThermalModelFile
    """
    extra = estimator_params or {}
    out = {}
    for m in methods:
        model = ThermalModel(
            m, estimator_params=extra.get(m), edges=edges if m == "sectional" else None
        )
        out[m] = model.fit(train_log, meta).to_file()
    return out


def _as_list(x: pd.DataFrame | Sequence[pd.DataFrame]) -> list[pd.DataFrame]:
    return [x] if isinstance(x, pd.DataFrame) else list(x)


def heldout_table(
    train_log: pd.DataFrame,
    test_logs: pd.DataFrame | Sequence[pd.DataFrame],
    truth: pd.DataFrame | Sequence[pd.DataFrame],
    meta: Mapping[str, Any] | None = None,
    *,
    models: Mapping[str, ThermalModelFile] | None = None,
    methods: Sequence[str] = METHODS,
    policy: str = "clamp",
    estimator_params: Mapping[str, Mapping[str, Any]] | None = None,
    step: StepConfig | None = None,
) -> pd.DataFrame:
    """Held-out thermal residual per run, channel and method on the simulated plant.

    Parameters
    ----------
    train_log : DataFrame
        Training log (e.g. the soak protocol).
    test_logs : DataFrame or sequence of DataFrame
        Held-out logs (e.g. ``repeat`` and ``ramp``).
    truth : DataFrame or sequence of DataFrame
        Row for row with ``test_logs``: ``bias_<channel>``, the true thermal bias in log
        units (turn-on offset and static output excluded), as written by the simulator.
    meta : mapping
        Metadata of the training log (units, latitude, heading: the static reference).
    models : mapping of str to ThermalModelFile, optional
        Already fitted models (otherwise fitted here with :func:`fit_all`).
    methods : sequence of str
        Methods to compare.
    policy : {"clamp", "extrapolate", "error"}
        Out-of-range handling.
    estimator_params : mapping, optional
        Extra hyper-parameters per method (see :func:`fit_all`).
    step : StepConfig, optional
        Step measurement on the residual.

    Returns
    -------
    DataFrame
        Long form: ``run, channel, unit, method, rms, max_step, crossings, out_of_range``;
        ``rms`` [log units] is the RMS of ``predicted − true`` bias about the run mean
        (for ``uncompensated``: of the true bias about its run mean).
    """
    step = step or StepConfig()
    models = (
        dict(models) if models is not None else fit_all(train_log, meta, methods, estimator_params)
    )
    rows = []
    for log, tr in zip(_as_list(test_logs), _as_list(truth), strict=True):
        if len(log) != len(tr):
            raise ValueError("each test log needs a truth table of the same rows")
        first = models[next(iter(models))]
        feats = model_features(log, first)
        true = tr[[f"bias_{c}" for c in first.channels]].to_numpy(dtype=np.float64)
        preds: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for m, mf in models.items():
            f, flags = predict_log(log, mf, policy)  # type: ignore[arg-type]
            ref = np.array([mf.models[c].static_reference or 0.0 for c in mf.channels])
            preds[m] = (f - ref, flags)
        for k, run in enumerate(feats.runs):
            r = np.flatnonzero(feats.run_codes == k)
            for j, c in enumerate(first.channels):
                edges = models.get("sectional", first).models[c].segment_edges
                entries = [("uncompensated", -true[r, j], np.zeros(r.size, dtype=bool))]
                entries += [(m, p[r, j] - true[r, j], fl[r, j]) for m, (p, fl) in preds.items()]
                for m, resid, fl in entries:
                    about = resid - resid.mean()
                    steps = (
                        edge_steps(feats.time_s[r], about, feats.temp[r, j], edges, step)
                        if edges is not None
                        else []
                    )
                    rows.append(
                        {
                            "run": run,
                            "channel": c,
                            "unit": first.models[c].unit or "",
                            "method": m,
                            "rms": float(np.sqrt(np.mean(about**2))),
                            "max_step": max((abs(s[2]) for s in steps), default=np.nan),
                            "crossings": len(steps),
                            "out_of_range": int(fl.sum()),
                        }
                    )
    return pd.DataFrame(rows)


def wide(table: pd.DataFrame, value: str = "rms") -> pd.DataFrame:
    """Pivot a long table: rows ``(run, channel)``, one column per method."""
    order = list(dict.fromkeys(table["method"]))
    out = table.pivot_table(index=["run", "channel"], columns="method", values=value, sort=False)
    return out[order]


# ----------------------------------------------------------------------------- real log


def tofupilot_mapping() -> Any:
    """Column mapping of the real log ``tofupilot_imu_thermal_cycle.tsv``.

    µs timestamps, ``imu.gyro.*`` [rad/s], ``imu.acc.*`` [m/s²], one temperature.
    """
    from rinscal.io.mapping import ColumnMapping

    cols = {f"imu.gyro.{a}": f"gyro_{a}" for a in "xyz"}
    cols.update({f"imu.acc.{a}": f"accel_{a}" for a in "xyz"})
    return ColumnMapping(
        columns=cols,
        time="timestamp",
        time_unit="us",
        relative_time=True,
        separator="tab",
        temperature="imu.temperature",
        drop=("imu.status",),
        run="thermal_cycle",
        units={"gyro": "rad/s", "accel": "m/s^2"},
    )


def real_log_legs(log: pd.DataFrame, smooth_s: float = 30.0) -> pd.DataFrame:
    """Cut a one-run thermal cycle into legs at its temperature turning points.

    Parameters
    ----------
    log : DataFrame
        One run with ``temp_in``.
    smooth_s : float [s]
        Running-median window applied to the temperature before locating the extremes.

    Returns
    -------
    DataFrame
        The same rows, ``run`` renamed to ``leg1_cool``, ``leg2_heat``, ``leg3_cool``
        (split at the first minimum and the following maximum of the temperature).
    """
    t = log["time_s"].to_numpy()
    dt = float(np.median(np.diff(t)))
    w = max(3, round(smooth_s / dt) | 1)
    temp = log["temp_in"].rolling(w, center=True, min_periods=1).median().to_numpy()
    i_min = int(np.argmin(temp))
    i_max = i_min + int(np.argmax(temp[i_min:]))
    names = np.empty(len(log), dtype=object)
    names[:i_min] = "leg1_cool"
    names[i_min:i_max] = "leg2_heat"
    names[i_max:] = "leg3_cool"
    out = log.copy()
    out[RUN] = names.astype(str)
    return out


def real_log_table(
    path: str | os.PathLike[str],
    mapping: Any = None,
    train_legs: Sequence[str] = ("leg1_cool", "leg2_heat"),
    test_legs: Sequence[str] = ("leg3_cool",),
    methods: Sequence[str] = METHODS,
    n_edges: int = 6,
    estimator_params: Mapping[str, Mapping[str, Any]] | None = None,
) -> tuple[pd.DataFrame, dict[str, ThermalModelFile]]:
    """Fit on some legs of the real thermal cycle, evaluate every method on another.

    Parameters
    ----------
    path : path-like
        The real log.
    mapping : ColumnMapping, optional
        How to read it (default :func:`tofupilot_mapping`).
    train_legs, test_legs : sequence of str
        Legs (see :func:`real_log_legs`) to fit on and to evaluate on.
    methods : sequence of str
        Methods.
    n_edges : int
        Sectional edges, evenly spread over the training temperature range (the log has no
        chamber set points).
    estimator_params : mapping, optional
        Extra hyper-parameters per method.

    Returns
    -------
    table : DataFrame
        :func:`rinscal.calibration.evaluate.evaluate` rows of the test legs with a
        ``method`` column, RMS about each leg's mean in the log's units; steps are measured
        at the sectional model's edges for every method.
    models : dict of str to ThermalModelFile
    """
    from rinscal.io.tables import read_log

    log = real_log_legs(read_log(path, mapping or tofupilot_mapping()))
    meta = {"units": {"gyro": "rad/s", "accel": "m/s^2"}}
    units = {
        c: meta["units"]["gyro" if c.startswith("gyro") else "accel"]
        for c in ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
    }
    meta = {"units": units}
    train = log[log[RUN].isin(train_legs)]
    test = log[log[RUN].isin(test_legs)]
    lo, hi = float(train["temp_in"].min()), float(train["temp_in"].max())
    edges = np.linspace(lo, hi, n_edges + 2)[1:-1].tolist()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MissingGradientWarning)
        models = fit_all(train, meta, methods, estimator_params, edges=edges)
        parts = []
        for m, mf in models.items():
            ev = evaluate(test, mf, policy="clamp", edges=edges)
            ev.insert(0, "method", m)
            parts.append(ev)
    return pd.concat(parts, ignore_index=True), models
