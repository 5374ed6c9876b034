"""The polynomial thermal law: each channel's bias as a polynomial in its own inner
temperature ``T``, the rate ``dT/dt``, the gradient ``ΔT``, their couplings and the hidden
package-stress state (:class:`ChannelThermal`, engineering units), and the channel's
signal errors (scale factor, its nonlinear terms and misalignment) as straight lines in
temperature."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from rinscal.errors import ConfigError
from rinscal.sim._checks import _finite

__all__ = [
    "POLYNOMIAL_KEYS",
    "ChannelThermal",
]


def _poly(coefs: tuple[float, ...], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Σ_k coefs[k]·x^(k+1) (no constant term), Horner form."""
    out = np.zeros_like(x)
    for c in reversed(coefs):
        out = (out + c) * x
    return out


def _poly_slope(coefs: tuple[float, ...], x: float) -> float:
    """Derivative of :func:`_poly` at the scalar ``x``."""
    return float(sum((k + 1) * c * x**k for k, c in enumerate(coefs)))


def _poly_window(
    coefs: tuple[float, ...],
    x: NDArray[np.float64],
    window: tuple[float, float] | None,
) -> NDArray[np.float64]:
    """:func:`_poly` inside ``window``, continued by its tangent outside (C¹), so that a
    polynomial fitted over a limited range does not explode beyond it."""
    if window is None or not coefs:
        return _poly(coefs, x)
    lo, hi = window
    xc = np.clip(x, lo, hi)
    out = _poly(coefs, xc)
    below, above = x < lo, x > hi
    if np.any(below):
        out[below] += _poly_slope(coefs, lo) * (x[below] - lo)
    if np.any(above):
        out[above] += _poly_slope(coefs, hi) * (x[above] - hi)
    return out


@dataclass(frozen=True)
class ChannelThermal:
    """Thermal-error coefficients of one channel, in engineering units (deg/h or µg).

    Bias: ``b = b0 + Σ t[k]·x^(k+1) + Σ rate[k]·r^(k+1) + Σ grad[k]·d^(k+1) + t_grad·x·d
    + t_rate·x·r + stress·s + shupe·ġ + h`` with ``x = T − t_ref`` [°C], ``r = dT/dt``
    [°C/min], ``d = ΔT`` [°C], ``s`` the hidden stress state [°C], ``ġ`` the rate of the
    radial gradient across a gyro's fibre coil [°C/min] (Shupe effect) and ``h`` the
    hysteresis of a quartz accelerometer (a play operator of half-width
    ``hysteresis_play_c`` on ``T``, ``h = ±hysteresis/2`` on a heating / cooling leg).

    Signal errors (the terms of :mod:`rinscal.sensormodel`, each a straight line in ``T``
    about ``t_cal``, the temperature of the unit's factory scale/axis calibration): scale
    factor ``scale_factor_ppm + scale_factor_ppm_per_c·(T − t_cal)``, asymmetry
    ``sf_asym_ppm + sf_asym_ppm_per_c·(T − t_cal)`` (gyros), quadratic term ``sf_quad +
    sf_quad_per_c·(T − t_cal)`` and the tilt towards each ``r`` axis ``misalignment_arcsec +
    misalignment_arcsec_per_c·(T − t_cal)``; :func:`rinscal.sim.sensor.sensor_law`
    collects them into an :class:`rinscal.sensormodel.ImuCalibration`. A raw (pulse) output
    carries them whole; a physical output, after the factory calibration at ``t_cal``, only
    their change since ``t_cal`` (to first order: ``(T − t_cal)·(scale_factor_ppm_per_c·1e-6
    ·s_j + Σ_k misalignment_arcsec_per_c[k]·(π/648000)·s_k)`` plus the drift of the
    nonlinear terms, for the true signal ``s`` along the ``r`` axes).

    Parameters
    ----------
    b0 : float [unit]
        Thermal bias at the reference temperature, at rest, without gradient.
    t : tuple of 1-4 float [unit/°C^k]
        Temperature polynomial.
    rate : tuple of 0-4 float [unit/(°C/min)^k]
        Temperature-rate polynomial (servo drift in accelerometers; the rate part of a
        FOG's thermal drift).
    grad : tuple of 0-4 float [unit/°C^k]
        Inside/outside gradient polynomial.
    t_grad : float [unit/°C²]
        Coupling of temperature and gradient.
    t_rate : float [unit/(°C·°C/min)]
        Coupling of temperature and rate.
    stress : float [unit/°C]
        Sensitivity to the hidden package-stress state.
    rate_range : (float, float) or None [°C/min]
        Range over which the rate polynomial holds; continued by its tangent outside.
    grad_range : (float, float) or None [°C]
        Range over which the gradient polynomial holds; continued by its tangent outside.
    shupe : float [unit/(°C/min)]
        Shupe bias per rate of the coil's radial gradient (gyros; outer minus hub).
    hysteresis : float [unit]
        Width of the thermal hysteresis loop (quartz accelerometers): heating and cooling
        legs differ by this much at the same temperature.
    hysteresis_play_c : float [°C]
        Half-width ``w`` of the play: a temperature reversal of ``2w`` takes the output from
        one leg to the other.
    scale_factor_ppm : float [ppm]
        Scale-factor error at ``t_cal`` (relative to the nominal pulse weight).
    scale_factor_ppm_per_c : float [ppm/°C]
        Scale-factor change with temperature.
    misalignment_arcsec : tuple of 3 float [arcsec]
        This axis's tilt towards the IMU axes x, y, z of the ``r`` frame at ``t_cal``
        (non-orthogonality and alignment to the case; its own entry must be 0).
    misalignment_arcsec_per_c : tuple of 3 float [arcsec/°C]
        Change with temperature of that tilt (its own entry must be 0: that is the scale
        factor; both checked by :class:`ImuConfig`).
    sf_asym_ppm : float [ppm]
        Scale-factor asymmetry at ``t_cal``: the scale factor is ``1 + k + a`` for positive
        and ``1 + k − a`` for negative input (gyros only; 0 for accelerometers).
    sf_asym_ppm_per_c : float [ppm/°C]
        Its change with temperature (gyros only).
    sf_quad : float [ppm/(deg/s) for gyros, µg/g² for accelerometers]
        Quadratic scale-factor term at ``t_cal``: the error ``q·u²`` of an input ``u``.
    sf_quad_per_c : float [ppm/(deg/s)/°C or µg/g²/°C]
        Its change with temperature.
    lever_arm_m : tuple of 3 float [m]
        Lever arm of an accelerometer's proof mass from the turntable axis, in ``r``, that
        the navigation computer's size-effect compensation leaves (the error of its lever-arm
        calibration; the whole arm for a computer that does not compensate): it senses
        ω×(ω×ρ) + ω̇×ρ. 0 for gyros.
    """

    b0: float = 0.0
    t: tuple[float, ...] = (0.0, 0.0, 0.0)
    rate: tuple[float, ...] = (0.0, 0.0)
    grad: tuple[float, ...] = (0.0, 0.0)
    t_grad: float = 0.0
    t_rate: float = 0.0
    stress: float = 0.0
    rate_range: tuple[float, float] | None = None
    grad_range: tuple[float, float] | None = None
    shupe: float = 0.0
    hysteresis: float = 0.0
    hysteresis_play_c: float = 1.0
    scale_factor_ppm_per_c: float = 0.0
    misalignment_arcsec_per_c: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale_factor_ppm: float = 0.0
    misalignment_arcsec: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sf_asym_ppm: float = 0.0
    sf_asym_ppm_per_c: float = 0.0
    sf_quad: float = 0.0
    sf_quad_per_c: float = 0.0
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            vals = () if v is None else v if isinstance(v, tuple) else (v,)
            for x in vals:
                _finite(f"thermal.{f.name}", x)
        for name, lo in (("t", 1), ("rate", 0), ("grad", 0)):
            if not lo <= len(getattr(self, name)) <= 4:
                raise ConfigError(f"thermal.{name} must have {lo} to 4 coefficients")
        for name in ("rate_range", "grad_range"):
            w = getattr(self, name)
            if w is not None and (len(w) != 2 or not w[0] < w[1]):
                raise ConfigError(f"thermal.{name} must be [low, high] with low < high")
        for name in ("misalignment_arcsec_per_c", "misalignment_arcsec", "lever_arm_m"):
            if len(getattr(self, name)) != 3:
                raise ConfigError(f"thermal.{name} must have 3 values (x, y, z)")
        if self.hysteresis_play_c <= 0:
            raise ConfigError("thermal.hysteresis_play_c must be > 0 °C")
        if self.hysteresis < 0:
            raise ConfigError("thermal.hysteresis (the loop width) must be >= 0")

    def evaluate(
        self,
        x: NDArray[np.float64],
        r: NDArray[np.float64],
        d: NDArray[np.float64],
        s: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Thermal bias [unit] for temperature offset ``x`` [°C], rate ``r`` [°C/min],
        gradient ``d`` [°C] and stress ``s`` [°C] (Shupe and hysteresis excluded)."""
        return (
            self.b0
            + _poly(self.t, x)
            + _poly_window(self.rate, r, self.rate_range)
            + _poly_window(self.grad, d, self.grad_range)
            + self.t_grad * x * d
            + self.t_rate * x * r
            + self.stress * s
        )


#: Keys of ``[thermal.<channel>]`` that make up the polynomial law's bias. Under the
#: mechanistic law they are replaced by ``[mechanistic.<channel>]``; the other keys of
#: ``[thermal.<channel>]`` (Shupe, hysteresis, signal errors, lever arm) hold under both laws.
POLYNOMIAL_KEYS = (
    "b0",
    "t",
    "rate",
    "grad",
    "t_grad",
    "t_rate",
    "stress",
    "rate_range",
    "grad_range",
)
