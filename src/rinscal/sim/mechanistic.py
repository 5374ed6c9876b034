"""The mechanistic thermal law: each channel's bias driven by the thermal network's own
states (electronics, block, coil, stress), with first-order lags (:class:`MechanisticThermal`,
engineering units)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numba
import numpy as np
from numpy.typing import NDArray

from rinscal.errors import ConfigError
from rinscal.sim._checks import _finite
from rinscal.sim.field import (
    BLOCK,
    COIL0,
    ELECTRONICS,
    N_GYROS,
    SENSOR0,
    STRESS0,
    ThermalField,
)

__all__ = [
    "MechanisticThermal",
    "first_order_lag",
]


@dataclass(frozen=True)
class MechanisticThermal:
    """Thermal bias of one channel driven by the network's own states (engineering units).

    The bias is a sum of physically shaped terms, each driven by a node of the thermal
    network (:data:`rinscal.sim.field.NODE_NAMES`), several of them nodes that no
    thermometer sees::

        b = b0
          + k_t · s_t · tanh((T_j − t_ref) / s_t)             own temperature, saturating
          + k_mount · y + k_mount2 · y²,  y = T_block − t_mount_c   mount, zero at assembly
          + k_elec · (L_τe[T_electronics] − t_ref)            electronics box, lagged
          + k_path · (T_electronics − T_block)                gradient along the mount path
          + k_coil · (T_coil − T_hub)                         coil's radial gradient (gyros)
          + k_stress · σ_j                                    package stress (τ_σ lag)

    ``T_j`` is the sensor's own node (its inner thermometer's), ``L_τ`` a first-order lag of
    time constant ``τ`` (:func:`first_order_lag`, from equilibrium at the run's first
    sample) and ``t_ref`` the configuration's ``t_ref_c``. Shupe, hysteresis and the signal
    errors come from the channel's ``[thermal.<channel>]`` table as under the polynomial law.
    See ``docs/plant.md`` ("The mechanistic law") for the physical reading of each term.

    Parameters
    ----------
    b0 : float [unit]
        Bias with every driving term at zero.
    k_t : float [unit/°C]
        Slope of the own-temperature term at ``t_ref``.
    t_sat_c : float [°C]
        Saturation scale of the own-temperature term (> 0): linear within a few degrees of
        ``t_ref``, bounded by ``±k_t·t_sat_c`` far from it.
    k_mount, k_mount2 : float [unit/°C, unit/°C²]
        Linear and quadratic sensitivity to the IMU block (the sensor's mount) relative to
        ``t_mount_c``; the linear term changes sign across ``t_mount_c``.
    t_mount_c : float [°C]
        Temperature at which the mount is stress-free (the bonding/assembly temperature).
    k_elec : float [unit/°C]
        Sensitivity to the lagged electronics-box temperature.
    tau_elec_s : float [s]
        Time constant of that lag (> 0): the readout's components behind the box node.
    k_path : float [unit/°C]
        Sensitivity to the gradient from the electronics box to the IMU block.
    k_coil : float [unit/°C]
        Sensitivity to the static radial gradient of a gyro's fibre coil (outer layers minus
        hub); must be 0 for an accelerometer.
    k_stress : float [unit/°C]
        Sensitivity to the hidden package-stress state (network ``tau_stress_s``).
    """

    b0: float = 0.0
    k_t: float = 0.0
    t_sat_c: float = 30.0
    k_mount: float = 0.0
    k_mount2: float = 0.0
    t_mount_c: float = 20.0
    k_elec: float = 0.0
    tau_elec_s: float = 600.0
    k_path: float = 0.0
    k_coil: float = 0.0
    k_stress: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _finite(f"mechanistic.{f.name}", getattr(self, f.name))
        if self.t_sat_c <= 0:
            raise ConfigError(f"mechanistic.t_sat_c must be > 0 °C, got {self.t_sat_c}")
        if self.tau_elec_s <= 0:
            raise ConfigError(f"mechanistic.tau_elec_s must be > 0 s, got {self.tau_elec_s}")

    def terms(self, field: ThermalField, j: int, t_ref_c: float) -> dict[str, NDArray[np.float64]]:
        """Each term of the bias of channel ``j`` [unit] through ``field`` (in time order,
        the whole run: the electronics lag starts at equilibrium with its first sample).

        Returns
        -------
        dict of str to ndarray, shape (n,)
            ``b0, temperature, mount, electronics, path, coil, stress``; their sum is
            :meth:`evaluate`.
        """
        if field.nodes is None:
            raise ConfigError(
                "the mechanistic thermal law needs the network's states (ThermalField.nodes, "
                "set by simulate_field)"
            )
        x = field.nodes
        n = x.shape[0]
        own = x[:, SENSOR0 + j]
        block = x[:, BLOCK]
        elec = x[:, ELECTRONICS]
        y = block - self.t_mount_c
        out = {
            "b0": np.full(n, self.b0),
            "temperature": self.k_t * self.t_sat_c * np.tanh((own - t_ref_c) / self.t_sat_c),
            "mount": self.k_mount * y + self.k_mount2 * y * y,
            "electronics": np.zeros(n),
            "path": self.k_path * (elec - block),
            "coil": np.zeros(n),
            "stress": self.k_stress * x[:, STRESS0 + j],
        }
        if self.k_elec:
            lag = first_order_lag(field.t, elec, self.tau_elec_s)
            out["electronics"] = self.k_elec * (lag - t_ref_c)
        if j < N_GYROS and self.k_coil:
            out["coil"] = self.k_coil * (x[:, COIL0 + j] - own)
        return out

    def evaluate(self, field: ThermalField, j: int, t_ref_c: float) -> NDArray[np.float64]:
        """Thermal bias [unit] of channel ``j`` through ``field`` (Shupe, hysteresis and
        signal errors excluded); see :meth:`terms`."""
        terms = self.terms(field, j, t_ref_c)
        out = terms.pop("b0")
        for v in terms.values():
            out = out + v
        return out


def first_order_lag(
    t: NDArray[np.float64], u: NDArray[np.float64], tau_s: float
) -> NDArray[np.float64]:
    """First-order lag ``τ dy/dt = u − y`` of a signal sampled at times ``t``.

    Exact for ``u`` linear between samples (any spacing), starting at equilibrium with the
    first sample (``y[0] = u[0]``).

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Sample times, increasing.
    u : ndarray, shape (n,)
        Input.
    tau_s : float [s]
        Time constant (> 0).

    Returns
    -------
    ndarray, shape (n,)
    """
    if not (math.isfinite(tau_s) and tau_s > 0):
        raise ConfigError(f"lag time constant must be > 0 s, got {tau_s}")
    return _lag(
        np.ascontiguousarray(t, dtype=np.float64),
        np.ascontiguousarray(u, dtype=np.float64),
        float(tau_s),
    )


@numba.njit(cache=True, nogil=True)
def _lag(t: NDArray[np.float64], u: NDArray[np.float64], tau: float) -> NDArray[np.float64]:
    out = np.empty(u.shape[0])  # pragma: no cover - compiled
    if u.shape[0] == 0:
        return out
    y = u[0]
    out[0] = y
    for k in range(u.shape[0] - 1):
        h = t[k + 1] - t[k]
        a = math.exp(-h / tau)
        # u linear over the step: y → a·y + (1 − a)·u[k] + (u[k+1] − u[k])·(1 − τ(1 − a)/h)
        y = a * y + (1.0 - a) * u[k] + (u[k + 1] - u[k]) * (1.0 - tau * (1.0 - a) / h)
        out[k + 1] = y
    return out
