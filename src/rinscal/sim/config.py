"""The IMU's configuration: its thermal law, effects, noise, output and thermal network
(:class:`ImuConfig`), read from a preset or a TOML file (:func:`load_imu`).

The configuration file uses deg/h and µg (see ``rinscal/data/navigation_grade.toml``);
:data:`ENG_TO_SI` converts them to SI.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from rinscal import units
from rinscal._check import deprecated, wrong_type
from rinscal.errors import ConfigError
from rinscal.imunoise import (
    NoiseConfig,
    imu_document,
    imu_section,
    preset_document,
    toml_document,
)
from rinscal.presets import DEFAULT_PRESET, PRESETS
from rinscal.schema import CHANNELS
from rinscal.sim._checks import _finite
from rinscal.sim.field import (
    N_GYROS,
    ThermalNetworkConfig,
    ThermometerConfig,
)
from rinscal.sim.mechanistic import MechanisticThermal
from rinscal.sim.polynomial import POLYNOMIAL_KEYS, ChannelThermal

__all__ = [
    "ENGINEERING_UNITS",
    "ENG_TO_SI",
    "THERMAL_LAWS",
    "EffectsConfig",
    "ImuConfig",
    "NoiseConfig",
    "OutputConfig",
    "load_imu",
    "resolve_imu",
]


#: Engineering unit of each channel in configuration files and physical-unit logs.
ENGINEERING_UNITS = ("deg/h",) * 3 + ("ug",) * 3
#: Factor from the engineering unit of each channel to SI [(rad/s)/(deg/h) or (m/s²)/µg].
ENG_TO_SI = np.array([units.DPH_TO_RPS] * 3 + [units.UG_TO_MPS2] * 3)

#: The thermal laws an :class:`ImuConfig` can use (``[imu] thermal_law``).
THERMAL_LAWS = ("polynomial", "mechanistic")


@dataclass(frozen=True)
class EffectsConfig:
    """Which error effects beyond the polynomial bias the plant applies (all on by default).

    Parameters
    ----------
    shupe : bool
        FOG Shupe bias from the rate of the coil's radial gradient.
    hysteresis : bool
        Quartz accelerometer thermal hysteresis with persistent memory.
    scale_factor : bool
        Scale factor, its asymmetry and its quadratic term against temperature (off: each
        held at its value at ``t_cal_c``).
    misalignment : bool
        Non-orthogonality against temperature (off: held at its value at ``t_cal_c``).
    lever_arm : bool
        The accelerometers' lever arm from the turntable axis (size effect), navigation.
    rotation_heat : bool
        Heat fixed in the body reaching the turning sensors by encoder angle, and the torque
        motor's heat while the table moves.
    angle_noise : bool
        The gyros' angle noise (``[noise] gyro_angle_*``: a dithered ring laser's white and
        correlated angle noise); a preset without it has sizes 0, so the switch changes
        nothing there.
    quantisation : bool
        With ``[output] mode = "pulses"``, the navigation plant puts out whole pulses of
        ``gyro_pulse_arcsec`` and ``accel_pulse_mps``, the remainder carried to the next
        sample as a pulse counter does (off: the pulse mode writes counts only in a
        simulated calibration log, the navigation plant's output is not quantised).
    """

    shupe: bool = True
    hysteresis: bool = True
    scale_factor: bool = True
    misalignment: bool = True
    lever_arm: bool = True
    rotation_heat: bool = True
    angle_noise: bool = True
    quantisation: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            if not isinstance(getattr(self, f.name), bool):
                raise ConfigError(f"effects.{f.name} must be true or false")


@dataclass(frozen=True)
class OutputConfig:
    """How the IMU reports: physical units or pulses.

    Parameters
    ----------
    mode : {"physical", "pulses"}
        ``physical``: mean rate per sample in deg/h and µg; ``pulses``: integer counts per
        sample from an accumulator with carried remainder (FOG and I/F converter style).
    gyro_pulse_arcsec : float [arcsec]
        Angle weight of one gyro pulse.
    accel_pulse_mps : float [m/s]
        Velocity weight of one accelerometer pulse.
    """

    mode: Literal["physical", "pulses"] = "physical"
    gyro_pulse_arcsec: float = 0.001
    accel_pulse_mps: float = 1e-6

    def __post_init__(self) -> None:
        if self.mode not in ("physical", "pulses"):
            raise ConfigError(f"output.mode must be 'physical' or 'pulses', got {self.mode!r}")
        for name in ("gyro_pulse_arcsec", "accel_pulse_mps"):
            if _finite(f"output.{name}", getattr(self, name)) <= 0:
                raise ConfigError(f"output.{name} must be > 0")

    def pulse_weight_si(self) -> NDArray[np.float64]:
        """Increment weight of one pulse per channel [rad, m/s]."""
        return np.array(
            [self.gyro_pulse_arcsec * units.ARCSEC_TO_RAD] * 3 + [self.accel_pulse_mps] * 3
        )


@dataclass(frozen=True)
class ImuConfig:
    """Everything that defines a simulated IMU on its turntable in a chamber.

    Parameters
    ----------
    name : str
        Free text.
    latitude_deg : float [deg]
        Latitude of the turntable (Earth rate and gravity in the static outputs).
    heading_deg : float [deg]
        Azimuth of the IMU y axis at encoder zero, clockwise from north.
    altitude_m : float [m]
        Height above the ellipsoid.
    t_ref_c : float [°C]
        Reference temperature of the thermal-bias polynomial.
    t_cal_c : float [°C]
        Temperature at which scale factors and axes were calibrated: their thermal changes
        are proportional to ``T − t_cal_c``.
    thermal : tuple of 6 ChannelThermal
        Thermal-bias coefficients per channel (gyro x..z in deg/h, accel x..z in µg).
    noise : NoiseConfig
        Stochastic errors.
    output : OutputConfig
        Units of the log.
    network : ThermalNetworkConfig
        The lumped thermal network.
    thermometer : ThermometerConfig
        The temperature sensors.
    effects : EffectsConfig
        Which effects beyond the polynomial bias are applied.
    thermal_law : {"polynomial", "mechanistic"}
        The law of the thermal bias: the polynomial of each ``thermal`` entry, or the
        network-driven terms of each ``mechanistic`` entry (Shupe, hysteresis and signal
        errors from ``thermal`` under both).
    mechanistic : tuple of 6 MechanisticThermal or None
        The mechanistic law's coefficients per channel; required with that law (and then
        the polynomial keys of ``thermal`` must be left at zero), refused with the other.
    """

    name: str = "custom"
    latitude_deg: float = 32.06
    heading_deg: float = 0.0
    altitude_m: float = 10.0
    t_ref_c: float = 20.0
    t_cal_c: float = 20.0
    thermal: tuple[ChannelThermal, ...] = field(
        default_factory=lambda: tuple(ChannelThermal() for _ in CHANNELS)
    )
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    network: ThermalNetworkConfig = field(default_factory=ThermalNetworkConfig)
    thermometer: ThermometerConfig = field(default_factory=ThermometerConfig)
    effects: EffectsConfig = field(default_factory=EffectsConfig)
    thermal_law: str = "polynomial"
    mechanistic: tuple[MechanisticThermal, ...] | None = None

    def __post_init__(self) -> None:
        lat = _finite("imu.latitude_deg", self.latitude_deg)
        if abs(lat) > 89.0:
            raise ConfigError(f"imu.latitude_deg must be within ±89°, got {lat}")
        _finite("imu.heading_deg", self.heading_deg)
        _finite("imu.altitude_m", self.altitude_m)
        _finite("imu.t_ref_c", self.t_ref_c)
        _finite("imu.t_cal_c", self.t_cal_c)
        if len(self.thermal) != len(CHANNELS):
            raise ConfigError(f"thermal: need one table per channel {CHANNELS}")
        for j, (ch, coef) in enumerate(zip(CHANNELS, self.thermal, strict=True)):
            for key in ("misalignment_arcsec_per_c", "misalignment_arcsec"):
                own = getattr(coef, key)[j % 3]
                if own != 0.0:
                    raise ConfigError(
                        f"[thermal.{ch}] {key}[{j % 3}] must be 0 (the tilt "
                        f"of an axis towards itself is its scale factor), got {own}"
                    )
            if j >= N_GYROS:
                for key in ("sf_asym_ppm", "sf_asym_ppm_per_c"):
                    if getattr(coef, key) != 0.0:
                        raise ConfigError(
                            f"[thermal.{ch}] {key} must be 0: an accelerometer has no "
                            "scale-factor asymmetry in the model (rinscal.sensormodel)"
                        )
            if j < 3 and any(coef.lever_arm_m):
                raise ConfigError(f"[thermal.{ch}] lever_arm_m: a gyro has no size effect")
        if self.thermal_law not in THERMAL_LAWS:
            raise ConfigError(
                f"imu.thermal_law must be one of {', '.join(THERMAL_LAWS)}, "
                f"got {self.thermal_law!r}"
            )
        if self.thermal_law == "polynomial":
            if self.mechanistic is not None:
                raise ConfigError(
                    "[mechanistic] coefficients given but imu.thermal_law = 'polynomial' "
                    "(they would be ignored): set thermal_law = 'mechanistic' or drop them"
                )
            return
        if self.mechanistic is None or len(self.mechanistic) != len(CHANNELS):
            raise ConfigError(
                f"imu.thermal_law = 'mechanistic' needs one [mechanistic.<channel>] table per "
                f"channel {CHANNELS}"
            )
        blank = ChannelThermal()
        for j, (ch, coef, mech) in enumerate(
            zip(CHANNELS, self.thermal, self.mechanistic, strict=True)
        ):
            if not isinstance(mech, MechanisticThermal):
                raise ConfigError(f"mechanistic[{j}] must be a MechanisticThermal")
            if j >= N_GYROS and mech.k_coil != 0.0:
                raise ConfigError(f"[mechanistic.{ch}] k_coil: an accelerometer has no coil")
            used = [k for k in POLYNOMIAL_KEYS if getattr(coef, k) != getattr(blank, k)]
            used = [k for k in used if k not in ("t", "rate", "grad") or any(getattr(coef, k))]
            if used:
                raise ConfigError(
                    f"[thermal.{ch}] polynomial key(s) {used} set but imu.thermal_law = "
                    "'mechanistic' (they would be ignored): the bias is [mechanistic."
                    f"{ch}]'s"
                )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>") -> ImuConfig:
        """Build and validate a configuration from the nested TOML layout.

        Every section must be present (``[imu]``, ``[output]``, ``[noise]``,
        ``[thermometer]``, ``[network]``, ``[effects]`` and ``[thermal.<channel>]`` for each
        of the six channels): a missing one is an error naming it, never silent zeros.
        Unknown sections or keys raise :class:`ConfigError` naming them and ``source``.
        """
        known = {"imu", "output", "noise", "thermometer", "network", "effects", "thermal"}
        known_opt = {"mechanistic"}
        extra = set(data) - known - known_opt
        if extra:
            raise ConfigError(
                f"{source}: unknown section(s) {sorted(extra)}; known {sorted(known | known_opt)}"
            )
        thermal_sec = data.get("thermal", {})
        if not isinstance(thermal_sec, dict):
            raise ConfigError(f"{source}: [thermal] must be a table")

        def section(name: str, klass: type, allowed: set[str] | None = None) -> dict[str, Any]:
            return imu_section(data, name, allowed or {f.name for f in fields(klass)}, source)

        imu_keys = {
            "name",
            "latitude_deg",
            "heading_deg",
            "altitude_m",
            "t_ref_c",
            "t_cal_c",
            "thermal_law",
        }
        klasses = {
            "noise": NoiseConfig,
            "output": OutputConfig,
            "network": ThermalNetworkConfig,
            "thermometer": ThermometerConfig,
            "effects": EffectsConfig,
        }
        # unknown keys first (a typo is the likelier mistake), then missing sections
        for name, klass in klasses.items():
            if name in data:
                section(name, klass)
        imu = section("imu", cls, imu_keys) if "imu" in data else {}
        bad = set(thermal_sec) - set(CHANNELS)
        if bad:
            raise ConfigError(f"{source}: unknown channel(s) {sorted(bad)} in [thermal]")
        missing = [f"[{k}]" for k in sorted(known - {"thermal"}) if k not in data]
        missing += [f"[thermal.{ch}]" for ch in CHANNELS if ch not in thermal_sec]
        if missing:
            raise ConfigError(f"{source}: missing section(s) {', '.join(missing)}")
        law = imu.get("thermal_law", "polynomial")
        if law not in THERMAL_LAWS:
            raise ConfigError(
                f"{source}: imu.thermal_law must be one of {', '.join(THERMAL_LAWS)}, got {law!r}"
            )
        mechanistic = _mechanistic_section(data, law, source)
        thermal = []
        required = {"b0", "t"} if law == "polynomial" else set()
        for ch in CHANNELS:
            sec = thermal_sec[ch]
            if not isinstance(sec, dict):
                raise ConfigError(f"{source}: [thermal.{ch}] must be a table")
            bad = set(sec) - {f.name for f in fields(ChannelThermal)}
            if bad:
                raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} in [thermal.{ch}]")
            poly = sorted(set(sec) & set(POLYNOMIAL_KEYS))
            if law == "mechanistic" and poly:
                raise ConfigError(
                    f"{source}: polynomial key(s) {poly} in [thermal.{ch}] but imu.thermal_law "
                    f"= 'mechanistic': the bias is [mechanistic.{ch}]'s; [thermal.{ch}] keeps "
                    "only shupe, hysteresis, signal errors and lever arm"
                )
            lacking = required - set(sec)
            if lacking:
                raise ConfigError(f"{source}: missing key(s) {sorted(lacking)} in [thermal.{ch}]")
            kw = {k: tuple(v) if isinstance(v, list) else v for k, v in sec.items()}
            try:
                thermal.append(ChannelThermal(**kw))
            except (TypeError, ConfigError) as e:
                raise ConfigError(f"{source}: [thermal.{ch}] {e}") from None
        try:
            return cls(
                thermal=tuple(thermal),
                noise=NoiseConfig(**section("noise", NoiseConfig)),
                output=OutputConfig(**section("output", OutputConfig)),
                network=ThermalNetworkConfig(**section("network", ThermalNetworkConfig)),
                thermometer=ThermometerConfig(**section("thermometer", ThermometerConfig)),
                effects=EffectsConfig(**section("effects", EffectsConfig)),
                mechanistic=mechanistic,
                **imu,
            )
        except (TypeError, ConfigError) as e:
            raise ConfigError(f"{source}: {e}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ImuConfig:
        """Read a configuration from a TOML file (layout of ``navigation_grade.toml``)."""
        data, source = toml_document(path)
        return cls.from_dict(data, source=source)

    @classmethod
    def preset(cls, name: str) -> ImuConfig:
        """A built-in preset by name (see :data:`PRESETS`)."""
        data, source = preset_document(name)
        return cls.from_dict(data, source=source)

    @classmethod
    def navigation_grade(cls) -> ImuConfig:
        """The built-in preset: a navigation-grade FOG + quartz RINS (our own unit)."""
        return cls.preset("navigation_grade")

    @classmethod
    def paper(cls) -> ImuConfig:
        """The built-in preset of the paper's own IMU (Tables 4 and 6 converted)."""
        return cls.preset("paper")

    def to_dict(self) -> dict[str, Any]:
        """The nested TOML layout (round-trips through :meth:`from_dict`)."""
        drop = POLYNOMIAL_KEYS if self.thermal_law == "mechanistic" else ()
        out: dict[str, Any] = {
            "imu": {
                "name": self.name,
                "latitude_deg": self.latitude_deg,
                "heading_deg": self.heading_deg,
                "altitude_m": self.altitude_m,
                "t_ref_c": self.t_ref_c,
                "t_cal_c": self.t_cal_c,
                "thermal_law": self.thermal_law,
            },
            "output": asdict(self.output),
            "noise": asdict(self.noise),
            "thermometer": asdict(self.thermometer),
            "network": _toml_table(asdict(self.network)),
            "effects": asdict(self.effects),
            "thermal": {
                ch: _toml_table(asdict(c), drop=drop)
                for ch, c in zip(CHANNELS, self.thermal, strict=True)
            },
        }
        if self.mechanistic is not None:
            out["mechanistic"] = {
                ch: {k: v for k, v in asdict(m).items() if j < N_GYROS or k != "k_coil"}
                for j, (ch, m) in enumerate(zip(CHANNELS, self.mechanistic, strict=True))
            }
        return out

    # ------------------------------------------------------------------ derived
    @property
    def latitude(self) -> float:
        """Latitude [rad]."""
        return self.latitude_deg * units.DEG_TO_RAD

    @property
    def heading(self) -> float:
        """Heading of the IMU y axis at encoder zero [rad]."""
        return self.heading_deg * units.DEG_TO_RAD

    def thermal_network(self) -> ThermalNetworkConfig:
        """The network as simulated: without the body-fixed hot side if that effect is off."""
        if self.effects.rotation_heat:
            return self.network
        return replace(self.network, rotation_heat_c=0.0, p_motor=0.0)

    def log_units(self) -> tuple[str, ...]:
        """Unit of each channel in a log written with this configuration."""
        return ("pulse",) * 6 if self.output.mode == "pulses" else ENGINEERING_UNITS


#: What an ``imu=`` argument accepts, in words.
IMU_ACCEPTED = f"an IMU: a preset name ({', '.join(PRESETS)}), a TOML file's path or an ImuConfig"


def load_imu(spec: str | os.PathLike[str]) -> ImuConfig:
    """An IMU configuration from a preset name (:data:`PRESETS`) or a TOML file path."""
    data, source = imu_document(spec)
    return ImuConfig.from_dict(data, source=source)


def resolve_imu(
    imu: str | os.PathLike[str] | ImuConfig | None = None,
    config: str | os.PathLike[str] | ImuConfig | None = None,
) -> ImuConfig:
    """The plant a public function was given: ``imu=`` or its older spelling ``config=``.

    Every function of the API that takes an IMU takes it as ``imu=`` (a preset name of
    :data:`PRESETS`, an IMU TOML file's path or an :class:`ImuConfig`), default the paper's
    own (:data:`~rinscal.presets.DEFAULT_PRESET`), as the command line does.

    Raises
    ------
    ConfigError
        Both ``imu`` and ``config`` given; an unknown preset or a bad TOML file.
    ArgumentTypeError
        Neither a name, a path nor an ImuConfig (the message names the argument).
    """
    if imu is not None and config is not None:
        raise ConfigError(
            "give the IMU once: imu= (config= is its older spelling), not both "
            f"(got imu={_shown_imu(imu)} and config={_shown_imu(config)})"
        )
    deprecated("config", config, "imu=", depth=2)  # resolve_imu's caller's caller
    name, spec = ("config", config) if config is not None else ("imu", imu)
    if spec is None:
        return ImuConfig.preset(DEFAULT_PRESET)
    if isinstance(spec, ImuConfig):
        return spec
    if not isinstance(spec, str | os.PathLike):
        raise wrong_type(name, spec, IMU_ACCEPTED)
    return load_imu(spec)


def _shown_imu(spec: object) -> str:
    """An IMU argument in a message: an ImuConfig by its name, else its repr."""
    return f"ImuConfig {spec.name!r}" if isinstance(spec, ImuConfig) else repr(spec)


def _toml_table(d: dict[str, Any], drop: tuple[str, ...] = ()) -> dict[str, Any]:
    """A dataclass dict as TOML can hold it: tuples as lists, None and ``drop`` left out."""
    return {
        k: list(v) if isinstance(v, tuple) else v
        for k, v in d.items()
        if v is not None and k not in drop
    }


def _mechanistic_section(
    data: dict[str, Any], law: str, source: str
) -> tuple[MechanisticThermal, ...] | None:
    """The ``[mechanistic.<channel>]`` tables: all six with every coefficient (``k_coil``
    for gyros only) under the mechanistic law, none under the polynomial one."""
    sec = data.get("mechanistic")
    if law == "polynomial":
        if sec is not None:
            raise ConfigError(
                f"{source}: [mechanistic] given but imu.thermal_law is 'polynomial' (it would "
                'be ignored): set thermal_law = "mechanistic" in [imu] or drop the section'
            )
        return None
    if not isinstance(sec, dict):
        raise ConfigError(
            f"{source}: imu.thermal_law = 'mechanistic' needs the section(s) "
            + ", ".join(f"[mechanistic.{ch}]" for ch in CHANNELS)
        )
    bad = set(sec) - set(CHANNELS)
    if bad:
        raise ConfigError(f"{source}: unknown channel(s) {sorted(bad)} in [mechanistic]")
    missing = [f"[mechanistic.{ch}]" for ch in CHANNELS if ch not in sec]
    if missing:
        raise ConfigError(f"{source}: missing section(s) {', '.join(missing)}")
    names = [f.name for f in fields(MechanisticThermal)]
    out = []
    for j, ch in enumerate(CHANNELS):
        tab = sec[ch]
        if not isinstance(tab, dict):
            raise ConfigError(f"{source}: [mechanistic.{ch}] must be a table")
        allowed = set(names) if j < N_GYROS else set(names) - {"k_coil"}
        bad = set(tab) - allowed
        if bad:
            why = " (an accelerometer has no coil)" if "k_coil" in bad and j >= N_GYROS else ""
            raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} in [mechanistic.{ch}]{why}")
        lacking = sorted(allowed - set(tab), key=names.index)
        if lacking:
            raise ConfigError(f"{source}: missing key(s) {lacking} in [mechanistic.{ch}]")
        try:
            out.append(MechanisticThermal(**tab))
        except (TypeError, ConfigError) as e:
            raise ConfigError(f"{source}: [mechanistic.{ch}] {e}") from None
    return tuple(out)
