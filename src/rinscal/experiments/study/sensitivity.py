"""The sensitivity map of a sweep study: where do methods 2 and 3 pay, in physical units.

Each plant variant of a sweep is placed by its **equivalent thermal sensitivities**, the
numbers a calibration engineer reads off a Table-6-style regression, instead of its sweep
multipliers (:func:`plant_sensitivities`):

* the horizontal accelerometers' bias per temperature rate [µg per °C/min] (the ``Ṫ`` term),
* their bias per inside/outside gradient [µg/°C] (the ``ΔT`` term),
* the gyros' bias per temperature rate [°/h per °C/min].

Under the polynomial law they are read from the plant's coefficients (already multiplied by
the sweep factors) as the slopes at the operating point ``T = OPERATING_POINT_C``, ``Ṫ = 0``,
``ΔT = 0`` (:func:`read_sensitivities`: the first-order coefficient plus the coupling to
``T``). The mechanistic law has no such coefficients: its bias is driven by nodes of the
thermal network no thermometer sees; its equivalents are the coefficients of the first-order
regression ``b = a0 + a_T·T + a_Ṫ·Ṫ + a_ΔT·ΔT`` fitted, per channel, to its true thermal bias
over the soak protocol of Table 3 (noise-free, the 1 s grid of the simulator, every 10 s
used; :func:`fit_sensitivities`), i.e. what a first-order Table 6 would say about that
plant. Both are of the nominal plant variant (the units scatter about it by the spec's
coefficient spread); Shupe and hysteresis are left out of both.

The map itself (:func:`sensitivity_map`) judges methods 2 and 3 against no compensation and
against the cubic in ``T`` (:func:`rinscal.experiments.study.compare.paired_against`), per
plant variant and warm-up time (the scenario's ``align_start_s``), one row per cell.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from rinscal import units
from rinscal.experiments.study.spec import StudySpec
from rinscal.experiments.study.tasks import plant_config
from rinscal.experiments.verdict import HOLDS, REVERSED, TOO_FEW, UNRESOLVED, verdict
from rinscal.sim.config import ImuConfig
from rinscal.sim.field import ThermalField, simulate_field
from rinscal.sim.protocols import THERMAL_DT_S, protocol_runs

__all__ = [
    "MAP_METHODS",
    "MAP_REFERENCES",
    "OPERATING_POINT_C",
    "SENSITIVITY_COLUMNS",
    "fit_sensitivities",
    "plant_sensitivities",
    "read_sensitivities",
    "sensitivity_map",
    "soak_fields",
]

#: Temperature at which the polynomial law's slopes are read [°C] (the lab).
OPERATING_POINT_C = 20.0
#: The equivalent sensitivities, with their units.
SENSITIVITY_COLUMNS = {
    "accel_rate_ug_per_c_min": "µg per °C/min",
    "accel_grad_ug_per_c": "µg/°C",
    "gyro_rate_dph_per_c_min": "°/h per °C/min",
}
#: Methods judged by the map, and the references they are judged against.
MAP_METHODS = ("regression", "neural")
MAP_REFERENCES = ("none", "poly-t")
#: Soak runs sampled every this many grid steps for the mechanistic fit.
_DECIMATE = 10


def _aggregate(per_channel: np.ndarray) -> dict[str, float]:
    """Per channel ``(6, 3)`` slopes ``[T, Ṫ, ΔT]`` → the three equivalents: the mean
    magnitude over the horizontal accelerometers (x, y) and over the three gyros."""
    return {
        "accel_rate_ug_per_c_min": float(np.mean(np.abs(per_channel[3:5, 1]))),
        "accel_grad_ug_per_c": float(np.mean(np.abs(per_channel[3:5, 2]))),
        "gyro_rate_dph_per_c_min": float(np.mean(np.abs(per_channel[0:3, 1]))),
    }


def read_sensitivities(
    config: ImuConfig, t_c: float = OPERATING_POINT_C
) -> tuple[np.ndarray, dict[str, float]]:
    """The polynomial law's slopes at ``T = t_c`` [°C], ``Ṫ = 0``, ``ΔT = 0``.

    Returns
    -------
    per_channel : ndarray, shape (6, 3)
        ``∂b/∂T`` [unit/°C], ``∂b/∂Ṫ`` [unit per °C/min], ``∂b/∂ΔT`` [unit/°C] per channel
        (gyros in °/h, accelerometers in µg): ``Σ k t[k−1] x^(k−1)`` with
        ``x = t_c − t_ref``, ``rate[0] + t_rate·x``, ``grad[0] + t_grad·x``.
    equivalents : dict
        :data:`SENSITIVITY_COLUMNS` (:func:`_aggregate`).
    """
    x = t_c - config.t_ref_c
    out = np.zeros((6, 3))
    for j, c in enumerate(config.thermal):
        out[j, 0] = sum((k + 1) * a * x**k for k, a in enumerate(c.t))
        out[j, 1] = (c.rate[0] if c.rate else 0.0) + c.t_rate * x
        out[j, 2] = (c.grad[0] if c.grad else 0.0) + c.t_grad * x
    return out, _aggregate(out)


def soak_fields(config: ImuConfig, hours: float | None = None) -> list[ThermalField]:
    """The soak protocol's noise-free thermal field, one per run, on the simulator's grid."""
    net = config.thermal_network()
    return [
        simulate_field(s.profile, net, s.duration_s, THERMAL_DT_S)
        for s in protocol_runs("soak", hours)
    ]


def _law_bias(field: ThermalField, config: ImuConfig) -> np.ndarray:
    """The thermal law's bias alone (no Shupe, no hysteresis), ``(n, 6)`` [°/h, µg]."""
    x = field.sensor - config.t_ref_c
    r = field.sensor_rate * units.MIN_TO_S
    d = field.gradient
    out = np.empty_like(x)
    for j, c in enumerate(config.thermal):
        if config.mechanistic is not None:
            out[:, j] = config.mechanistic[j].evaluate(field, j, config.t_ref_c)
        else:
            out[:, j] = c.evaluate(x[:, j], r[:, j], d[:, j], field.stress[:, j])
    return out


def fit_sensitivities(
    config: ImuConfig, fields: Sequence[ThermalField]
) -> tuple[np.ndarray, dict[str, float]]:
    """First-order Table-6 regression fitted to the plant's true thermal bias.

    Per channel, ``b = a0 + a_T·T + a_Ṫ·Ṫ + a_ΔT·ΔT`` by least squares over every run of
    ``fields`` stacked (``T`` the sensor's temperature [°C], ``Ṫ`` its rate [°C/min], ``ΔT``
    sensor minus package surface [°C]; every 10th grid point).

    Returns
    -------
    per_channel : ndarray, shape (6, 3)
        ``a_T``, ``a_Ṫ``, ``a_ΔT`` per channel [°/h or µg per °C, per °C/min, per °C].
    equivalents : dict
        :data:`SENSITIVITY_COLUMNS` (:func:`_aggregate`).
    """
    xs, ys = [], []
    for f in fields:
        idx = np.arange(0, f.t.size, _DECIMATE)
        b = _law_bias(f, config)[idx]
        xs.append(
            np.stack([f.sensor[idx], f.sensor_rate[idx] * units.MIN_TO_S, f.gradient[idx]], axis=-1)
        )
        ys.append(b)
    x = np.concatenate(xs)  # (n, 6, 3)
    y = np.concatenate(ys)  # (n, 6)
    out = np.zeros((6, 3))
    for j in range(6):
        a = np.column_stack([np.ones(x.shape[0]), x[:, j, :]])
        coef, *_ = np.linalg.lstsq(a, y[:, j], rcond=None)
        out[j] = coef[1:]
    return out, _aggregate(out)


def plant_sensitivities(spec: StudySpec) -> pd.DataFrame:
    """One row per plant variant of ``spec``: ``plant``, ``law``, ``source`` (``read at
    20 °C`` or ``fitted on the soak protocol``), :data:`SENSITIVITY_COLUMNS` (read for the
    polynomial law, fitted for the mechanistic) and the fitted ones for every law
    (``fitted <column>``: for a polynomial plant they differ from the read slopes where
    ``Ṫ`` and ``ΔT`` move together on the soak protocol and higher orders bend the bias)."""
    fields: dict[str, list[ThermalField]] = {}
    rows = []
    for i, p in enumerate(spec.plants):
        cfg = plant_config(p)
        if p.imu not in fields:
            fields[p.imu] = soak_fields(cfg)
        _, fitted = fit_sensitivities(cfg, fields[p.imu])
        if cfg.thermal_law == "mechanistic":
            eq, source = fitted, "fitted on the soak protocol"
        else:
            eq, source = read_sensitivities(cfg)[1], f"read at {OPERATING_POINT_C:g} °C"
        rows.append(
            {
                "plant": i,
                "plant_label": p.label,
                "law": cfg.thermal_law,
                "source": source,
                **eq,
                **{f"fitted {k}": v for k, v in fitted.items()},
            }
        )
    return pd.DataFrame(rows)


#: A map cell's name for each verdict on "method better than reference".
_CELLS = {HOLDS: "better", REVERSED: "worse", UNRESOLVED: "unresolved", TOO_FEW: "not enough units"}


def sensitivity_map(comparisons: pd.DataFrame, sens: pd.DataFrame) -> pd.DataFrame:
    """The map's cells, one row per plant variant, warm-up time, method and reference.

    Parameters
    ----------
    comparisons : DataFrame
        :func:`rinscal.experiments.study.compare.paired_against` of the study (references
        ``none`` and ``poly-t``).
    sens : DataFrame
        :func:`plant_sensitivities`.

    Returns
    -------
    DataFrame
        The physical sensitivities of the plant, ``scenario``, ``warm-up [min]``,
        ``method``, ``reference``, ``delta`` (method − reference [nmi], mean over units),
        ``delta ci low/high``, ``n units``, ``cell``: ``better`` or ``worse`` (the interval
        excludes zero), ``unresolved`` (it contains zero) or ``not enough units``; and
        ``verdict`` in words.
    """
    c = comparisons[
        comparisons["method"].isin(MAP_METHODS)
        & comparisons["reference"].isin(MAP_REFERENCES)
        & (comparisons["metric"] == "max_error_nmi")
    ]
    if c.empty:
        return pd.DataFrame()
    rows = []
    for _, r in c.iterrows():
        lo, hi, n = r["delta ci low"], r["delta ci high"], int(r["n units"])
        cell = _CELLS[verdict(n, lo, hi)]
        rows.append(
            {
                "plant": r["plant"],
                "scenario": r["scenario"],
                "warm-up [min]": r["align_start_s"] / units.MIN_TO_S,
                "method": r["method"],
                "reference": r["reference"],
                "delta": r["delta"],
                "delta ci low": lo,
                "delta ci high": hi,
                "n units": n,
                "cell": cell,
                "verdict": r["verdict"],
            }
        )
    out = pd.DataFrame(rows)
    return sens.merge(out, on="plant", how="right")
