"""The stochastic errors of an IMU (:class:`NoiseConfig`, data-sheet units) and the reading
of an IMU configuration document (a built-in preset or a TOML file) into its nested tables.

Shared by the simulator (:mod:`rinscal.sim.config` builds the whole plant from the document)
and navigation (a recording told ``imu=`` takes only the noise, :func:`load_noise`, and so
loads no simulator module).
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from rinscal import _check, units
from rinscal.errors import ConfigError
from rinscal.presets import PRESETS

__all__ = [
    "NoiseConfig",
    "NoiseSource",
    "imu_document",
    "imu_section",
    "load_noise",
    "preset_document",
    "toml_document",
]


@dataclass(frozen=True)
class NoiseConfig:
    """Stochastic errors of the sensors (engineering units, as on a data sheet).

    Parameters
    ----------
    gyro_arw_deg_rth : float [deg/√h]
        Gyro angle random walk.
    gyro_bias_rw_dph_rth : float [deg/h/√h]
        Gyro bias random walk.
    gyro_turn_on_dph : float [deg/h]
        Gyro turn-on-to-turn-on bias repeatability, 1σ.
    gyro_outlier_dph : float [deg/h]
        Size (1σ) of a gyro vibration outlier.
    accel_vrw_ug_rthz : float [µg/√Hz]
        Accelerometer white-noise density.
    accel_bias_rw_ug_rth : float [µg/√h]
        Accelerometer bias random walk.
    accel_turn_on_ug : float [µg]
        Accelerometer turn-on-to-turn-on repeatability, 1σ.
    accel_outlier_ug : float [µg]
        Size (1σ) of an accelerometer vibration outlier.
    outlier_rate_hz : float [1/s]
        Mean rate of single-sample outliers per channel (torque-motor vibration).
    gyro_angle_white_arcsec : float [arcsec]
        White *angle* noise of each gyro, the standard deviation of the angle read at each
        sample (readout and dither-stripping residual of a dithered ring laser, pulse
        quantisation aside): Allan deviation ``√3·s/τ`` (slope −1) whatever the rate.
        0 (the default): none.
    gyro_angle_markov_arcsec : float [arcsec]
        Stationary standard deviation of a first-order Gauss-Markov angle noise of each
        gyro (the slowly wandering part of the dither-stripping residual): Allan slope −½
        below ``gyro_angle_markov_tau_s``, −1 beyond; it never accumulates. 0: none.
    gyro_angle_markov_tau_s : float [s]
        Its correlation time (> 0 where it has a size).
    """

    gyro_arw_deg_rth: float = 0.001
    gyro_bias_rw_dph_rth: float = 0.0003
    gyro_turn_on_dph: float = 0.003
    gyro_outlier_dph: float = 5.0
    accel_vrw_ug_rthz: float = 10.0
    accel_bias_rw_ug_rth: float = 0.5
    accel_turn_on_ug: float = 15.0
    accel_outlier_ug: float = 1000.0
    outlier_rate_hz: float = 0.002
    gyro_angle_white_arcsec: float = 0.0
    gyro_angle_markov_arcsec: float = 0.0
    gyro_angle_markov_tau_s: float = 100.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _check.number(f"noise.{f.name}", getattr(self, f.name), min=0)
        if self.gyro_angle_markov_arcsec > 0 and not self.gyro_angle_markov_tau_s > 0:
            raise ConfigError(
                "noise.gyro_angle_markov_tau_s must be > 0 s with a Gauss-Markov angle noise, "
                f"got {self.gyro_angle_markov_tau_s}"
            )

    def angle_noise_si(self) -> tuple[float, float, float]:
        """Gyro angle noise: white sd [rad], Gauss-Markov sd [rad] and its time [s]."""
        return (
            self.gyro_angle_white_arcsec * units.ARCSEC_TO_RAD,
            self.gyro_angle_markov_arcsec * units.ARCSEC_TO_RAD,
            float(self.gyro_angle_markov_tau_s),
        )

    def white_density_si(self) -> NDArray[np.float64]:
        """White-noise density per channel [rad/s/√Hz = rad/√s, m/s²/√Hz]."""
        g = self.gyro_arw_deg_rth * units.DPRH_TO_RPRS
        a = self.accel_vrw_ug_rthz * units.UG_TO_MPS2
        return np.array([g] * 3 + [a] * 3)

    def bias_rw_si(self) -> NDArray[np.float64]:
        """Bias random-walk density per channel [rad/s/√s, m/s²/√s]."""
        g = self.gyro_bias_rw_dph_rth * units.DPH_TO_RPS / math.sqrt(units.HOUR_TO_S)
        a = self.accel_bias_rw_ug_rth * units.UG_TO_MPS2 / math.sqrt(units.HOUR_TO_S)
        return np.array([g] * 3 + [a] * 3)

    def turn_on_sd_si(self) -> NDArray[np.float64]:
        """Turn-on repeatability (1σ) per channel [rad/s, m/s²]."""
        g = self.gyro_turn_on_dph * units.DPH_TO_RPS
        a = self.accel_turn_on_ug * units.UG_TO_MPS2
        return np.array([g] * 3 + [a] * 3)

    def outlier_sd_si(self) -> NDArray[np.float64]:
        """Outlier size (1σ) per channel [rad/s, m/s²]."""
        g = self.gyro_outlier_dph * units.DPH_TO_RPS
        a = self.accel_outlier_ug * units.UG_TO_MPS2
        return np.array([g] * 3 + [a] * 3)


def preset_document(name: str) -> tuple[dict[str, Any], str]:
    """The nested tables of a built-in preset (see :data:`~rinscal.presets.PRESETS`) and the
    source named in errors."""
    if name not in PRESETS:
        raise ConfigError(f"unknown IMU preset {name!r}; choose one of {', '.join(PRESETS)}")
    text = resources.files("rinscal.data").joinpath(f"{name}.toml").read_text()
    return tomllib.loads(text), f"preset {name} ({name}.toml)"


def toml_document(path: str | os.PathLike[str]) -> tuple[dict[str, Any], str]:
    """The nested tables of an IMU TOML file and the source named in errors."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: IMU configuration file not found") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML: {e}") from None
    return data, str(path)


def imu_document(spec: str | os.PathLike[str]) -> tuple[dict[str, Any], str]:
    """The nested tables of an IMU given as a preset name or a TOML file path."""
    if not isinstance(spec, str | os.PathLike):
        raise _check.wrong_type("spec", spec, "an IMU preset name or a TOML file's path")
    if isinstance(spec, str) and spec in PRESETS:
        return preset_document(spec)
    path = Path(spec)
    if path.suffix.lower() != ".toml" and not path.exists():
        raise ConfigError(
            f"IMU {str(spec)!r} is neither a preset ({', '.join(PRESETS)}) nor a TOML file"
        )
    return toml_document(path)


def imu_section(data: dict[str, Any], name: str, names: set[str], source: str) -> dict[str, Any]:
    """The table ``[name]`` of a document, its keys among ``names``, lists as tuples."""
    sec = data.get(name)
    if not isinstance(sec, dict):
        raise ConfigError(f"{source}: [{name}] must be a table")
    bad = set(sec) - names
    if bad:
        raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} in [{name}]")
    return {k: tuple(v) if isinstance(v, list) else v for k, v in sec.items()}


def load_noise(spec: str | os.PathLike[str]) -> NoiseConfig:
    """The noise of an IMU given as a preset name or a TOML file path (its ``[noise]``)."""
    data, source = imu_document(spec)
    return NoiseConfig(**imu_section(data, "noise", {f.name for f in fields(NoiseConfig)}, source))


@runtime_checkable
class NoiseSource(Protocol):
    """Anything that names a unit and holds its noise: an ``ImuConfig`` of the simulator
    (:mod:`rinscal.sim.config`), seen from a layer that must not import it."""

    name: str
    noise: NoiseConfig
