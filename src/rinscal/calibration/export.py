"""Export thermal models for flight software: PX4 ``.params``, ArduPilot ``.parm``, C headers.

Flight-software exports (PX4, ArduPilot) take a cubic in temperature: every channel of the
exported sensors is written as a ``poly-t`` (degree ≤ 3), ``px4`` or ``ardupilot`` model (a
file whose top-level method is ``auto`` may mix them per channel). Where ``fit --method
auto`` chose a model they cannot hold (a regression, a ``poly-t`` of degree 4, a network),
:func:`flight_model` takes the channel's best candidate they can hold by held-out RMS, fitted
on all the data (the model file's ``selection.flight``; the same fit as ``fit --method
poly-t|px4|ardupilot`` with the same settings), and says what that costs
(:class:`FlightChoice`; written as comments in the file and printed by ``rinscal export``);
the model file itself, and what ``compensate`` and ``navigate`` apply, are unchanged. A
channel with no such candidate (another method, or an ``auto`` file written before schema
version 4) is refused with the channels named and what to do (refit, or the C header).
The clamp range is the training range of a
``poly-t`` channel and the model's own ``t_min``/``t_max`` for ``px4``/``ardupilot``
channels, intersected over the three axes and **rounded inwards** at the written precision
(0.01 °C: ``TMIN`` up, ``TMAX`` down), so the firmware never evaluates the cubic outside
the range it was fitted on.

PX4 (``src/modules/temperature_compensation``; parameters ``TC_G*``/``TC_A*``)
    ``offset = X0 + X1·d + X2·d² + X3·d³`` with ``d = clamp(T, TMIN, TMAX) − TREF`` [°C], and
    the corrected value is ``raw − offset``, in SI (rad/s, m/s²). Written here per axis
    ``_0.._2`` (x, y, z): ``TC_G0_X3_0 .. TC_G0_X0_2``, ``TC_G0_TREF``, ``TC_G0_TMIN``,
    ``TC_G0_TMAX`` (and ``TC_A0_*``), ``TC_G_ENABLE``/``TC_A_ENABLE`` = 1, ``TC_G0_ID``/
    ``TC_A0_ID`` (set 0, or the set of the model's ``source["instance"]`` when it was fitted
    on a ULog instance: instance 1 writes ``TC_G1_*``; ``--instance`` chooses it). PX4
    applies the first set whose ``ID`` matches, and a file loaded into one set clears no other
    (the header says so, and that ``TC_*_ENABLE`` needs a reboot). PX4 applies the set only to the
    sensor whose ``device_id`` equals the ``ID`` parameter (``set_sensor_id``:
    ``device_id == (uint32_t)ID``), so an id of 0 means the file is never applied:
    the ids are required (``gyro_id``/``accel_id``, else the model's
    ``source["device_ids"]``, e.g. ``{"gyro": 2293768, "accel": 2294024}``) and the export
    is refused without them. An id is the ``device_id`` of ``sensor_gyro``/``sensor_accel``
    in a ULog (uint32) or the ``CAL_GYRO0_ID``/``CAL_ACC0_ID`` parameter (int32); it is
    written as the int32 PX4 stores (ids ≥ 2³¹, e.g. of DroneCAN IMUs, become negative).
    ``X0`` is the bias at ``TREF`` without Earth rate/gravity (``f(TREF) − static_reference``)
    when the model knows its static reference, else 0 (only the thermal change relative to
    ``TREF`` is exported; the ordinary offset calibration keeps the constant). Floats are
    written with 9 significant digits (enough to round-trip PX4's float32). File format:
    QGroundControl's tab-separated ``vehicle-id component-id name value type`` lines
    (type 9 = float, 6 = int32).
ArduPilot (``AP_InertialSensor_tempcal.cpp``; parameters ``INS_TCALn_*``)
    ``v −= P(clamp(T) − 35) − P(clamp(CALTEMP) − 35)`` with ``P(d) = (c1 + (c2 + c3 d) d) d ·
    1e−6``: a fixed reference of 35 °C, no constant term, coefficients stored × 1e6, in SI.
    ``n`` is the IMU instance + 1: ``--instance`` (0-based, as the readers number them), else
    the model's ``source["instance"]`` (a DataFlash ``IMU`` instance), else 0; instances 3
    and 4 (``INS4_TCAL_*``, ``INS5_TCAL_*``) are refused. Written: ``INS_TCALn_ENABLE`` = 1,
    ``INS_TCALn_TMIN``, ``INS_TCALn_TMAX``,
    ``INS_TCALn_ACC1_X .. ACC3_Z``, ``INS_TCALn_GYR1_X .. GYR3_Z`` (the cubic re-expanded about
    35 °C) as ``NAME VALUE`` lines with ``#`` comments (MAVProxy/Mission Planner ``.parm``).
    ArduPilot has no TREF parameter; the constant is the job of its offset calibration and
    ``INS_ACCn_CALTEMP``/``INS_GYRn_CALTEMP``. MAVProxy's ``param load`` (pymavlink
    ``mavparm.MAVParmDict.load``, ``mindelta = 1e-6``) does not send a value within 1e-6 of
    the vehicle's current one, so a nonzero stored coefficient of magnitude ≤ 1e-6 stays at
    its default 0 on a fresh vehicle: :func:`to_ardupilot_parm` then emits a
    :class:`SmallCoefficientWarning` naming the parameter and the share of that channel's
    thermal span over ``[TMIN, TMAX]`` lost when the term is zeroed (navigation-grade gyros
    have cubic terms of that size).
C header (every method)
    The coefficients as ``static const double`` arrays and one small ``static inline``
    reference function per channel, ``double <prefix>_<channel>(double T, double Tdot,
    double dT)`` returning ``f`` in log units (no clamping, except the clamp that is part of
    a ``px4``/``ardupilot`` model; the training ranges are given as macros), evaluated
    exactly as :func:`rinscal.calibration.inference.predict_params`. A model file that holds
    an IMU calibration adds, in the file's order of application
    (:data:`rinscal.calibration.imustage.IMU_ORDER`), ``void <prefix>_imu_correct(const
    double raw[6], const double T[6], const double Tdot[6], double out[6])`` (raw output in
    the log's units × ``unit_to_si`` → SI; at each channel's clamped inner temperature, the
    fixed-point iteration of the nonlinear scale-factor terms, three times, then the 3×3
    solve of ``I + M`` per triad; → deg/h and µg) and ``void <prefix>_compensate(raw, T, Tdot,
    dT, out)``: ``<prefix>_imu_correct`` then ``out − (f − STATIC_REF)`` per channel. Channel
    order gyro x..z, accel x..z; ``Tdot`` is used only by a calibration with rate laws.

Why one module: about 740 lines, one idea: a model file written out as another program's
input. The three targets share the clamp range, the re-expansion of the cubics and the
number formatting, and the C header's IMU step is the same evaluation as its channels'.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal

import numpy as np

from rinscal.calibration.flightmodel import FLIGHT_METHODS, FlightChoice, flight_model
from rinscal.calibration.imustage import PHYSICAL_TO_SI, ImuStage
from rinscal.calibration.inference import poly_shift, segment_params
from rinscal.calibration.modelfile import INPUT_NAMES, FittedModel
from rinscal.errors import ConfigError
from rinscal.firmware import ARDUPILOT_SCALE, ARDUPILOT_TREF_C, ardupilot_tcal_prefix
from rinscal.sensormodel import PARAMETERS

__all__ = [
    "ARDUPILOT_SCALE",
    "ARDUPILOT_TREF_C",
    "FLIGHT_METHODS",
    "MAVPROXY_MIN_DELTA",
    "TEMP_DECIMALS",
    "FlightChoice",
    "SmallCoefficientWarning",
    "flight_model",
    "lost_share",
    "to_ardupilot_parm",
    "to_c_header",
    "to_px4_params",
]

_AXES = ("x", "y", "z")
_CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: Decimals of the written TMIN/TMAX [°C] (rounded inwards at this precision).
TEMP_DECIMALS = 2
#: pymavlink ``MAVParmDict.mindelta``: MAVProxy's ``param load`` skips a value within this of
#: the vehicle's current one (stored units, i.e. ArduPilot's coefficient × 1e6).
MAVPROXY_MIN_DELTA = 1.0e-6
_INT32_MIN, _INT32_MAX, _UINT32_MAX = -(2**31), 2**31 - 1, 2**32 - 1
_FLOAT32_MAX = float(np.finfo(np.float32).max)


class SmallCoefficientWarning(UserWarning):
    """An ArduPilot coefficient (× 1e6) is nonzero but within MAVProxy's 1e-6 load threshold.

    Attributes
    ----------
    parameter : str
        The parameter, e.g. ``INS_TCAL1_GYR3_Z``.
    value : float
        Its written value (SI × 1e6).
    lost_share : float
        ``max |P_full − P_without_term|`` over ``[TMIN, TMAX]`` divided by the span
        ``max P_full − min P_full`` of the channel's correction there (a fraction, not %).
    """

    def __init__(self, message: str, parameter: str, value: float, lost_share: float) -> None:
        super().__init__(message)
        self.parameter = parameter
        self.value = value
        self.lost_share = lost_share


def _changed_lines(changed: tuple[FlightChoice, ...]) -> list[str]:
    """Header comments naming the channels written with another candidate than the model's."""
    if not changed:
        return []
    return [
        "# not the model file's choice (PX4/ArduPilot hold a cubic in T; the best one by",
        "# held-out RMS of 60 s means is written; compensate/navigate apply the file's):",
        *(f"#   {ch.describe()}" for ch in changed),
    ]


@dataclass(frozen=True)
class _Axis:
    """One axis of a sensor as flight software sees it."""

    channel: str
    coef: np.ndarray  # SI coefficients of d^0..d^3, d = T − t_ref [°C]
    t_ref: float  # [°C]
    t_min: float  # clamp range [°C]
    t_max: float


def _sensor_axes(model: FittedModel, sensor: str) -> list[_Axis]:
    """The three axes of a sensor (``gyro`` or ``accel``) as SI cubics with their clamp range."""
    out = []
    for a in _AXES:
        c = f"{sensor}_{a}"
        if c not in model.models:
            raise ConfigError(f"the model has no channel {c}; PX4/ArduPilot need all three axes")
        cm = model.models[c]
        method = cm.params.get("method")
        if method not in FLIGHT_METHODS:
            raise ConfigError(
                f"{c} is a {method} model: PX4 and ArduPilot take a clamped cubic in "
                f"temperature, i.e. a poly-t (degree <= 3), px4 or ardupilot model per "
                f"channel; export this model as a C header (--format c) instead"
            )
        if cm.unit_to_si is None:
            raise ConfigError(
                f"{c}: unit unknown (no log metadata); flight software needs SI coefficients"
            )
        coef = np.asarray(cm.params["coef"], dtype=np.float64)
        if coef.size > 4:
            raise ConfigError(f"{c}: degree {coef.size - 1} > 3 does not fit PX4/ArduPilot")
        coef = np.pad(coef, (0, 4 - coef.size))
        ref = cm.static_reference
        coef[0] = coef[0] - ref if ref is not None else 0.0
        if method == "poly-t":
            lo, hi = float(cm.train_range[0, 0]), float(cm.train_range[0, 1])
        else:  # px4 / ardupilot: the model's own clamp
            lo, hi = float(cm.params["t_min"]), float(cm.params["t_max"])
        out.append(_Axis(c, coef * cm.unit_to_si, float(cm.params["t_ref"]), lo, hi))
    return out


def _inward_range(axes: list[_Axis], what: str) -> tuple[str, str]:
    """``TMIN``/``TMAX`` text [°C]: the axes' common range rounded inwards.

    ``TMIN`` is rounded up and ``TMAX`` down to :data:`TEMP_DECIMALS` decimals, exactly (in
    decimal): the written numbers lie inside the common range of the axes.
    """
    lo = max(ax.t_min for ax in axes)
    hi = min(ax.t_max for ax in axes)
    q = Decimal(1).scaleb(-TEMP_DECIMALS)
    a = Decimal(lo).quantize(q, rounding=ROUND_CEILING)  # Decimal(float) is exact
    b = Decimal(hi).quantize(q, rounding=ROUND_FLOOR)
    if a > b:
        raise ConfigError(
            f"{what}: the common temperature range of the channels [{lo:g}, {hi:g}] degC "
            f"holds no {q} degC step once rounded inwards; the axes' ranges must overlap"
        )
    return f"{a + 0:.{TEMP_DECIMALS}f}", f"{b + 0:.{TEMP_DECIMALS}f}"


def _device_id(value: int | None, model: FittedModel, key: str, option: str, param: str) -> int:
    """The int32 ``TC_*0_ID`` of a sensor: the option, else ``source["device_ids"][key]``."""
    topic, cal = {
        "gyro": ("sensor_gyro", "CAL_GYRO0_ID"),
        "accel": ("sensor_accel", "CAL_ACC0_ID"),
    }[key]
    where = option
    if value is None:
        ids = model.source.get("device_ids")
        if isinstance(ids, Mapping) and ids.get(key) is not None:
            value, where = ids[key], f'the model\'s source["device_ids"]["{key}"]'
    how = (
        f"pass {option}: PX4 applies the thermal parameters only to the sensor whose device "
        f"id equals {param}, so {param} = 0 means the file is never applied. The id is the "
        f"device_id of {topic} in a ULog of the vehicle, or its {cal} parameter"
    )
    if value is None:
        raise ConfigError(
            f"PX4 export needs the {key} device id and the model has none "
            f'(no source["device_ids"]["{key}"]); {how}'
        )
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ConfigError(f"{where}: the {key} device id must be an integer, got {value!r}; {how}")
    v = int(value)
    if v == 0:
        raise ConfigError(f"{where}: the {key} device id is 0; {how}")
    if not _INT32_MIN <= v <= _UINT32_MAX:
        raise ConfigError(
            f"{where}: the {key} device id {v} is neither an int32 nor a uint32; {how}"
        )
    return v - 2**32 if v > _INT32_MAX else v  # PX4 stores the uint32 id as an int32


def _float_text(name: str, value: float) -> str:
    """A float parameter as written (9 significant digits: round-trips a float32)."""
    if not np.isfinite(value) or abs(value) > _FLOAT32_MAX:
        raise ConfigError(f"{name} = {value!r} is not a finite float32; the model is unusable")
    return f"{value:.9g}"


def _instance(model: FittedModel) -> int | None:
    """The IMU instance the model was fitted on (``source["instance"]``, from a flight log)."""
    v = model.source.get("instance")
    return int(v) if isinstance(v, int) and not isinstance(v, bool) and v >= 0 else None


def to_px4_params(
    model: FittedModel,
    gyro_id: int | None = None,
    accel_id: int | None = None,
    instance: int | None = None,
) -> str:
    """PX4 thermal-compensation parameters (one ``TC_G<n>``/``TC_A<n>`` set).

    Parameters
    ----------
    model : FittedModel
        Every gyro and accelerometer channel a ``poly-t`` (degree ≤ 3), ``px4`` or
        ``ardupilot`` model with known units, or an ``auto`` choice the file keeps such a
        candidate for (:func:`flight_model`: the best one by held-out RMS is written, and
        named in the header comments).
    gyro_id, accel_id : int, optional
        Device ids of the gyro and accelerometer (``TC_G0_ID``, ``TC_A0_ID``): the
        ``device_id`` of ``sensor_gyro``/``sensor_accel`` in a ULog (uint32) or the
        ``CAL_GYRO0_ID``/``CAL_ACC0_ID`` parameter (int32). ``None``: the model's
        ``source["device_ids"]["gyro"|"accel"]``; an explicit id wins.
    instance : int, optional
        The parameter set ``n`` 0-3, numbered as the readers number IMU instances (PX4
        applies a set to the sensor whose id it holds, whatever the set). Default: the
        model's ``source["instance"]`` (a model fitted on ULog instance 1 goes to
        ``TC_G1``/``TC_A1`` and leaves instance 0's set alone), else 0.

    Returns
    -------
    str
        The ``.params`` file text (SI: rad/s, m/s²; temperatures in °C).

    Raises
    ------
    ConfigError
        A device id missing or 0 (naming ``--gyro-id``/``--accel-id``), a channel whose
        method is not a clamped cubic, unknown units, or axes without a common range.
    """
    model, changed = flight_model(model)
    slot = instance
    if slot is None:
        inst = _instance(model)
        slot = inst if inst is not None and inst <= 3 else 0
    if slot not in (0, 1, 2, 3):
        raise ConfigError(f"PX4 thermal parameter set (instance) must be 0-3, got {slot}")
    ids = {
        "gyro": _device_id(gyro_id, model, "gyro", "--gyro-id", f"TC_G{slot}_ID"),
        "accel": _device_id(accel_id, model, "accel", "--accel-id", f"TC_A{slot}_ID"),
    }
    lines = [
        "# PX4 thermal compensation parameters, written by rinscal",
        f"# X0 = bias at TREF {'without Earth rate/gravity' if _has_ref(model) else 'set to 0'}"
        "; SI units (rad/s, m/s^2); TMIN/TMAX rounded inwards (degC)",
        f"# TC_G{slot}_ID = {ids['gyro']}, TC_A{slot}_ID = {ids['accel']}: applied only to the "
        "sensors with these device ids.",
        "# PX4 uses the FIRST set (TC_G0.., TC_A0..) whose ID equals a sensor's device id, and",
        "# loading this file clears no other set: if another set already holds one of these",
        "# ids, set that set's ID to 0 first (or export into it with --instance).",
        "# TC_G_ENABLE and TC_A_ENABLE take effect after a reboot.",
        *_changed_lines(changed),
        "#",
        "# Vehicle-Id\tComponent-Id\tName\tValue\tType",
    ]

    def put(name: str, text: str, typ: int = 9) -> None:
        lines.append(f"1\t1\t{name}\t{text}\t{typ}")

    for sensor, tag in (("gyro", "G"), ("accel", "A")):
        axes = _sensor_axes(model, sensor)
        tmin, tmax = _inward_range(axes, f"TC_{tag}{slot}_TMIN/TMAX")
        # PX4 has one TREF/TMIN/TMAX per sensor: each axis's cubic is re-expanded about the
        # mean reference (as written), and the range is the one every axis is valid on
        tref_text = _float_text(f"TC_{tag}{slot}_TREF", float(np.mean([ax.t_ref for ax in axes])))
        tref = float(tref_text)
        put(f"TC_{tag}_ENABLE", "1", 6)
        put(f"TC_{tag}{slot}_ID", str(ids[sensor]), 6)
        coefs = [poly_shift(ax.coef, ax.t_ref - tref, 1.0) for ax in axes]
        for k in (3, 2, 1, 0):
            for i, coef in enumerate(coefs):
                name = f"TC_{tag}{slot}_X{k}_{i}"
                put(name, _float_text(name, float(coef[k])))
        put(f"TC_{tag}{slot}_TREF", tref_text)
        put(f"TC_{tag}{slot}_TMIN", tmin)
        put(f"TC_{tag}{slot}_TMAX", tmax)
    return "\n".join(lines) + "\n"


def _has_ref(model: FittedModel) -> bool:
    return all(cm.static_reference is not None for cm in model.models.values())


def _poly_range(c: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """Min and max of ``Σ_k c[k] d^k`` for ``d`` in ``[lo, hi]`` (endpoints and extrema)."""
    d = [lo, hi]
    deriv = np.polynomial.polynomial.polyder(c)
    if np.any(deriv != 0):
        for r in np.polynomial.polynomial.polyroots(np.trim_zeros(deriv, "b")):
            if abs(r.imag) <= 1e-12 * max(1.0, abs(r.real)) and lo < r.real < hi:
                d.append(float(r.real))
    v = np.polynomial.polynomial.polyval(np.asarray(d), c)
    return float(v.min()), float(v.max())


def lost_share(coef: np.ndarray, k: int, t_min: float, t_max: float) -> float:
    """Share of a channel's ArduPilot thermal span lost when term ``k`` is zeroed.

    Parameters
    ----------
    coef : ndarray, shape (4,)
        ``[0, c1, c2, c3]``: ArduPilot's polynomial ``P(d) = Σ c_k d^k``, ``d = T − 35`` [°C]
        (any consistent unit: the share is a ratio).
    k : int
        The term zeroed (1 to 3).
    t_min, t_max : float [°C]
        The clamp range ``[TMIN, TMAX]``.

    Returns
    -------
    float
        ``max |P_full − P_without_k|`` over the range divided by ``max P_full − min P_full``
        (a fraction; ``inf`` if the span is 0).
    """
    lo, hi = t_min - ARDUPILOT_TREF_C, t_max - ARDUPILOT_TREF_C
    p_lo, p_hi = _poly_range(np.asarray(coef, dtype=np.float64), lo, hi)
    lost = abs(float(coef[k])) * max(abs(lo), abs(hi)) ** k  # |c_k d^k| peaks at an endpoint
    span = p_hi - p_lo
    return lost / span if span > 0 else float("inf")


def to_ardupilot_parm(model: FittedModel, instance: int | None = None) -> str:
    """ArduPilot ``INS_TCALn_*`` parameters of a clamped-cubic model.

    Parameters
    ----------
    model : FittedModel
        Every gyro and accelerometer channel a ``poly-t`` (degree ≤ 3), ``px4`` or
        ``ardupilot`` model with known units, or an ``auto`` choice the file keeps such a
        candidate for (:func:`flight_model`, as for :func:`to_px4_params`).
    instance : int, optional
        The IMU instance, numbered as the readers number it (DataFlash ``IMU.I``, 0-based):
        0, 1, 2 write ``INS_TCAL1_*`` .. ``INS_TCAL3_*``. Default: the model's
        ``source["instance"]`` (the instance it was fitted on), else 0. Instances 3 and 4
        (IMUs 4 and 5, whose parameters ArduPilot keeps under ``INS4_TCAL_*`` and
        ``INS5_TCAL_*``) are refused.

    Returns
    -------
    str
        The ``.parm`` file text (coefficients in SI × 1e6; temperatures in °C).

    Warns
    -----
    SmallCoefficientWarning
        Per written coefficient ``v`` with ``0 < |v| ≤ 1e-6``, which MAVProxy's ``param load``
        does not send to a vehicle where it is 0 (see :data:`MAVPROXY_MIN_DELTA`).
    """
    model, changed = flight_model(model)
    if instance is None:
        instance = _instance(model) or 0
    try:
        p = ardupilot_tcal_prefix(instance)
    except ValueError:
        p = ""
    if not p.startswith("INS_TCAL"):
        where = (
            f"keeps its temperature calibration under {p}*, which this export does not write"
            if p
            else "has no parameters in ArduPilot"
        )
        raise ConfigError(
            f"ArduPilot IMU instance {instance} (IMU {instance + 1}) {where}; the export "
            "writes instances 0, 1 and 2 (INS_TCAL1_* .. INS_TCAL3_*)"
        )
    imu = instance + 1
    blocks: dict[str, list[tuple[str, np.ndarray]]] = {}
    all_axes: list[_Axis] = []
    for sensor, tag in (("accel", "ACC"), ("gyro", "GYR")):
        axes = _sensor_axes(model, sensor)
        all_axes += axes
        blocks[tag] = [
            (ax.channel, poly_shift(ax.coef, ax.t_ref - ARDUPILOT_TREF_C, 1.0)) for ax in axes
        ]
    tmin, tmax = _inward_range(all_axes, f"{p}TMIN/TMAX")
    ids = model.source.get("device_ids")
    lines = [
        "# ArduPilot IMU temperature calibration, written by rinscal",
        *(
            [f"# for IMU {imu} (device ids: gyro {ids.get('gyro')}, accel {ids.get('accel')})"]
            if isinstance(ids, Mapping)
            else []
        ),
        "# cubic about 35 degC, no constant term, coefficients x 1e6 (SI units);",
        "# TMIN/TMAX: the common range of all six channels, rounded inwards (degC)",
        *_changed_lines(changed),
        f"{p}ENABLE 1",
        f"{p}TMIN {tmin}",
        f"{p}TMAX {tmax}",
    ]
    written: dict[tuple[str, int], np.ndarray] = {}  # (tag, axis) -> [0, v1, v2, v3] as written
    for tag in ("ACC", "GYR"):
        for k in (1, 2, 3):
            for i, a in enumerate(_AXES):
                name = f"{p}{tag}{k}_{a.upper()}"
                text = _float_text(name, float(blocks[tag][i][1][k] * ARDUPILOT_SCALE))
                lines.append(f"{name} {text}")
                written.setdefault((tag, i), np.zeros(4))[k] = float(text)
    t_lo, t_hi = float(tmin), float(tmax)
    for (tag, i), values in written.items():
        channel = blocks[tag][i][0]
        for k in (1, 2, 3):
            value = float(values[k])
            if value == 0.0 or abs(value) > MAVPROXY_MIN_DELTA:
                continue
            name = f"{p}{tag}{k}_{_AXES[i].upper()}"
            share = lost_share(values, k, t_lo, t_hi)
            warnings.warn(
                SmallCoefficientWarning(
                    f"{name} = {value:.3g} is nonzero but within MAVProxy's 1e-6 load "
                    f"threshold: 'param load' does not send a value within 1e-6 of the "
                    f"vehicle's current one (pymavlink MAVParmDict.mindelta), so on a vehicle "
                    f"where it is 0 (the default) it stays 0 and {channel} loses "
                    f"{100 * share:.1f} % of its thermal span over [{tmin}, {tmax}] degC; "
                    f"load with 'param forceload' or set it by hand",
                    parameter=name,
                    value=value,
                    lost_share=share,
                ),
                stacklevel=2,
            )
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- C header


def _c(v: float) -> str:
    return repr(float(v)) if np.isfinite(v) else "0.0"


def _carr(name: str, values: np.ndarray) -> str:
    vals = ", ".join(_c(v) for v in np.asarray(values, dtype=np.float64).ravel())
    return f"static const double {name}[{max(np.size(values), 1)}] = {{{vals or '0.0'}}};"


def _horner_c(var: str, coef: list[float]) -> str:
    """C expression of ``Σ_{k=1..K} coef[k−1] var^k`` evaluated as in ``_inference._horner``."""
    expr = _c(coef[-1])
    for c in coef[-2::-1]:
        expr = f"({expr} * {var} + {_c(c)})"
    return f"({expr} * {var})"


def _regression_c(p: dict, out: str, indent: str) -> list[str]:
    lines = [f"{indent}{out} = {_c(p['intercept'])};"]
    names = ("T", "Tdot", "dT")
    for v, order in enumerate(p["orders"]):
        if order == 0:
            continue
        z = f"z{v}"
        lines.append(
            f"{indent}{{ const double {z} = ({names[v]} - {_c(p['center'][v])}) * "
            f"(1.0 / {_c(p['scale'][v])});"
        )
        lines.append(f"{indent}  {out} += {_horner_c(z, p['coef'][v])}; }}")
    return lines


def to_c_header(model: FittedModel, prefix: str = "rinscal") -> str:
    """A self-contained C99 header evaluating the model of every channel.

    Parameters
    ----------
    model : FittedModel
        Any model.
    prefix : str
        Prefix of every C identifier (letters, digits, underscores).

    Returns
    -------
    str
        Header text; ``double <prefix>_<channel>(double T, double Tdot, double dT)``
        returns the modelled output in log units (``dT`` ignored without a gradient term).
    """
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise ConfigError(f"C prefix must be an identifier, got {prefix!r}")
    guard = f"{prefix.upper()}_THERMAL_MODEL_H"
    lines = [
        f"/* Thermal model ({model.method}) written by rinscal ({model.created_by}).",
        " * f(T, Tdot, dT): T inner temperature [degC], Tdot its rate [degC/min]",
        f" * ({model.derivative_kind} least-squares slope over {model.derivative_window_s:g} s),",
        " * dT = T - T_outer [degC]. Returns the modelled output in the log's units;",
        " * compensated = raw - (f - STATIC_REF). No clamping (px4/ardupilot models: their own",
        " * clamp, part of the model): see the _MIN and _MAX macros. */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "#include <math.h>",
        "",
    ]
    for c in model.channels:
        cm = model.models[c]
        p = cm.params
        fn = f"{prefix}_{c}"
        up = fn.upper()
        for i in range(cm.n_inputs):
            lines.append(f"#define {up}_{INPUT_NAMES[i].upper()}_MIN {_c(cm.train_range[i, 0])}")
            lines.append(f"#define {up}_{INPUT_NAMES[i].upper()}_MAX {_c(cm.train_range[i, 1])}")
        if cm.static_reference is not None:
            lines.append(f"#define {up}_STATIC_REF {_c(cm.static_reference)}")
        if cm.unit_to_si is not None:
            lines.append(f"#define {up}_UNIT_TO_SI {_c(cm.unit_to_si)}  /* {cm.unit} */")
        body: list[str] = []
        if p["method"] in FLIGHT_METHODS:
            coef = [float(v) for v in p["coef"]]
            if p["method"] == "poly-t":
                body.append(f"  const double d = T - {_c(p['t_ref'])};")
            else:  # px4 / ardupilot: the clamp is part of the model
                lo, hi = _c(p["t_min"]), _c(p["t_max"])
                body.append(f"  const double Tc = T < {lo} ? {lo} : (T > {hi} ? {hi} : T);")
                body.append(f"  const double d = Tc - {_c(p['t_ref'])};")
            if len(coef) == 1:
                body.append(f"  return {_c(coef[0])};")
            else:
                body.append(f"  return {_horner_c('d', coef[1:])} + {_c(coef[0])};")
        elif p["method"] == "regression":
            body.append("  double f;")
            body += _regression_c(p, "f", "  ")
            body.append("  return f;")
        elif p["method"] == "sectional":
            edges = [float(e) for e in p["edges"]]
            lines.append(_carr(f"{fn}_edges", np.asarray(edges)))
            body.append("  double f;")
            body.append("  int k = 0;")
            body.append(f"  while (k < {len(edges)} && T > {fn}_edges[k]) k++;")
            body.append("  switch (k) {")
            for k in range(len(edges) + 1):
                body.append(f"  case {k}:")
                body += _regression_c(segment_params(p, k), "f", "    ")
                body.append("    break;")
            body.append("  default: f = 0.0;")
            body.append("  }")
            body.append("  return f;")
        elif p["method"] == "neural":
            w = np.asarray(p["W"], dtype=np.float64)
            n, d = w.shape
            inv = 1.0 / np.asarray(p["x_scale"], dtype=np.float64)
            wf = w * inv[None, :]
            bf = np.asarray(p["b"], dtype=np.float64) - wf @ np.asarray(p["x_mean"])
            lines.append(_carr(f"{fn}_W", wf))
            lines.append(_carr(f"{fn}_b", bf))
            lines.append(_carr(f"{fn}_v", np.asarray(p["v"], dtype=np.float64)))
            body.append("  const double x[3] = {T, Tdot, dT};")
            body.append("  double acc = 0.0;")
            body.append(f"  for (int j = 0; j < {n}; j++) {{")
            body.append("    double a = 0.0;")
            body.append(f"    for (int i = 0; i < {d}; i++) a += x[i] * {fn}_W[j * {d} + i];")
            body.append(f"    a += {fn}_b[j];")
            body.append("    acc += (0.5 + 0.5 * tanh(0.5 * a)) * " + f"{fn}_v[j];")
            body.append("  }")
            body.append(
                f"  return (acc + {_c(p['b_out'])}) * {_c(p['y_scale'])} + {_c(p['y_mean'])};"
            )
        else:
            raise ConfigError(f"{c}: no C form for method {p['method']!r}")
        lines.append(f"static inline double {fn}(double T, double Tdot, double dT) {{")
        lines.append("  (void)T; (void)Tdot; (void)dT;")
        lines += body
        lines.append("}")
        lines.append("")
    if model.imu_stage is not None:
        lines += _imu_c(model, model.imu_stage, prefix)
    lines.append(f"#endif /* {guard} */")
    return "\n".join(lines) + "\n"


_KIND_ARRAY = {"sf": "sf", "sf_asym": "asym", "sf_quad": "quad"}


def _imu_c(model: FittedModel, stage: ImuStage, prefix: str) -> list[str]:
    """C of the IMU calibration's step and of the whole compensation (see the module
    docstring), evaluated as :meth:`ImuStage.physical` and
    :meth:`rinscal.sensormodel.ImuCalibration.value` (same Horner order)."""
    cal = stage.calibration
    lo, hi = cal.t_range_c
    fn = f"{prefix}_imu_correct"
    k_in = np.array([stage.input_unit_to_si[c] for c in _CHANNELS])
    lines = [
        "/* IMU calibration, applied before the thermal model: raw (log units) x UNIT_TO_SI",
        " * -> SI -> inverse sensor model at each channel's inner temperature T (clamped to",
        f" * [{lo:g}, {hi:g}] degC; laws in T - {cal.t0_c:g}): scale factor and nonlinear terms",
        " * (fixed-point iteration), then misalignment (solve I + M) -> deg/h and ug. */",
        _carr(f"{fn}_unit_to_si", k_in),
        _carr(f"{fn}_physical_to_si", PHYSICAL_TO_SI),
        f"static inline void {fn}(const double raw[6], const double T[6], const double Tdot[6],",
        "                         double out[6]) {",
        "  (void)Tdot;",
        "  double sf[6] = {0}, asym[6] = {0}, quad[6] = {0}, mis[6][3] = {{0}};",
        "  double x[6], r[6];",
        "  for (int i = 0; i < 6; i++) {",
        f"    const double Tc = T[i] < {_c(lo)} ? {_c(lo)} : (T[i] > {_c(hi)} ? {_c(hi)} : T[i]);",
        f"    x[i] = Tc - {_c(cal.t0_c)};",
        "    r[i] = Tdot[i];",
        "  }",
    ]
    for p in PARAMETERS:
        t = list(cal.t_coefs.get(p.name, ()))
        rate = list(cal.rate_coefs.get(p.name, ()))
        if not t and not rate:
            continue
        ch = p.channel
        expr = "0.0"
        for c in reversed(t):  # ImuCalibration._poly: out = out * x + c
            expr = f"({expr} * x[{ch}] + {_c(c)})"
        if rate:
            rexpr = "0.0"
            for c in reversed([0.0, *rate]):
                rexpr = f"({rexpr} * r[{ch}] + {_c(c)})"
            expr = f"({expr} + {rexpr})"
        value = f"{expr} * {_c(p.to_si)}"
        if p.kind == "bias":
            continue  # the thermal model holds the bias
        if p.kind == "mis":
            base = 3 if p.sensor == "accel" else 0
            lines.append(f"  mis[{base + p.axis}][{p.towards}] = {value};  /* {p.name} */")
        else:
            lines.append(f"  {_KIND_ARRAY[p.kind]}[{ch}] = {value};  /* {p.name} */")
    lines += [
        "  for (int b = 0; b < 6; b += 3) {",
        "    double u[3];",
        "    for (int j = 0; j < 3; j++) {",
        "      const int i = b + j;",
        f"      const double y = raw[i] * {fn}_unit_to_si[i];",
        "      const double gain = 1.0 + sf[i];",
        "      u[j] = y / gain;",
        "      for (int it = 0; it < 3; it++)",
        "        u[j] = (y - asym[i] * fabs(u[j]) - quad[i] * u[j] * u[j]) / gain;",
        "    }",
        "    /* s = (I + M)^-1 u by Gaussian elimination with partial pivoting */",
        "    double a[3][4];",
        "    for (int j = 0; j < 3; j++) {",
        "      for (int k = 0; k < 3; k++) a[j][k] = (j == k ? 1.0 : 0.0) + mis[b + j][k];",
        "      a[j][3] = u[j];",
        "    }",
        "    for (int c = 0; c < 3; c++) {",
        "      int piv = c;",
        "      for (int j = c + 1; j < 3; j++) if (fabs(a[j][c]) > fabs(a[piv][c])) piv = j;",
        "      for (int k = 0; k < 4; k++) { double t = a[c][k]; a[c][k] = a[piv][k]; "
        "a[piv][k] = t; }",
        "      for (int j = c + 1; j < 3; j++) {",
        "        const double f = a[j][c] / a[c][c];",
        "        for (int k = c; k < 4; k++) a[j][k] -= f * a[c][k];",
        "      }",
        "    }",
        "    for (int j = 2; j >= 0; j--) {",
        "      double v = a[j][3];",
        "      for (int k = j + 1; k < 3; k++) v -= a[j][k] * out[b + k];",
        "      out[b + j] = v / a[j][j];",
        "    }",
        f"    for (int j = 0; j < 3; j++) out[b + j] /= {fn}_physical_to_si[b + j];",
        "  }",
        "}",
        "",
        "/* The whole compensation in the model file's order: the IMU calibration, then the",
        " * thermal bias, out = y - (f(T, Tdot, dT) - STATIC_REF), in deg/h and ug. */",
        f"static inline void {prefix}_compensate(const double raw[6], const double T[6],",
        "    const double Tdot[6], const double dT[6], double out[6]) {",
        f"  {fn}(raw, T, Tdot, out);",
    ]
    for c in model.channels:
        i = _CHANNELS.index(c)
        ref = model.models[c].static_reference
        ref_text = f" - {prefix.upper()}_{c.upper()}_STATIC_REF" if ref is not None else ""
        lines.append(f"  out[{i}] -= {prefix}_{c}(T[{i}], Tdot[{i}], dT[{i}]){ref_text};")
    lines += ["}", ""]
    return lines
