"""Validation of a thermal model file's channel entries (the bulk of
:meth:`rinscal.calibration.modelfile.FittedModel.load`'s checks), apart from the file's
layout and evaluation so that :mod:`rinscal.calibration.modelfile` stays one readable idea.

Every check raises :class:`ValueError` naming the key; the model file turns it into a
:class:`~rinscal.errors.ModelFileError` naming the file.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rinscal.calibration._domain import validate_domain
from rinscal.calibration.inference import n_inputs, validate_params
from rinscal.units import G0, check_sensor_unit

#: The sensor channels, as :data:`rinscal.schema.CHANNELS` (that module loads pandas).
CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: Top-level method of a file whose channels were chosen one by one (``fit --method auto``).
AUTO = "auto"
#: Input names, in feature-matrix column order.
INPUT_NAMES: tuple[str, str, str] = ("T", "Tdot", "dT")
#: Input units, in :data:`INPUT_NAMES` order.
INPUT_UNITS: tuple[str, str, str] = ("degC", "degC/min", "degC")
#: Name of the temperature-rate estimator (see :mod:`rinscal.calibration.thermal.rate`).
RATE_ESTIMATOR = "windowed least-squares slope"
#: Keys of the payload (schema version 3 adds ``imu_calibration``), of a channel's entry
#: and of its metrics (exactly these).
PAYLOAD_KEYS_V2 = ("method", "created_by", "channels", "features", "source", "channel_models")
PAYLOAD_KEYS = (*PAYLOAD_KEYS_V2, "imu_calibration")
CHANNEL_KEYS = (
    "params",
    "unit",
    "unit_to_si",
    "static_reference",
    "train_range",
    "segment_edges",
    "metrics",
    "domain",
    "fallback",
    "selection",
)
#: Keys of a channel's entry in schema version 1.
CHANNEL_KEYS_V1 = CHANNEL_KEYS[:7]
#: Keys of a channel's ``selection`` entry (method ``auto``) up to schema version 3; version 4
#: adds ``flight``: the full-data fits of the candidates PX4 and ArduPilot can hold.
SELECTION_KEYS_V3 = ("scheme", "folds", "tolerance", "chosen", "fallback", "table")
SELECTION_KEYS = (*SELECTION_KEYS_V3, "flight")
#: Methods of the models a ``selection.flight`` entry may hold (a clamped cubic in T).
FLIGHT_PARAM_METHODS = ("poly-t", "px4", "ardupilot")
METRIC_KEYS = ("rms_train", "rms_train_about_run_mean", "n_train", "n_outliers", "n_runs")


def exact(d: Any, keys: tuple[str, ...], where: str) -> None:
    """``d`` must be an object with exactly ``keys``."""
    if not isinstance(d, dict):
        raise ValueError(f"{where} must be a JSON object")
    missing = [k for k in keys if k not in d]
    if missing:
        raise ValueError(f"missing key(s) {', '.join(f'{where}.{k}' for k in missing)}")
    extra = sorted(set(d) - set(keys))
    if extra:
        raise ValueError(f"unexpected key(s) {', '.join(f'{where}.{k}' for k in extra)}")


def finite(v: Any, what: str, positive: bool = False, allow_none: bool = True) -> float | None:
    if v is None and allow_none:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ValueError(
            f"{what} must be a finite number{' or null' if allow_none else ''}, got {v!r}"
        )
    if positive and v <= 0:
        raise ValueError(f"{what} must be positive, got {v!r}")
    return float(v)


def channel_fields(d: Any, c: str, method: str, k: int, version: int) -> dict[str, Any]:
    """Validate one channel's entry of a model file; the fields of its ``ChannelModel``.

    Raises
    ------
    ValueError
        Naming the key (``channel_models.<c>.<key>``) and the problem.
    """
    exact(d, CHANNEL_KEYS if version >= 2 else CHANNEL_KEYS_V1, f"channel_models.{c}")
    params = d["params"]
    try:
        validate_params(params)
    except ValueError as exc:
        raise ValueError(f"channel_models.{c}.params: {exc}") from None
    if method != AUTO and params["method"] != method:
        raise ValueError(f"channel_models.{c} is a {params['method']} model in a {method} file")
    need = n_inputs(params)
    if need > k:
        raise ValueError(f"channel_models.{c} uses {need} inputs but the file's features have {k}")
    tr = d["train_range"]
    if not isinstance(tr, dict) or set(tr) != set(INPUT_NAMES[:need]):
        raise ValueError(f"channel_models.{c}.train_range must give {list(INPUT_NAMES[:need])}")
    rng = np.zeros((need, 2))
    for j, name in enumerate(INPUT_NAMES[:need]):
        pair = tr[name]
        if not isinstance(pair, list) or len(pair) != 2:
            raise ValueError(f"channel_models.{c}.train_range.{name} must be [min, max]")
        lo = finite(pair[0], f"channel_models.{c}.train_range.{name}", allow_none=False)
        hi = finite(pair[1], f"channel_models.{c}.train_range.{name}", allow_none=False)
        assert lo is not None and hi is not None
        if lo > hi:
            raise ValueError(f"channel_models.{c}.train_range.{name} has min > max")
        rng[j] = (lo, hi)
    unit = d["unit"]
    if unit is not None and not isinstance(unit, str):
        raise ValueError(f"channel_models.{c}.unit must be text or null")
    k_si = finite(d["unit_to_si"], f"channel_models.{c}.unit_to_si", positive=True)
    if unit is not None:
        try:
            check_sensor_unit(c.partition("_")[0], unit, k_si)  # gyro_x -> gyro
        except ValueError as exc:
            raise ValueError(f"channel_models.{c}: {exc}") from None
    ref = finite(d["static_reference"], f"channel_models.{c}.static_reference")
    if params["method"] == "px4" and ref is not None and k_si is not None:
        # before issue 21 a px4 accelerometer's coef[0] held no gravity (PX4's median removed)
        # while its static reference did: compensation would add 1 g. No sensor is 0.5 g off.
        if abs(float(params["coef"][0]) - ref) * k_si > 0.5 * G0:
            raise ValueError(
                f"channel_models.{c}: the px4 model's level at TREF, {params['coef'][0]:.6g}, is "
                f"more than 0.5 g from its static reference {ref:.6g}: a model written before "
                "rinscal kept the training level in px4 fits would remove gravity twice; refit it"
            )
    edges = d["segment_edges"]
    e_arr = None
    if edges is not None:
        if not isinstance(edges, list) or not all(
            isinstance(e, (int, float)) and not isinstance(e, bool) and np.isfinite(e)
            for e in edges
        ):
            raise ValueError(f"channel_models.{c}.segment_edges must be a list of numbers or null")
        e_arr = np.asarray(edges, dtype=np.float64)
        if np.any(np.diff(e_arr) <= 0):
            raise ValueError(f"channel_models.{c}.segment_edges must be strictly increasing")
    metrics = d["metrics"]
    exact(metrics, METRIC_KEYS, f"channel_models.{c}.metrics")
    mvals = {}
    for key, v in metrics.items():
        fv = finite(v, f"channel_models.{c}.metrics.{key}", allow_none=False)
        assert fv is not None
        mvals[str(key)] = fv
    domain = d.get("domain")
    if domain is not None:
        try:
            validate_domain(domain, need)
        except ValueError as exc:
            raise ValueError(f"channel_models.{c}.{exc}") from None
    fallback = d.get("fallback")
    if fallback is not None:
        try:
            validate_params(fallback)
        except ValueError as exc:
            raise ValueError(f"channel_models.{c}.fallback: {exc}") from None
        if n_inputs(fallback) != 1:
            raise ValueError(f"channel_models.{c}.fallback must be a model of T alone")
    selection = d.get("selection")
    if selection is not None:
        where = f"channel_models.{c}.selection"
        exact(selection, SELECTION_KEYS if version >= 4 else SELECTION_KEYS_V3, where)
        if not isinstance(selection["table"], list):
            raise ValueError(f"{where}.table must be a list")
        if "flight" in selection:
            _check_flight(selection, where)
    return {
        "params": params,
        "train_range": rng,
        "unit": unit,
        "unit_to_si": k_si,
        "static_reference": ref,
        "segment_edges": e_arr,
        "metrics": mvals,
        "domain": domain,
        "fallback": fallback,
        "selection": selection,
    }


def _check_flight(selection: dict[str, Any], where: str) -> None:
    """``selection.flight``: candidate names of the table, each a cubic-type model of T."""
    flight = selection["flight"]
    if not isinstance(flight, dict):
        raise ValueError(f"{where}.flight must be a JSON object")
    rows = {r.get("name"): r for r in selection["table"] if isinstance(r, dict)}
    for name, params in flight.items():
        if name not in rows:
            raise ValueError(f"{where}.flight.{name}: not a candidate of {where}.table")
        finite(rows[name].get("heldout_rms"), f"{where}.table[{name}].heldout_rms")
        try:
            validate_params(params)
        except ValueError as exc:
            raise ValueError(f"{where}.flight.{name}: {exc}") from None
        if params["method"] not in FLIGHT_PARAM_METHODS or n_inputs(params) != 1:
            raise ValueError(
                f"{where}.flight.{name} must be a poly-t, px4 or ardupilot model of T alone"
            )
        if params["method"] == "poly-t" and len(params["coef"]) > 4:
            raise ValueError(f"{where}.flight.{name}: a poly-t of degree > 3 is not a cubic")
