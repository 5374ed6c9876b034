"""The IMU's sensor-error model: what turns a true rate and specific force into the output of
each channel, and back; its parameters, their names and units, and their laws in temperature.

Both the simulator (:mod:`rinscal.sim`, the truth) and the calibration
(:mod:`rinscal.calibration.imu`, the estimate, and every compensator) use it, so it lives on
the ground floor.

The forward model (one triad, gyros or accelerometers; ``s`` the true rate [rad/s] or
specific force [m/s²] resolved in the rotating IMU frame ``r``; ``j, k`` the axes x, y, z)::

    u_j = s_j + Σ_{k≠j} m_jk · s_k                           misalignment
    y_j = b_j + (1 + k_j) · u_j + a_j · |u_j| + q_j · u_j²    bias, scale factor, nonlinearity

- ``b_j`` the bias [rad/s, m/s²];
- ``k_j`` the linear scale-factor error [-] (``gyro_sf_x`` in ppm);
- ``a_j`` the asymmetry [-]: the scale factor is ``1 + k_j + a_j`` for positive and
  ``1 + k_j − a_j`` for negative input (gyros; ``gyro_sf_asym_x`` in ppm);
- ``q_j`` the quadratic term [1/(rad/s) or 1/(m/s²)]: a scale-factor error that grows with
  the input (``gyro_sf_quad_x`` in ppm per deg/s, ``accel_sf_quad_x`` in µg/g²);
- ``m_jk`` the misalignment [rad]: the tilt of sensing axis ``j`` towards IMU axis ``k``
  (``gyro_mis_xy`` is gyro x towards axis y, in arcsec), six per triad. It holds both the
  non-orthogonality of the triad and its alignment to the case.

This is the model of Wang, Cheng, Fu (Sensors 19, 3568, 2019, the paper's reference 29) with
the misalignment matrix written as ``I + M`` (``M`` zero on its diagonal) and the scale factor
applied after it; to first order it is ``y = b + (I + K + M) s`` plus the nonlinear terms,
the ``T`` matrix of :class:`pyins.inertial_sensor.Parameters` with ``T = (I + K)(I + M)``.
Pulses are ``y · dt / w`` for the pulse weight ``w`` of the channel (an angle or a velocity
increment); the scale-factor error is relative to that nominal weight.

The inverse (:func:`triad_inverse`) solves the scalar equation of each channel for ``u_j``
by fixed-point iteration (the nonlinear terms are ~1e-4 of the signal, so a few iterations
reach machine precision) and then ``s = (I + M)⁻¹ u``.

Each parameter is a function of temperature (:class:`ImuCalibration`): a polynomial in the
inner temperature ``T`` of its own channel about ``t0_c`` and, for a calibration on a ramp, a
polynomial in its rate ``Ṫ`` [°C/min]; outside the calibrated temperature range it is held at
the range's edge value (a polynomial in temperature is not trusted beyond its data).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import _check, units
from rinscal.errors import ConfigError

__all__ = [
    "AXES",
    "IMU_CALIBRATION_SCHEMA",
    "PARAMETERS",
    "ImuCalibration",
    "ParameterSpec",
    "TriadErrors",
    "parameter_spec",
    "triad_forward",
    "triad_inverse",
]

AXES = ("x", "y", "z")
#: Schema tag of a serialised :class:`ImuCalibration`.
IMU_CALIBRATION_SCHEMA = "rinscal.imu-calibration/1"

_PPM = 1e-6
#: ppm per deg/s to SI: a quadratic coefficient q [1/(rad/s)] with q·u² the error.
_PPM_PER_DPS = _PPM / units.DPS_TO_RPS
#: µg/g² to SI: q [1/(m/s²)] with q·f² the error [m/s²].
_UG_PER_G2 = units.UG_TO_MPS2 / units.G0**2


@dataclass(frozen=True)
class ParameterSpec:
    """One named parameter of the sensor-error model.

    Attributes
    ----------
    name : str
        e.g. ``gyro_sf_x``, ``accel_mis_zy``.
    sensor : {"gyro", "accel"}
        Triad.
    kind : {"bias", "sf", "sf_asym", "sf_quad", "mis"}
        Term of the forward model.
    axis : int
        Sensing axis (0, 1, 2 for x, y, z).
    towards : int or None
        For a misalignment, the axis the sensing axis tilts towards.
    unit : str
        Unit in tables and files (``deg/h``, ``ug``, ``ppm``, ``ppm/(deg/s)``, ``ug/g^2``,
        ``arcsec``).
    to_si : float
        Factor from ``unit`` to the SI value of the forward model.
    """

    name: str
    sensor: str
    kind: str
    axis: int
    towards: int | None
    unit: str
    to_si: float

    @property
    def channel(self) -> int:
        """Index of the parameter's channel in ``gyro_x .. accel_z`` (0-5)."""
        return self.axis + (3 if self.sensor == "accel" else 0)


def _specs() -> tuple[ParameterSpec, ...]:
    out: list[ParameterSpec] = []
    kinds = {
        "gyro": (
            ("bias", "deg/h", units.DPH_TO_RPS),
            ("sf", "ppm", _PPM),
            ("sf_asym", "ppm", _PPM),
            ("sf_quad", "ppm/(deg/s)", _PPM_PER_DPS),
        ),
        "accel": (
            ("bias", "ug", units.UG_TO_MPS2),
            ("sf", "ppm", _PPM),
            ("sf_quad", "ug/g^2", _UG_PER_G2),
        ),
    }
    for sensor, terms in kinds.items():
        for kind, unit, to_si in terms:
            for j, ax in enumerate(AXES):
                out.append(
                    ParameterSpec(f"{sensor}_{kind}_{ax}", sensor, kind, j, None, unit, to_si)
                )
        for j, ax in enumerate(AXES):
            for k, other in enumerate(AXES):
                if k != j:
                    out.append(
                        ParameterSpec(
                            f"{sensor}_mis_{ax}{other}",
                            sensor,
                            "mis",
                            j,
                            k,
                            "arcsec",
                            units.ARCSEC_TO_RAD,
                        )
                    )
    return tuple(out)


#: Every parameter of the model, gyros first, in table order.
PARAMETERS: tuple[ParameterSpec, ...] = _specs()
_BY_NAME = {p.name: p for p in PARAMETERS}


def parameter_spec(name: str) -> ParameterSpec:
    """The :class:`ParameterSpec` of ``name``; a :class:`ConfigError` naming the known ones."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise ConfigError(f"unknown IMU parameter {name!r}; known: {', '.join(_BY_NAME)}") from None


@dataclass(frozen=True)
class TriadErrors:
    """The errors of one triad in SI, constant or one row per sample.

    Attributes
    ----------
    bias : ndarray, shape (3,) or (n, 3) [rad/s or m/s²]
    sf : ndarray, shape (3,) or (n, 3) [-]
    asym : ndarray, shape (3,) or (n, 3) [-]
    quad : ndarray, shape (3,) or (n, 3) [1/(rad/s) or 1/(m/s²)]
    mis : ndarray, shape (3, 3) or (n, 3, 3) [rad]
        ``mis[..., j, k]``: axis ``j`` towards axis ``k``; zero diagonal.
    """

    bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    sf: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    asym: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    quad: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    mis: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))

    def matrix(self) -> NDArray[np.float64]:
        """``(I + K)(I + M)``: the linear part, as pyins' ``transform`` [-]."""
        eye = np.eye(3)
        return (1.0 + np.asarray(self.sf))[..., :, None] * (eye + np.asarray(self.mis))


def triad_forward(s: ArrayLike, e: TriadErrors) -> NDArray[np.float64]:
    """The output of a triad for the true input ``s`` (the forward model above).

    Parameters
    ----------
    s : array_like, shape (n, 3) or (3,) [rad/s or m/s²]
        True rate or specific force in ``r``.
    e : TriadErrors
        Errors, constant or per sample.

    Returns
    -------
    ndarray, shape of ``s`` [rad/s or m/s²]
        Output in SI (before any pulse weight).
    """
    s = np.asarray(s, dtype=float)
    mis = np.asarray(e.mis, dtype=float)
    u = s + np.einsum("...jk,...k->...j", mis, s)
    return e.bias + (1.0 + e.sf) * u + e.asym * np.abs(u) + e.quad * u * u


def triad_inverse(y: ArrayLike, e: TriadErrors, iterations: int = 8) -> NDArray[np.float64]:
    """The true input that gives the output ``y``: the inverse of :func:`triad_forward`.

    Parameters
    ----------
    y : array_like, shape (n, 3) or (3,) [rad/s or m/s²]
        Output in SI.
    e : TriadErrors
        Errors, constant or per sample.
    iterations : int
        Most fixed-point iterations of the scalar equation of each channel; it stops when
        the iterate no longer changes (3 reach machine precision for nonlinear terms below
        1e-4 of the signal).

    Returns
    -------
    ndarray, shape of ``y`` [rad/s or m/s²]
    """
    y = np.asarray(y, dtype=float)
    gain = 1.0 + np.asarray(e.sf)
    rest = y - e.bias
    u = rest / gain
    if np.any(e.asym) or np.any(e.quad):
        # a contraction with factor |a| + 2|q·u| (~1e-4): each pass gains four digits
        for _ in range(iterations):
            nxt = (rest - e.asym * np.abs(u) - e.quad * u * u) / gain
            done = np.all(np.abs(nxt - u) <= 1e-15 * (np.abs(nxt) + 1e-300))
            u = nxt
            if done:
                break
    a = np.eye(3) + np.asarray(e.mis, dtype=float)
    if a.ndim == 2:
        return np.linalg.solve(a, u.T).T if u.ndim == 2 else np.linalg.solve(a, u)
    return np.linalg.solve(a, u[..., None])[..., 0]


def _poly(coefs: tuple[float, ...], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Σ_k coefs[k]·x^k (constant first), Horner form."""
    out = np.zeros_like(x)
    for c in reversed(coefs):
        out = out * x + c
    return out


@dataclass(frozen=True)
class ImuCalibration:
    """The IMU's calibration: every parameter of the model as a function of temperature.

    ``value(T, Ṫ) = Σ_k t_coefs[k]·(T' − t0_c)^k + Σ_{k≥1} rate_coefs[k−1]·Ṫ^k`` in the
    parameter's table unit, with ``T'`` the inner temperature of the parameter's own channel
    clamped to ``t_range_c`` and ``Ṫ`` its rate [°C/min]. A parameter that is absent is zero.

    Parameters
    ----------
    t0_c : float [°C]
        Centre of the temperature polynomials.
    t_range_c : (float, float) [°C]
        Temperatures the calibration covered; outside, each law is held at the edge.
    t_coefs : dict of str to tuple of float [unit/°C^k]
        Temperature polynomial of each parameter, constant first.
    rate_coefs : dict of str to tuple of float [unit/(°C/min)^k]
        Rate polynomial (from a ramp calibration), first power first; may be empty.
    source : str
        Free text: where the calibration came from.
    """

    t0_c: float
    t_range_c: tuple[float, float]
    t_coefs: dict[str, tuple[float, ...]]
    rate_coefs: dict[str, tuple[float, ...]] = field(default_factory=dict)
    source: str = ""

    def __post_init__(self) -> None:
        _check.number("t0_c", self.t0_c)
        _check.numbers_of("t_range_c", self.t_range_c, length=2)
        _check.mapping("t_coefs", self.t_coefs)
        _check.mapping("rate_coefs", self.rate_coefs)
        for table in (self.t_coefs, self.rate_coefs):
            for name, coefs in table.items():
                _check.numbers_of(f"coefficients of {name}", coefs, nonempty=False)
        _check.instance("source", self.source, str, "free text (str)")
        lo, hi = self.t_range_c
        if not (math.isfinite(self.t0_c) and math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ConfigError(
                f"IMU calibration: t0_c {self.t0_c} and t_range_c {self.t_range_c} must be "
                "finite with low <= high"
            )
        for table in (self.t_coefs, self.rate_coefs):
            for name, coefs in table.items():
                parameter_spec(name)
                if not all(math.isfinite(float(c)) for c in coefs):
                    raise ConfigError(f"IMU calibration: {name} has a non-finite coefficient")

    # ------------------------------------------------------------------ evaluation
    def value(
        self, name: str, temp_c: ArrayLike, tdot_c_per_min: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """One parameter at the given temperatures, in its table unit (see
        :class:`ParameterSpec`)."""
        lo, hi = self.t_range_c
        x = np.clip(np.asarray(temp_c, dtype=float), lo, hi) - self.t0_c
        out = _poly(tuple(self.t_coefs.get(name, ())), x)
        rate = self.rate_coefs.get(name, ())
        if rate and tdot_c_per_min is not None:
            r = np.asarray(tdot_c_per_min, dtype=float)
            out = out + _poly((0.0, *rate), r)
        return np.asarray(out, dtype=float)

    def select(self, kinds: tuple[str, ...]) -> ImuCalibration:
        """The same calibration restricted to the parameters of the given kinds (``bias``,
        ``sf``, ``sf_asym``, ``sf_quad``, ``mis``); the others become zero."""
        keep = {p.name for p in PARAMETERS if p.kind in kinds}
        return ImuCalibration(
            self.t0_c,
            self.t_range_c,
            {n: c for n, c in self.t_coefs.items() if n in keep},
            {n: c for n, c in self.rate_coefs.items() if n in keep},
            self.source,
        )

    def relative_to(self, t_cal_c: float) -> ImuCalibration:
        """The thermal part of this calibration: every law minus its value at ``t_cal_c``
        [°C] (zero there), what remains for a unit whose computer already applies a
        calibration made at ``t_cal_c``."""
        t_coefs = {}
        for name, coefs in self.t_coefs.items():
            c = list(coefs) or [0.0]
            c[0] -= float(self.value(name, t_cal_c))
            t_coefs[name] = tuple(c)
        source = f"{self.source} (relative to {t_cal_c:g} °C)".strip()
        return ImuCalibration(self.t0_c, self.t_range_c, t_coefs, dict(self.rate_coefs), source)

    def triads(
        self, temp_c: ArrayLike, tdot_c_per_min: ArrayLike | None = None
    ) -> tuple[TriadErrors, TriadErrors]:
        """Gyro and accelerometer errors at the given channel temperatures.

        Parameters
        ----------
        temp_c : array_like, shape (6,) or (n, 6) [°C]
            Inner temperature of each channel (gyro x..z, accel x..z).
        tdot_c_per_min : array_like, shape of ``temp_c``, optional [°C/min]
            Its rate (used only by laws fitted on a ramp).

        Returns
        -------
        gyro, accel : TriadErrors
            In SI, one row per sample when ``temp_c`` is 2-D.
        """
        temp = np.asarray(temp_c, dtype=float)
        if temp.shape[-1] != 6:
            raise ConfigError(f"IMU calibration: need 6 channel temperatures, got {temp.shape}")
        tdot = None if tdot_c_per_min is None else np.asarray(tdot_c_per_min, dtype=float)
        lead = temp.shape[:-1]
        out = []
        for base, sensor in ((0, "gyro"), (3, "accel")):
            arrays = {k: np.zeros((*lead, 3)) for k in ("bias", "sf", "sf_asym", "sf_quad")}
            mis = np.zeros((*lead, 3, 3))
            for p in PARAMETERS:
                if p.sensor != sensor or (
                    p.name not in self.t_coefs and p.name not in self.rate_coefs
                ):
                    continue
                ch = base + p.axis
                v = (
                    self.value(p.name, temp[..., ch], None if tdot is None else tdot[..., ch])
                    * p.to_si
                )
                if p.kind == "mis":
                    assert p.towards is not None
                    mis[..., p.axis, p.towards] = v
                else:
                    arrays[p.kind][..., p.axis] = v
            out.append(
                TriadErrors(
                    bias=arrays["bias"],
                    sf=arrays["sf"],
                    asym=arrays["sf_asym"],
                    quad=arrays["sf_quad"],
                    mis=mis,
                )
            )
        return out[0], out[1]

    def correct(
        self,
        y_si: ArrayLike,
        temp_c: ArrayLike,
        tdot_c_per_min: ArrayLike | None = None,
        *,
        with_bias: bool = True,
    ) -> NDArray[np.float64]:
        """The true rates and specific forces behind the outputs ``y_si`` (the inverse model).

        Parameters
        ----------
        y_si : array_like, shape (n, 6) [rad/s, m/s²]
            Output of gyro x..z and accel x..z, pulses already multiplied by their weight.
        temp_c : array_like, shape (n, 6) [°C]
            Inner temperature of each channel.
        tdot_c_per_min : array_like, shape (n, 6), optional [°C/min]
        with_bias : bool
            Remove the calibration's biases too; ``False`` leaves them in the output (when
            a thermal bias model fitted on calibrated output removes them afterwards).

        Returns
        -------
        ndarray, shape (n, 6) [rad/s, m/s²]
        """
        y = _check.array("y_si", y_si, last=6)
        _check.array("temp_c", temp_c, last=6)
        _check.array("tdot_c_per_min", tdot_c_per_min, last=6, optional=True)
        _check.flag("with_bias", with_bias)
        gyro, accel = self.triads(temp_c, tdot_c_per_min)
        out = np.empty_like(y)
        for sl, e in ((slice(0, 3), gyro), (slice(3, 6), accel)):
            if not with_bias:
                e = TriadErrors(
                    bias=np.zeros_like(e.bias), sf=e.sf, asym=e.asym, quad=e.quad, mis=e.mis
                )
            out[..., sl] = triad_inverse(y[..., sl], e)
        return out

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (units in the parameter table's)."""
        return {
            "schema": IMU_CALIBRATION_SCHEMA,
            "t0_c": self.t0_c,
            "t_range_c": list(self.t_range_c),
            "units": {n: parameter_spec(n).unit for n in self.t_coefs},
            "t_coefs": {n: list(map(float, c)) for n, c in self.t_coefs.items()},
            "rate_coefs": {n: list(map(float, c)) for n, c in self.rate_coefs.items()},
            "source": self.source,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>") -> ImuCalibration:
        """Read :meth:`to_dict`'s layout; a :class:`ConfigError` naming ``source`` and the key
        otherwise."""
        if not isinstance(data, dict):
            raise ConfigError(f"{source}: not an IMU calibration (not a JSON object)")
        if data.get("schema") != IMU_CALIBRATION_SCHEMA:
            raise ConfigError(
                f"{source}: not an IMU calibration (schema {data.get('schema')!r}, "
                f"expected {IMU_CALIBRATION_SCHEMA!r})"
            )
        missing = [k for k in ("t0_c", "t_range_c", "t_coefs") if k not in data]
        if missing:
            raise ConfigError(f"{source}: malformed IMU calibration: no {', '.join(missing)}")

        def table(key: str) -> dict[str, tuple[float, ...]]:
            got = data.get(key, {})
            if not isinstance(got, dict):
                raise ConfigError(f"{source}: {key} must be an object of parameter: [coefficients]")
            out = {}
            for n, v in got.items():
                if not isinstance(v, list) or not all(
                    isinstance(c, int | float) and not isinstance(c, bool) for c in v
                ):
                    raise ConfigError(f"{source}: {key}.{n} must be a list of numbers, got {v!r}")
                out[str(n)] = tuple(float(c) for c in v)
            return out

        t_coefs, rate = table("t_coefs"), table("rate_coefs")
        rng = data["t_range_c"]
        if not (isinstance(rng, list) and len(rng) == 2 and all(_is_number(v) for v in rng)):
            raise ConfigError(f"{source}: t_range_c must be [low, high] in °C, got {rng!r}")
        if not _is_number(data["t0_c"]):
            raise ConfigError(f"{source}: t0_c must be a number [°C], got {data['t0_c']!r}")
        units_in = data.get("units", {})
        if not isinstance(units_in, dict):
            raise ConfigError(f"{source}: units must be an object of parameter: unit")
        try:
            for n, u in units_in.items():
                if parameter_spec(n).unit != u:
                    raise ConfigError(
                        f"{n} is in {u!r}, rinscal's unit is {parameter_spec(n).unit!r}"
                    )
            return cls(
                t0_c=float(data["t0_c"]),
                t_range_c=(float(rng[0]), float(rng[1])),
                t_coefs=t_coefs,
                rate_coefs=rate,
                source=str(data.get("source", "")),
            )
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)
