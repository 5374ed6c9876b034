"""Each channel's bias over time from a parked cold start on a static base (issue 38).

A parked vehicle at a known site records its IMU (on the turntable), the encoder angle and
the temperatures. The aided filter of :mod:`rinscal.nav.gnss_ins` (15 error states, the
biases in ``r`` as random walks) runs over the whole recording with three measurements at
every step: zero velocity and the known site (:mod:`rinscal.nav.aiding`, the engine's static
aiding, not a navigation loop of its own) and :class:`rinscal.nav.aiding.BodyHeadingHeld`
(the body does not turn: the table's rate against the encoder). Between opposite table
positions the projection of gravity through the unknown tilt and of the horizontal Earth
rate through the unknown heading change sign in ``r`` while the biases do not, so the
horizontal biases become observable once the table has turned; the vertical accelerometer
is seen against gravity, the vertical gyro against ``Ω sin L`` and the encoder. Heading and
tilt are the filter's attitude errors (nuisances), started from a coarse inertial-frame
alignment with the heading unknown; nothing is read from a reference. The coarse heading of
a few seconds is degrees off, where the error model is not linear, so the filter and
smoother run twice: over the first :data:`FIRST_PASS_S` from the coarse attitude, then over
the whole recording from the first pass's smoothed body attitude (constant on a static base).

A Rauch-Tung-Striebel fixed-interval smoother then runs backwards over the filter's stored
step covariances, so every epoch's bias uses the data on both sides. Closed-loop feedback
is handled as follows: with ``x⁺_k`` the correction fed back at step ``k``, an error
relative to the solution *before* that feedback is the error relative to the solution
after it plus ``x⁺_k`` (to first order, every state), so with ``e_k`` the smoothed error
relative to the fed-back solution at ``k``::

    A_k = P⁺_k Φ_{k+1}ᵀ (P⁻_{k+1})⁻¹
    e_k = A_k (e_{k+1} + x⁺_{k+1}),   e_last = 0
    P^s_k = P⁺_k + A_k (P^s_{k+1} − P⁻_{k+1}) A_kᵀ

and the smoothed bias is the filter's estimate plus ``e_k`` (the bias states are the bias
left in the compensated output). The prior of the first bias is zero with the unit's
turn-on repeatability (a zero-mean random effect per run); the random walk lets the bias
follow a cold start's warm-up. One axis cannot tell a horizontal sensor's misalignment
towards z (``g γ``) from its bias: the series is the *total equivalent error* on the static
base.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import block_diag

from rinscal import earth
from rinscal.errors import ConfigError
from rinscal.nav.aiding import (
    ATT,
    GYRO,
    N_STATES,
    VEL,
    BodyHeadingHeld,
    KnownPosition,
    Linearised,
    ZeroVelocity,
)
from rinscal.nav.align import InertialCoarseAlign
from rinscal.nav.attitude import euler_from_C_nb
from rinscal.nav.gnss_ins import (
    AidedInertial,
    ImuNoise,
    InitialSd,
    initial_covariance,
    kalman_update,
)
from rinscal.nav.rotation import C_br
from rinscal.nav.strapdown import Strapdown
from rinscal.schema import NavSamples

#: Prior sd of each gyro's error per unit of table rate [rad/rad] (200 ppm).
RATE_ERROR_SD = 2e-4
#: Their random walk [1/√s]: 180 ppm in an hour. They drift with the warm-up (about
#: 5 ppm/°C), and the x and y ones, which only their sum with the accelerometer bias
#: determines, carry into that sum (g × 3e-6 = 3 µg/√s) what a random walk of the bias alone
#: would miss: the heat fixed in the body gives each position its own bias (±15 µg at 42 °C
#: on ``paper``), which looks like a tilt and no state holds (docs/navigation.md).
RATE_ERROR_RW = 3e-6
#: Unmodelled specific-force error while the table turns [m/s²] (the lever arms' size
#: effect: 5 cm at 10 °/s is 1.5 mm/s²).
MOVE_ACCEL_SD = 2e-3
#: How far a bias may move per °C of its sensor's temperature, 1σ (gyro [rad/s/°C], accel
#: [m/s²/°C]): 0.01 °/h and 50 µg per °C, a navigation-grade unit's order (paper Table 6).
THERMAL_SD: tuple[float, float] = (0.01 * math.pi / 180 / 3600, 50 * 9.80665e-6)
#: And per °C/min of change of its temperature rate (0.1 °/h and 500 µg per °C/min).
THERMAL_RATE_SD: tuple[float, float] = (0.1 * math.pi / 180 / 3600, 500 * 9.80665e-6)
#: And per °C of change of the gradient between its sensor and the outside (``T − T_out``):
#: 0.01 °/h and 1000 µg per °C (the power-on gradient moves a navigation-grade
#: accelerometer by about a milli-g within the first minute: paper Table 6, ``dT``).
THERMAL_GRAD_SD: tuple[float, float] = (0.01 * math.pi / 180 / 3600, 1000 * 9.80665e-6)
#: Prior sd of each bias at power-on beyond the turn-on repeatability (gyro [rad/s], accel
#: [m/s²]): 0.01 °/h and 1000 µg. The thermal part of a bias at power-on is not zero: the
#: warm-up's rate and gradient act from the first second (on ``paper`` they put 300-600 µg
#: on a horizontal accelerometer at power-on), and a prior held to the turn-on
#: repeatability pulls the first minute's estimates towards zero before the first reversal
#: can tell bias from tilt. A gyro's is kept near its turn-on repeatability: its level is
#: told from the heading only slowly, and a wide prior let a 42 °C start's x gyro wander
#: (86 % of epochs within 2 sd at 0.05 °/h, 100 % at 0.01 °/h; tests/nav/test_fieldbias_plant.py).
POWER_ON_SD: tuple[float, float] = (0.01 * math.pi / 180 / 3600, 1000 * 9.80665e-6)
#: Length of the first pass [s], from the coarse attitude, whose smoothed attitude starts
#: the second (:func:`estimate_bias_series`): by then the heading is known to about an
#: arcminute on a navigation-grade unit.
FIRST_PASS_S = 1800.0
#: The least heading prior of the second pass [rad] (3 arcmin).
REFINED_HEADING_SD = math.radians(0.05)
#: Window of the temperature and its rate that drive the bias process noise [s].
THERMAL_WINDOW_S = 60.0
#: Time over which a cold start's warm-up may move a bias by one turn-on repeatability [s]:
#: sets the default bias random walk (:func:`field_noise`). Measured on 4 h parked starts
#: (tests/nav/_parked.py: a 0.02 °/h, 50 µg exponential warm-up of 30 min against 0.003 °/h,
#: 15 µg turn-on, 6 seeds): at 300 s every horizontal channel is within 2 sd on 100 % of
#: the epochs after the first period (median sd 0.0036 °/h, 3.1 µg); at 600 s the sd
#: halves but one seed's y gyro falls to 80 % (the others ≥ 98 %); at 3600 s the
#: horizontal gyros lag the warm-up (45-60 %).
WARM_UP_S = 300.0


def field_noise(
    gyro_noise_density: float,
    accel_noise_density: float,
    gyro_turn_on: float,
    accel_turn_on: float,
    gyro_bias_rw: float = 0.0,
    accel_bias_rw: float = 0.0,
    warm_up_s: float = WARM_UP_S,
) -> ImuNoise:
    """The filter's noise for a parked cold start, from the unit's noise.

    The bias prior is the turn-on repeatability; the bias random walk is the unit's own or,
    if larger, the one that moves a bias by one turn-on repeatability in ``warm_up_s``
    (``turn_on / √warm_up_s``): wide enough to follow the warm-up after a cold start.

    Parameters
    ----------
    gyro_noise_density : float [rad/√s]
    accel_noise_density : float [m/s²/√Hz]
    gyro_turn_on : float [rad/s]
        Turn-on-to-turn-on repeatability, 1σ.
    accel_turn_on : float [m/s²]
    gyro_bias_rw : float [rad/s/√s]
        The unit's bias random walk.
    accel_bias_rw : float [m/s²/√s]
    warm_up_s : float [s]
    """
    if not (math.isfinite(warm_up_s) and warm_up_s > 0):
        raise ConfigError(f"field noise: warm_up_s must be > 0 s, got {warm_up_s}")
    r = 1.0 / math.sqrt(warm_up_s)
    return ImuNoise(
        gyro_noise_density=gyro_noise_density,
        accel_noise_density=accel_noise_density,
        gyro_bias_sd=gyro_turn_on,
        accel_bias_sd=accel_turn_on,
        gyro_bias_rw=max(gyro_bias_rw, gyro_turn_on * r),
        accel_bias_rw=max(accel_bias_rw, accel_turn_on * r),
    )


@dataclass(frozen=True)
class BiasSeries:
    """Smoothed bias of each channel on an epoch grid (SI, IMU frame ``r``).

    Attributes
    ----------
    t : ndarray, shape (m,) [s]
        Epochs (end of each filter step).
    bias : ndarray, shape (m, 6) [rad/s, m/s²]
        Total equivalent error of gx, gy, gz, ax, ay, az on the static base.
    sd : ndarray, shape (m, 6)
        Its smoothed standard deviation (same units).
    temps : ndarray, shape (m, 6) [°C]
        Mean inner temperature per channel over each step (NaN where not recorded).
    temp_out : ndarray, shape (m,) [°C]
        Mean outer temperature over each step (NaN where not recorded).
    attitude : ndarray, shape (m, 3) [rad]
        Smoothed heading (clockwise from north), pitch and roll of the body.
    attitude_sd : ndarray, shape (m, 3) [rad]
        Their standard deviations.
    rate_error : ndarray, shape (m, 3) [rad/rad], optional
        Smoothed gyro error per unit of table rate (z: scale-factor error; x, y:
        misalignment towards the table axis, known only together with the accelerometer
        bias it mimics), which acts only while the table turns.
    rate_error_sd : ndarray, shape (m, 3), optional
        Its standard deviation.
    table_rate : ndarray, shape (m,) [rad/s], optional
        Mean table rate over each step.
    separable_s : float [s], optional
        When the table has first stood at two positions half a turn apart: from then on the
        horizontal biases are told from heading and tilt (:func:`first_reversal_end`; the
        vertical ones are from the start), if less well than after the first period. None:
        as ``first_period_s``.
    first_period_s : float [s]
        End of the table's first full rotation period (it has stood in, or passed, all
        four quarter turns and come back to its starting angle); ``inf`` if it never did.
    """

    t: NDArray[np.float64]
    bias: NDArray[np.float64]
    sd: NDArray[np.float64]
    temps: NDArray[np.float64]
    temp_out: NDArray[np.float64]
    attitude: NDArray[np.float64]
    attitude_sd: NDArray[np.float64]
    first_period_s: float
    rate_error: NDArray[np.float64] | None = None
    rate_error_sd: NDArray[np.float64] | None = None
    table_rate: NDArray[np.float64] | None = None
    separable_s: float | None = None


def _concat(pieces: Iterable[NavSamples]) -> dict[str, NDArray[np.float64]]:
    parts: dict[str, list[NDArray[np.float64]]] = {
        k: [] for k in ("t", "dt", "dtheta", "dv", "table", "temps", "temp_out")
    }
    for p in pieces:
        if p.table is None:
            raise ConfigError("field bias: the recording has no encoder angle (table)")
        n = p.n
        parts["t"].append(p.t)
        parts["dt"].append(p.dt)
        parts["dtheta"].append(p.dtheta)
        parts["dv"].append(p.dv)
        parts["table"].append(p.table)
        parts["temps"].append(p.temps if p.temps is not None else np.full((n, 6), np.nan))
        parts["temp_out"].append(p.temp_out if p.temp_out is not None else np.full(n, np.nan))
    if not parts["t"]:
        raise ConfigError("field bias: the recording has no samples")
    return {k: np.concatenate(v) for k, v in parts.items()}


def first_period_end(t: ArrayLike, angle: ArrayLike, tol: float = math.radians(0.05)) -> float:
    """End of the table's first full rotation period [s].

    The first time at which the (unwrapped) encoder angle, relative to its first value, has
    been nearest to each of the four quarter turns and is back within ``tol`` [rad] of its
    start (modulo a turn); ``inf`` if that never happens.

    Parameters
    ----------
    t : array_like, shape (n,) [s]
    angle : array_like, shape (n,) [rad]
        Encoder angle (wrapped or not).
    """
    a = np.unwrap(np.asarray(angle, dtype=float))
    rel = a - a[0]
    quarter = np.mod(np.rint(rel / (0.5 * math.pi)), 4).astype(np.int64)
    tt = np.asarray(t, dtype=float)
    firsts = [np.flatnonzero(quarter == q) for q in range(4)]
    if any(f.size == 0 for f in firsts):
        return math.inf
    first_all = max(int(f[0]) for f in firsts)
    wrapped = np.abs(np.angle(np.exp(1j * rel[first_all:])))
    back = np.flatnonzero(wrapped <= tol)
    return float(tt[first_all + back[0]]) if back.size else math.inf


def first_reversal_end(t: ArrayLike, angle: ArrayLike, tol: float = math.radians(5.0)) -> float:
    """The first time [s] the table stands at an angle half a turn from its first one
    (within ``tol`` [rad]) and has stopped there: between two opposite positions every
    horizontal projection of gravity and of the Earth rate changes sign while the biases do
    not. ``inf`` if it never does."""
    a = np.asarray(angle, dtype=float)
    tt = np.asarray(t, dtype=float)
    if a.size < 2:
        return math.inf
    rel = np.abs(np.angle(np.exp(1j * (a - a[0]))))
    still = np.abs(np.diff(a, prepend=a[0])) < 1e-9
    hit = np.flatnonzero((rel >= math.pi - tol) & still)
    return float(tt[hit[0]]) if hit.size else math.inf


def estimate_bias_series(
    pieces: Iterable[NavSamples],
    *,
    site: tuple[float, float, float],
    noise: ImuNoise,
    step_s: float = 1.0,
    align_s: float = 30.0,
    velocity_sd: float = 0.005,
    position_sd: float = 0.05,
    encoder_sd: float = 0.0,
    level_sd: float = 1e-3,
    heading_sd: float = math.radians(5.0),
    rate_error_sd: float = RATE_ERROR_SD,
    rate_error_rw: float = RATE_ERROR_RW,
    move_accel_sd: float = MOVE_ACCEL_SD,
    thermal_sd: tuple[float, float] = THERMAL_SD,
    thermal_rate_sd: tuple[float, float] = THERMAL_RATE_SD,
    thermal_grad_sd: tuple[float, float] = THERMAL_GRAD_SD,
    power_on_sd: tuple[float, float] = POWER_ON_SD,
) -> BiasSeries:
    """Smoothed bias series of a parked cold start (module docstring).

    Parameters
    ----------
    pieces : iterable of NavSamples
        The recording, in time order (SI increments in ``r``, encoder angle required;
        :meth:`rinscal.io.navopen.NavLog.pieces`). The sample interval must be uniform.
    site : (float, float, float)
        Latitude [rad], longitude [rad], height [m] of the parked IMU.
    noise : ImuNoise
        White noise, bias prior (turn-on repeatability) and bias random walk
        (:func:`field_noise`).
    step_s : float [s]
        Filter step and epoch spacing.
    align_s : float [s]
        Length of the coarse alignment at the start. Where the table stands still through
        it (a parked start), the attitude solved is the one at power-on and the epochs start
        at the first sample; otherwise they start after it.
    velocity_sd : float [m/s]
        Zero-velocity measurement noise (each ENU component).
    position_sd : float [m]
        Known-site measurement noise (each coordinate).
    encoder_sd : float [rad]
        Encoder reading noise.
    level_sd, heading_sd : float [rad]
        Prior sd of the tilts and the heading after the coarse alignment.
    rate_error_sd : float [rad/rad]
        Prior sd of each gyro's error per unit of table rate.
    rate_error_rw : float [1/√s]
        Their random walk (they drift with temperature).
    thermal_sd : (float, float) [rad/s/°C, m/s²/°C]
        How far a gyro's and an accelerometer's bias may move per °C of its own
        temperature (1σ): the bias process noise grows with the temperature's change.
    thermal_rate_sd : (float, float) [rad/s per °C/min, m/s² per °C/min]
        And per change of the temperature rate: after power-on the biases move fastest,
        following the rate of the warm-up as much as the temperature.
    thermal_grad_sd : (float, float) [rad/s/°C, m/s²/°C]
        And per °C of change of the gradient ``T − T_out`` (where the outer temperature is
        recorded): the power-on gradient moves the biases most in the first minutes.
    power_on_sd : (float, float) [rad/s, m/s²]
        Prior sd of the gyro and accelerometer biases at power-on, added to the turn-on
        repeatability (:data:`POWER_ON_SD`).
    move_accel_sd : float [m/s²]
        Specific-force error while the table turns that no state holds (the
        accelerometers' size effect, ``ω² ρ`` and ``ω̇ × ρ`` of their lever arms): the
        velocity's process noise over each step of a move.
    """
    lat, lon, alt = (float(v) for v in site)
    if not (math.isfinite(lat) and abs(lat) < 0.5 * math.pi and math.isfinite(lon)):
        raise ConfigError(f"field bias: site must be (lat [rad], lon [rad], h [m]), got {site}")
    for name, v in (("step_s", step_s), ("align_s", align_s)):
        if not (math.isfinite(v) and v > 0):
            raise ConfigError(f"field bias: {name} must be > 0 s, got {v}")
    d = _concat(pieces)
    t_all = d["t"]
    dt = float(np.median(d["dt"]))
    if np.any(np.abs(d["dt"] - dt) > 1e-3 * dt) or np.any(np.diff(t_all) <= 0):
        raise ConfigError("field bias: the sample interval must be uniform (no gaps)")
    n = t_all.size
    n_align = round(align_s / dt)
    n_step = max(1, round(step_s / dt))
    if n_align + 2 * n_step > n:
        raise ConfigError(
            f"field bias: the recording ({n * dt:.0f} s) is shorter than the alignment "
            f"({align_s:g} s) and two steps"
        )
    coarse = InertialCoarseAlign(lat, alt, dt)
    coarse.feed(d["dtheta"][:n_align], d["dv"][:n_align])
    C0 = coarse.solve()
    enc = np.unwrap(d["table"])
    # the table stood still through the coarse window: the attitude solved there is the
    # one at power-on, and the filter starts at the first sample
    i0 = 0 if np.all(enc[:n_align] == enc[0]) else n_align
    tune = _Tuning(
        noise, n_step, velocity_sd, position_sd, encoder_sd, level_sd, rate_error_sd,
        rate_error_rw, move_accel_sd, (thermal_sd, thermal_rate_sd, thermal_grad_sd),
        power_on_sd,
    )  # fmt: skip
    # Pass 1, over the first FIRST_PASS_S: a few seconds of a navigation-grade gyro leave
    # the coarse heading tens of degrees off, where the error model is no longer linear and
    # the first minutes' smoothed tilts (so the horizontal biases) are off by tens of µg.
    # Its smoothed body attitude (constant on a static base) starts pass 2 over the whole
    # recording, within the linear range.
    n1 = min(n, i0 + max(1, round(FIRST_PASS_S / dt)))
    rough = _smoothed(d, enc, dt, (lat, lon, alt), C0, heading_sd, i0, n1, tune)
    C_start = rough.C_nb[-1] @ C_br(enc[max(i0 - 1, 0)])
    up = ATT.start + 2  # the heading error φ_U
    heading_sd2 = max(3.0 * float(np.sqrt(rough.Ps[-1, up, up])), REFINED_HEADING_SD)
    run = _smoothed(d, enc, dt, (lat, lon, alt), C_start, heading_sd2, i0, n, tune)
    t_ep, ends, starts, es, Ps = run.t_ep, run.ends, run.starts, run.es, run.Ps
    b_hat, k_ep, C_nb, dphi, dur = run.b_hat, run.k_ep, run.C_nb, run.dphi, run.dur
    nx = N_STATES + 3
    kk = slice(N_STATES, nx)
    # the horizontal accelerometers' equivalent error on the static base: their bias plus
    # −g k_xy, the tilt the moves leave (with its sd from the joint covariance)
    g = float(earth.gravity(lat, alt))
    L = np.zeros((6, nx))
    L[:, 9:15] = np.eye(6)
    L[3, N_STATES] = L[4, N_STATES + 1] = -g
    bias = b_hat + es[:, 9:15]
    bias[:, 3:5] -= g * (k_ep[:, :2] + es[:, N_STATES : N_STATES + 2])
    var = np.diagonal(Ps, axis1=1, axis2=2)
    sd = np.sqrt(np.maximum(np.einsum("ij,mjk,ik->mi", L, Ps, L), 0.0))
    att = euler_from_C_nb(C_nb)
    P_att = Ps[:, ATT, ATT]
    # heading: φ_U; pitch about the body x, roll about the body y (their horizontal parts)
    bx = C_nb[:, :, 0]
    by = C_nb[:, :, 1]
    att_sd = np.stack(
        [
            np.sqrt(np.maximum(P_att[:, 2, 2], 0.0)),
            np.sqrt(np.maximum(np.einsum("mi,mij,mj->m", bx, P_att, bx), 0.0)),
            np.sqrt(np.maximum(np.einsum("mi,mij,mj->m", by, P_att, by), 0.0)),
        ],
        axis=1,
    )
    temps = _step_means(d["temps"], starts, ends)
    temp_out = _step_means(d["temp_out"][:, None], starts, ends)[:, 0]
    t0 = t_all[0] - dt
    t_full, a_full = np.concatenate([[t0], t_all]), np.concatenate([[enc[0]], enc])
    first = first_period_end(t_full, a_full)
    separable = min(first_reversal_end(t_full, a_full), first)
    rate_error = k_ep + es[:, kk]
    rate_error_sd_s = np.sqrt(np.maximum(var[:, kk], 0.0))
    return BiasSeries(
        t_ep,
        bias,
        sd,
        temps,
        temp_out,
        att,
        att_sd,
        first,
        rate_error,
        rate_error_sd_s,
        dphi / dur,
        separable,
    )


@dataclass(frozen=True)
class _Tuning:
    """The filter's noise and priors (:func:`estimate_bias_series`' parameters, SI)."""

    noise: ImuNoise
    n_step: int
    velocity_sd: float
    position_sd: float
    encoder_sd: float
    level_sd: float
    rate_error_sd: float
    rate_error_rw: float
    move_accel_sd: float
    thermal: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]
    power_on_sd: tuple[float, float]


@dataclass(frozen=True)
class _Pass:
    """One forward filter and backward smoother over samples ``[i0, n_end)``."""

    t_ep: NDArray[np.float64]
    ends: NDArray[np.intp]
    starts: NDArray[np.intp]
    dphi: NDArray[np.float64]
    dur: NDArray[np.float64]
    es: NDArray[np.float64]
    Ps: NDArray[np.float64]
    b_hat: NDArray[np.float64]
    k_ep: NDArray[np.float64]
    C_nb: NDArray[np.float64]


def _smoothed(
    d: dict[str, NDArray[np.float64]],
    enc: NDArray[np.float64],
    dt: float,
    site: tuple[float, float, float],
    C0: NDArray[np.float64],
    heading_sd: float,
    i0: int,
    n_end: int,
    tune: _Tuning,
) -> _Pass:
    """Filter and smooth samples ``[i0, n_end)`` of the recording ``d`` (its unwrapped
    encoder angle ``enc`` [rad], sample interval ``dt`` [s]) from the attitude ``C0``
    (``C_nr``) with the heading prior ``heading_sd`` [rad] (module docstring)."""
    lat, lon, alt = site
    noise = tune.noise
    t_all = d["t"]
    dth, dvv = d["dtheta"], d["dv"]
    P0 = initial_covariance(
        InitialSd(tune.position_sd, tune.velocity_sd, tune.level_sd, heading_sd), noise
    )
    P0[9:15, 9:15] += np.diag(np.repeat(np.square(tune.power_on_sd), 3))
    filt = AidedInertial(Strapdown(lat, lon, alt, np.zeros(3), C0, dt, "free"), P0, noise)
    n_step = tune.n_step
    ends = np.arange(i0 + n_step, n_end + 1, n_step)
    m = ends.size
    t_ep = t_all[ends - 1]
    starts = np.concatenate([[i0], ends[:-1]])
    dphi = enc[ends - 1] - enc[np.maximum(starts - 1, 0)]
    dur = (ends - starts) * dt
    drive = _thermal_drive(d["temps"][:n_end], d["temp_out"][:n_end], dt, ends, tune.thermal)
    zv = ZeroVelocity(t_ep, tune.velocity_sd, horizontal=False)
    kp = KnownPosition(t_ep, lat, lon, alt, tune.position_sd)
    held = BodyHeadingHeld(t_ep, dphi, dur, noise.gyro_noise_density, tune.encoder_sd)

    # each gyro's error per unit of table rate (3 states after the filter's 15): while the
    # table turns at φ̇ a gyro reads k φ̇ more (z: its scale-factor error; x, y: their
    # misalignment towards the table axis), which turns (z) and tilts (x, y) the platform
    # by k Δφ each move. On one axis a tilt left by the moves is exactly an accelerometer
    # bias −g k_xy: the filter carries both, and the series reports their sum (below).
    nx = N_STATES + 3
    kk = slice(N_STATES, nx)
    dphi_s = np.diff(enc, prepend=enc[0])  # encoder change over each sample [rad]
    P = np.zeros((nx, nx))
    P[:N_STATES, :N_STATES] = filt.P
    P[kk, kk] = tune.rate_error_sd**2 * np.eye(3)
    k_hat = np.zeros(3)
    Pp = np.empty((m, nx, nx))
    Pm = np.empty((m, nx, nx))
    Phi = np.empty((m, nx, nx))
    xp = np.empty((m, nx))
    b_hat = np.empty((m, 6))
    k_ep = np.empty((m, 3))
    C_nr = np.empty((m, 3, 3))
    x0 = np.zeros(nx)
    i = i0
    for k, e in enumerate(ends):
        rate = float(dphi[k]) / float(dur[k])  # mean table rate over the step [rad/s]
        P15 = P[:N_STATES, :N_STATES].copy()
        filt.P = P15.copy()
        ph = filt.propagate(dth[i:e] - np.outer(dphi_s[i:e], k_hat), dvv[i:e])
        i = int(e)
        Q15 = filt.P - ph @ P15 @ ph.T
        A = np.eye(nx)
        A[:N_STATES, :N_STATES] = ph
        # k φ̇ acts over the step as a gyro bias would on position, velocity and attitude
        # (Φ's gyro-bias columns), but it is not the bias state: those rows stay zero
        A[:N_STATES, kk] = ph[:, GYRO] * rate
        A[GYRO, kk] = 0.0
        P = A @ P @ A.T
        P[:N_STATES, :N_STATES] += Q15
        P[kk, kk] += tune.rate_error_rw**2 * float(dur[k]) * np.eye(3)
        P[9:15, 9:15] += np.diag(drive[k])  # the biases move with the temperatures
        if rate != 0.0:  # the accelerometers' lever arms while the table turns, unmodelled
            P[VEL, VEL] += (tune.move_accel_sd * float(dur[k])) ** 2 * np.eye(3)
        Phi[k] = A
        Pm[k] = P
        st = filt.state(float(t_ep[k]))
        lins = [zv.linearise(k, st), kp.linearise(k, st), held.linearise(k, st)]
        H = np.vstack([v.H for v in lins])
        HA = np.zeros((H.shape[0], nx))
        HA[:, :N_STATES] = H
        HA[:, kk] = H[:, GYRO] * rate
        lin = Linearised(
            np.concatenate([v.residual for v in lins]), HA, block_diag(*(v.R for v in lins))
        )
        P, x, _ = kalman_update(P, x0, lin)
        filt.feed_back(x[:N_STATES])
        k_hat = k_hat + x[kk]
        Pp[k] = P
        xp[k] = x
        b_hat[k, :3] = filt.gyro_bias
        b_hat[k, 3:] = filt.accel_bias
        k_ep[k] = k_hat
        C_nr[k] = filt.nav.C_nr

    es, Ps = _rts(Pp, Pm, Phi, xp)
    # the horizontal accelerometers' equivalent error on the static base: their bias plus
    # −g k_xy, the tilt the moves leave (with its sd from the joint covariance)

    es, Ps = _rts(Pp, Pm, Phi, xp)
    # smoothed attitude: C_true = (I + [φ×]) C̃ (φ the smoothed error left in C̃)
    C_s = np.einsum("mij,mjk->mik", np.eye(3) + _skew_rows(es[:, ATT]), C_nr)
    C_nb = np.einsum("mij,mkj->mik", C_s, C_br(enc[ends - 1]))
    return _Pass(t_ep, ends, starts, dphi, dur, es, Ps, b_hat, k_ep, C_nb)


def _skew_rows(v: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.zeros((v.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


def _thermal_drive(
    temps: NDArray[np.float64],
    temp_out: NDArray[np.float64],
    dt: float,
    ends: NDArray[np.intp],
    sds: tuple[tuple[float, float], tuple[float, float], tuple[float, float]],
) -> NDArray[np.float64]:
    """Bias process noise each step adds for the change of its sensor's temperature, its
    temperature rate and its gradient to the outside, (m, 6) [variance].

    With ``T`` the temperature averaged over :data:`THERMAL_WINDOW_S`, ``Ṫ`` [°C/min] its
    change over that window and ``G = T − T_out`` likewise averaged, a step adds
    ``((σ_T ΔT)² + (σ_Ṫ ΔṪ)² + (σ_G ΔG)²) · N`` with ``N`` the steps in a window: a warm-up
    moves a bias the same way over a whole window, not by independent steps, so over a
    window the bias may move by ``σ`` times the change (not ``1/√N`` of it). ``sds``: the
    (gyro, accelerometer) sds per °C, per °C/min and per °C of gradient. Zero where the
    recording has no temperature; no gradient term where it has no outer temperature.
    """
    w = max(1, round(THERMAL_WINDOW_S / dt))

    def cumulative(a: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([np.zeros((1, a.shape[1])), np.cumsum(np.nan_to_num(a), axis=0)])

    def smooth(c: NDArray[np.float64], at: NDArray[np.intp]) -> NDArray[np.float64]:
        """Mean over the window ending at sample ``at`` (shorter at the start), from the
        cumulative sum ``c`` of the series."""
        lo = np.maximum(at + 1 - w, 0)
        return (c[at + 1] - c[lo]) / (at + 1 - lo)[:, None]

    def change(a: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.diff(a, axis=0, prepend=a[:1])

    c_temps = cumulative(temps)
    at = smooth(c_temps, ends - 1)
    rate = (at - smooth(c_temps, np.maximum(ends - 1 - w, 0))) / (THERMAL_WINDOW_S / 60.0)
    st, rt, gt = (np.repeat(v, 3) for v in sds)
    out = (st * change(at)) ** 2 + (rt * change(rate)) ** 2
    if np.all(np.isfinite(temp_out)):
        out += (gt * change(smooth(cumulative(temps - temp_out[:, None]), ends - 1))) ** 2
    steps = float(np.median(np.diff(ends))) if ends.size > 1 else 1.0
    out *= max(THERMAL_WINDOW_S / (dt * steps), 1.0)
    out[:, ~np.all(np.isfinite(temps), axis=0)] = 0.0
    return out


def _step_means(a: NDArray[np.float64], starts: NDArray, ends: NDArray) -> NDArray[np.float64]:
    c = np.concatenate([np.zeros((1, a.shape[1])), np.cumsum(a, axis=0)])
    return (c[ends] - c[starts]) / (ends - starts)[:, None]


def _rts(
    Pp: NDArray[np.float64], Pm: NDArray[np.float64], Phi: NDArray[np.float64], xp: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Fixed-interval smoother over a closed-loop filter (module docstring): the smoothed
    errors relative to each fed-back solution and their covariances."""
    m = Pp.shape[0]
    es = np.zeros((m, Pp.shape[1]))
    Ps = np.empty_like(Pp)
    Ps[-1] = Pp[-1]
    if m > 1:
        # A_k = P⁺_k Φ_{k+1}ᵀ (P⁻_{k+1})⁻¹  (P⁻ symmetric: solve for A_kᵀ)
        A = np.transpose(np.linalg.solve(Pm[1:], Phi[1:] @ Pp[:-1]), (0, 2, 1))
        for k in range(m - 2, -1, -1):
            es[k] = A[k] @ (es[k + 1] + xp[k + 1])
            Ps[k] = Pp[k] + A[k] @ (Ps[k + 1] - Pm[k + 1]) @ A[k].T
    return es, Ps


__all__ = [
    "WARM_UP_S",
    "BiasSeries",
    "estimate_bias_series",
    "field_noise",
    "first_period_end",
    "first_reversal_end",
]
