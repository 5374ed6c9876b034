"""The plant's scale factor, its nonlinear terms and misalignment as laws in temperature:
the true sensor-error model of the simulated unit.

Each channel of :class:`~rinscal.sim.config.ImuConfig` holds, beside its thermal bias,
the terms of the forward model of :mod:`rinscal.sensormodel` at the temperature of the
unit's factory calibration ``t_cal_c`` and their slopes in temperature
(:class:`~rinscal.sim.polynomial.ChannelThermal`): scale factor [ppm], asymmetry [ppm]
(gyros), quadratic term [ppm/(deg/s) or µg/g²] and the tilt of the sensing axis towards the
other two [arcsec]. :func:`sensor_law` collects them into one
:class:`~rinscal.sensormodel.ImuCalibration` (straight lines about ``t_cal_c``; no biases:
the bias of the plant is its thermal law, :func:`rinscal.sim.plant.thermal_bias_r`).

What the log holds depends on its unit (``[output] mode``):

- **pulses** is the RAW output: the whole forward model with every term at its absolute
  value at the channel's temperature (:func:`raw_output_r`), then pulses. What a turntable
  calibration estimates.
- **physical** (deg/h, µg) is the output after the unit's factory calibration at
  ``t_cal_c``: the values at ``t_cal_c`` are removed, and the signal error is each term's
  change since then, ``p(T) − p(t_cal)``, applied to first order (products of two
  parameters, below 1e-8 of the signal, neglected): the linear scale-factor and
  misalignment drift of :func:`rinscal.sim.plant.signal_errors_r` plus the drift of the
  nonlinear terms (:func:`nonlinear_drift_r`). With zero slopes of the nonlinear terms the
  physical output is bit for bit what it was before those terms existed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal.sensormodel import AXES, ImuCalibration, parameter_spec, triad_forward
from rinscal.sim.config import ImuConfig

__all__ = [
    "SENSOR_LAW_RANGE_C",
    "drift_law",
    "nonlinear_drift_coefs",
    "nonlinear_drift_r",
    "raw_output_r",
    "sensor_law",
]

#: Temperatures over which the plant's straight lines hold [°C]: wider than any chamber
#: protocol, so that the clamp of :class:`~rinscal.sensormodel.ImuCalibration` never acts.
SENSOR_LAW_RANGE_C = (-60.0, 100.0)

_PPM = 1e-6


def sensor_law(config: ImuConfig) -> ImuCalibration:
    """The plant's true scale-factor, asymmetry, quadratic and misalignment laws.

    Parameters
    ----------
    config : ImuConfig
        The plant. ``effects.scale_factor`` off holds scale factor, asymmetry and quadratic
        term at their values at ``t_cal_c``; ``effects.misalignment`` off holds the
        misalignments there.

    Returns
    -------
    ImuCalibration
        ``t0_c = config.t_cal_c``, ``t_range_c`` :data:`SENSOR_LAW_RANGE_C`, each parameter
        ``(value at t_cal, slope)`` in its table unit (ppm, ppm/(deg/s), µg/g², arcsec); no
        bias parameters.
    """
    fx = config.effects
    sf_on = 1.0 if fx.scale_factor else 0.0
    mis_on = 1.0 if fx.misalignment else 0.0
    coefs: dict[str, tuple[float, ...]] = {}
    for j, coef in enumerate(config.thermal):
        sensor = "gyro" if j < 3 else "accel"
        axis = j % 3
        ax = AXES[axis]
        coefs[f"{sensor}_sf_{ax}"] = (
            float(coef.scale_factor_ppm),
            sf_on * coef.scale_factor_ppm_per_c,
        )
        if sensor == "gyro":
            coefs[f"gyro_sf_asym_{ax}"] = (
                float(coef.sf_asym_ppm),
                sf_on * coef.sf_asym_ppm_per_c,
            )
        coefs[f"{sensor}_sf_quad_{ax}"] = (float(coef.sf_quad), sf_on * coef.sf_quad_per_c)
        for k, other in enumerate(AXES):
            if k != axis:
                coefs[f"{sensor}_mis_{ax}{other}"] = (
                    float(coef.misalignment_arcsec[k]),
                    mis_on * coef.misalignment_arcsec_per_c[k],
                )
    return ImuCalibration(
        t0_c=float(config.t_cal_c),
        t_range_c=SENSOR_LAW_RANGE_C,
        t_coefs=coefs,
        source=f"rinscal plant {config.name!r}",
    )


def drift_law(config: ImuConfig) -> ImuCalibration:
    """The laws of a physical-unit output: :func:`sensor_law` less its values at ``t_cal``
    (each parameter its change since the factory calibration, ``p(T) − p(t_cal)``)."""
    law = sensor_law(config)
    return ImuCalibration(
        t0_c=law.t0_c,
        t_range_c=law.t_range_c,
        t_coefs={k: (0.0, *v[1:]) for k, v in law.t_coefs.items()},
        source=law.source + ", change since t_cal",
    )


def raw_output_r(
    law: ImuCalibration,
    temp_c: ArrayLike,
    omega_r: ArrayLike,
    f_r: ArrayLike,
    bias_r: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The raw output of the six channels: the whole forward model of
    :mod:`rinscal.sensormodel` with every term at the channel's temperature.

    Parameters
    ----------
    law : ImuCalibration
        The plant's laws (:func:`sensor_law`).
    temp_c : array_like, shape (n, 6) or (6,) [°C]
        Inner temperature of each channel.
    omega_r, f_r : array_like, shape (n, 3) or (3,) [rad/s, m/s²]
        True angular rate and specific force in ``r``.
    bias_r : array_like, shape (n, 6) or (6,), optional [rad/s, m/s²]
        Bias of each channel (thermal bias, turn-on offset); default 0.

    Returns
    -------
    ndarray, shape (n, 6) or (6,) [rad/s, m/s²]
    """
    gyro, accel = law.triads(temp_c)
    out = np.concatenate([triad_forward(omega_r, gyro), triad_forward(f_r, accel)], axis=-1)
    if bias_r is not None:
        out = out + np.asarray(bias_r, dtype=float)
    return out


def nonlinear_drift_coefs(config: ImuConfig) -> NDArray[np.float64] | None:
    """Slopes of the asymmetry and quadratic terms, as one row per channel.

    Returns
    -------
    ndarray, shape (2, 6) or None
        Row 0: the asymmetry's slope ``a'_j`` [1/°C] (gyros; 0 for accelerometers), row 1:
        the quadratic term's ``q'_j`` [1/((rad/s)·°C) or 1/((m/s²)·°C)]; None when every
        slope is zero or the scale-factor effect is off (nothing to add).
    """
    if not config.effects.scale_factor:
        return None
    law = sensor_law(config)
    out = np.zeros((2, 6))
    for j in range(6):
        sensor = "gyro" if j < 3 else "accel"
        ax = AXES[j % 3]
        if sensor == "gyro":
            name = f"gyro_sf_asym_{ax}"
            out[0, j] = law.t_coefs[name][1] * parameter_spec(name).to_si
        name = f"{sensor}_sf_quad_{ax}"
        out[1, j] = law.t_coefs[name][1] * parameter_spec(name).to_si
    return out if np.any(out) else None


def nonlinear_drift_r(
    coefs: NDArray[np.float64],
    temp_offset: NDArray[np.float64],
    omega_r: ArrayLike,
    f_r: ArrayLike,
) -> NDArray[np.float64]:
    """The change since ``t_cal`` of the asymmetry and quadratic terms (physical output).

    Parameters
    ----------
    coefs : ndarray, shape (2, 6)
        From :func:`nonlinear_drift_coefs`.
    temp_offset : ndarray, shape (n, 6) [°C]
        ``T_j − t_cal`` of each channel.
    omega_r, f_r : array_like, shape (n, 3) or (3,) [rad/s, m/s²]
        True angular rate and specific force in ``r``.

    Returns
    -------
    ndarray, shape (n, 6) [rad/s, m/s²]
        ``(T_j − t_cal)·(a'_j·|s_j| + q'_j·s_j²)`` with ``a'``, ``q'`` the slopes.
    """
    s = np.concatenate(
        [np.atleast_2d(np.asarray(omega_r, float)), np.atleast_2d(np.asarray(f_r, float))],
        axis=1,
    )
    return temp_offset * (coefs[0] * np.abs(s) + coefs[1] * s * s)
