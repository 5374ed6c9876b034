"""Export thermal models for flight software: PX4 ``.params``, ArduPilot ``.parm``, C headers.

PX4 (``src/lib/temperature_compensation``; parameters ``TC_G*``/``TC_A*``)
    ``offset = X0 + X1·d + X2·d² + X3·d³`` with ``d = clamp(T, TMIN, TMAX) − TREF``, and the
    corrected value is ``raw − offset``, in SI (rad/s, m/s²). Written here per axis
    ``_0.._2`` (x, y, z): ``TC_G0_X3_0 .. TC_G0_X0_2``, ``TC_G0_TREF``, ``TC_G0_TMIN``,
    ``TC_G0_TMAX`` (and ``TC_A0_*``), ``TC_G_ENABLE``/``TC_A_ENABLE`` = 1, ``TC_G0_ID``/
    ``TC_A0_ID`` = the device id you pass (PX4 matches the parameters to the sensor by it).
    ``X0`` is the bias at ``TREF`` without Earth rate/gravity (``f(TREF) − static_reference``)
    when the model knows its static reference, else 0 (only the thermal change relative to
    ``TREF`` is exported; the ordinary offset calibration keeps the constant). File format:
    QGroundControl's tab-separated ``vehicle-id component-id name value type`` lines
    (type 9 = float, 6 = int32). Only ``poly-t`` models of degree ≤ 3 fit this form.
ArduPilot (``AP_InertialSensor_tempcal.cpp``; parameters ``INS_TCALn_*``)
    ``v −= P(clamp(T) − 35) − P(clamp(CALTEMP) − 35)`` with ``P(d) = (c1 + (c2 + c3 d) d) d ·
    1e−6``: a fixed reference of 35 °C, no constant term, coefficients stored × 1e6, in SI.
    Written: ``INS_TCALn_ENABLE`` = 1, ``INS_TCALn_TMIN``, ``INS_TCALn_TMAX``,
    ``INS_TCALn_ACC1_X .. ACC3_Z``, ``INS_TCALn_GYR1_X .. GYR3_Z`` (the cubic re-expanded about
    35 °C) as ``NAME VALUE`` lines with ``#`` comments (MAVProxy/Mission Planner ``.parm``).
    ArduPilot has no TREF parameter; the constant is the job of its offset calibration and
    ``INS_ACCn_CALTEMP``/``INS_GYRn_CALTEMP``.
C header (every method)
    The coefficients as ``static const double`` arrays and one small ``static inline``
    reference function per channel, ``double <prefix>_<channel>(double T, double Tdot,
    double dT)`` returning ``f`` in log units (no clamping; the training ranges are given as
    macros), evaluated exactly as :func:`rinscal.calibration._inference.predict_params`.
"""

from __future__ import annotations

import re

import numpy as np

from rinscal.calibration._inference import poly_shift, segment_params
from rinscal.calibration.modelfile import INPUT_NAMES, ThermalModelFile
from rinscal.errors import ConfigError

__all__ = ["to_ardupilot_parm", "to_c_header", "to_px4_params"]

_AXES = ("x", "y", "z")
#: ArduPilot's fixed reference temperature [°C].
ARDUPILOT_TREF_C = 35.0
#: ArduPilot stores coefficients multiplied by this.
ARDUPILOT_SCALE = 1.0e6


def _poly_t_si(
    model: ThermalModelFile, sensor: str
) -> list[tuple[np.ndarray, float, float, float]]:
    """Per axis of a sensor: (SI coefficients about t_ref, t_ref, tmin, tmax)."""
    if model.method != "poly-t":
        raise ConfigError(
            f"PX4 and ArduPilot take a cubic in temperature: export a poly-t model, not "
            f"{model.method} (use the C header for the other methods)"
        )
    out = []
    for a in _AXES:
        c = f"{sensor}_{a}"
        if c not in model.models:
            raise ConfigError(f"the model has no channel {c}; PX4/ArduPilot need all three axes")
        cm = model.models[c]
        if cm.unit_to_si is None:
            raise ConfigError(
                f"{c}: unit unknown (no log metadata); flight software needs SI coefficients"
            )
        coef = np.asarray(cm.params["coef"], dtype=np.float64)
        if coef.size > 4:
            raise ConfigError(f"{c}: degree {coef.size - 1} > 3 does not fit PX4/ArduPilot")
        coef = np.pad(coef, (0, 4 - coef.size))
        ref = cm.static_reference
        coef = coef.copy()
        coef[0] = coef[0] - ref if ref is not None else 0.0
        out.append(
            (
                coef * cm.unit_to_si,
                float(cm.params["t_ref"]),
                float(cm.train_range[0, 0]),
                float(cm.train_range[0, 1]),
            )
        )
    return out


def to_px4_params(model: ThermalModelFile, gyro_id: int = 0, accel_id: int = 0) -> str:
    """PX4 thermal-compensation parameters of a ``poly-t`` model (instance 0).

    Parameters
    ----------
    model : ThermalModelFile
        A ``poly-t`` model of all six channels with known units.
    gyro_id, accel_id : int
        Device ids of the gyro and accelerometer (``TC_G0_ID``, ``TC_A0_ID``).

    Returns
    -------
    str
        The ``.params`` file text.
    """
    lines = [
        "# PX4 thermal compensation parameters, written by rinscal from a poly-t model",
        f"# X0 = bias at TREF {'without Earth rate/gravity' if _has_ref(model) else 'set to 0'}"
        "; SI units (rad/s, m/s^2); set TC_G0_ID/TC_A0_ID to your sensors' device ids",
        "#",
        "# Vehicle-Id\tComponent-Id\tName\tValue\tType",
    ]

    def put(name: str, value: float, typ: int = 9) -> None:
        text = str(int(value)) if typ == 6 else f"{value:.9g}"
        lines.append(f"1\t1\t{name}\t{text}\t{typ}")

    for sensor, tag, dev in (("gyro", "G", gyro_id), ("accel", "A", accel_id)):
        axes = _poly_t_si(model, sensor)
        # PX4 has one TREF/TMIN/TMAX per sensor: each axis's cubic is re-expanded about the
        # mean reference, and the range is the one every axis was trained on
        tref = float(np.mean([ax[1] for ax in axes]))
        put(f"TC_{tag}_ENABLE", 1, 6)
        put(f"TC_{tag}0_ID", int(dev), 6)
        coefs = [poly_shift(coef, t_ref - tref, 1.0) for coef, t_ref, _, _ in axes]
        for k in (3, 2, 1, 0):
            for i, coef in enumerate(coefs):
                put(f"TC_{tag}0_X{k}_{i}", float(coef[k]))
        put(f"TC_{tag}0_TREF", tref)
        put(f"TC_{tag}0_TMIN", max(ax[2] for ax in axes))
        put(f"TC_{tag}0_TMAX", min(ax[3] for ax in axes))
    return "\n".join(lines) + "\n"


def _has_ref(model: ThermalModelFile) -> bool:
    return all(cm.static_reference is not None for cm in model.models.values())


def to_ardupilot_parm(model: ThermalModelFile, imu: int = 1) -> str:
    """ArduPilot ``INS_TCALn_*`` parameters of a ``poly-t`` model.

    Parameters
    ----------
    model : ThermalModelFile
        A ``poly-t`` model of all six channels with known units.
    imu : int
        IMU instance ``n`` (1-3).

    Returns
    -------
    str
        The ``.parm`` file text.
    """
    if imu not in (1, 2, 3):
        raise ConfigError(f"ArduPilot IMU instance must be 1, 2 or 3, got {imu}")
    lines = [
        "# ArduPilot IMU temperature calibration, written by rinscal from a poly-t model",
        "# cubic about 35 degC, no constant term, coefficients x 1e6 (SI units)",
    ]
    tmin, tmax = -np.inf, np.inf
    blocks: dict[str, list[np.ndarray]] = {}
    for sensor, tag in (("accel", "ACC"), ("gyro", "GYR")):
        axes = _poly_t_si(model, sensor)
        per_axis = []
        for coef, t_ref, lo, hi in axes:
            about35 = poly_shift(coef, t_ref - ARDUPILOT_TREF_C, 1.0)
            per_axis.append(about35)
            tmin, tmax = max(tmin, lo), min(tmax, hi)
        blocks[tag] = per_axis
    p = f"INS_TCAL{imu}_"
    lines.append(f"{p}ENABLE 1")
    lines.append(f"{p}TMIN {tmin:.2f}")
    lines.append(f"{p}TMAX {tmax:.2f}")
    for tag in ("ACC", "GYR"):
        for k in (1, 2, 3):
            for i, a in enumerate(_AXES):
                value = blocks[tag][i][k] * ARDUPILOT_SCALE
                lines.append(f"{p}{tag}{k}_{a.upper()} {value:.9g}")
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


def to_c_header(model: ThermalModelFile, prefix: str = "rinscal") -> str:
    """A self-contained C99 header evaluating the model of every channel.

    Parameters
    ----------
    model : ThermalModelFile
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
        " * compensated = raw - (f - STATIC_REF). No clamping: see the _MIN and _MAX macros. */",
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
        if p["method"] == "poly-t":
            coef = [float(v) for v in p["coef"]]
            body.append(f"  const double d = T - {_c(p['t_ref'])};")
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
        else:  # neural
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
        lines.append(f"static inline double {fn}(double T, double Tdot, double dT) {{")
        lines.append("  (void)T; (void)Tdot; (void)dT;")
        lines += body
        lines.append("}")
        lines.append("")
    lines.append(f"#endif /* {guard} */")
    return "\n".join(lines) + "\n"
